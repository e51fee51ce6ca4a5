#pragma once
/// @file FemCases.h
/// The bodies the deformation benchmarks step (bench_fem, bench_step_parts): the bunny at a
/// resolution, its base fixed, under gravity, and the scaling case of docs/performance.md,
/// "Deformation solver at scale".

#include <Eigen/SparseCore>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEuler.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/topology/CutTopology.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut::bench {

/// A body ready to step: grid, octree, model and the solver settings of its scene.
struct FemCase {
  VoxelGrid grid;
  DeformationOctree octree;
  ElasticModel model;
  ImplicitEulerParams params;
};

inline VoxelGrid voxelGrid(const std::string& spec, int resolution) {
  VoxelizeParams vp;
  vp.resolution.resolution = resolution;
  return voxelize(loadModel(spec).materials, vp);
}

/// Fixes the nodes whose rest position lies in [lo, hi].
inline void fixBox(FemCase& c, const Vec3d& lo, const Vec3d& hi) {
  std::vector<std::uint8_t> fixed(c.octree.nodeCount(), 0);
  for (std::size_t n = 0; n < fixed.size(); ++n) {
    const Vec3d& x = c.octree.restPositions()[n];
    fixed[n] = (x.array() >= lo.array()).all() && (x.array() <= hi.array()).all() ? 1 : 0;
  }
  c.model.setFixed(std::move(fixed));
}

/// The connected y-links that the blade of scenes/bunny-ear.json crosses over its sweep: the
/// segment x in [-0.044, 0.012] m at height 0.129 m, moved along z from 0.025 to -0.025 m.
inline std::vector<std::uint64_t> earCutLinks(const VoxelGrid& g) {
  std::vector<std::uint64_t> links;
  const double h = g.voxelSize();
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    if (!g.hasLink(v, 1) || !g.connected(v, 1)) continue;
    const Vec3d p = g.position(v);
    if (p.y() < 0.129 && p.y() + h >= 0.129 && p.x() >= -0.044 && p.x() <= 0.012 &&
        p.z() >= -0.025 && p.z() <= 0.025)
      links.push_back(VoxelGrid::linkId(v, 1));
  }
  return links;
}

/// The bunny at `resolution` of `material` (the deformation octree's levels, its defaults
/// unless given), its ear cut off first when `cut`, base fixed, under gravity; the caller sets
/// the step.
inline FemCase bunnyBody(int resolution, const ElasticMaterial& material, bool cut,
                         int startLevel = DeformationOctreeParams{}.startLevel,
                         int maxLevel = DeformationOctreeParams{}.maxLevel) {
  FemCase c;
  c.grid = voxelGrid("bunny", resolution);
  DeformationOctreeParams dp;
  dp.startLevel = startLevel;
  dp.maxLevel = maxLevel;
  c.octree = buildDeformationOctree(c.grid, dp);
  if (cut) {
    const std::vector<std::uint64_t> links = earCutLinks(c.grid);
    for (std::uint64_t id : links)
      c.grid.setConnected(static_cast<std::size_t>(id / 3), static_cast<int>(id % 3), false);
    (void)updateCutTopology(c.octree, c.grid, links);
  }
  std::vector<ElasticMaterial> mats(2);
  mats[1] = material;
  c.model = ElasticModel(c.octree, c.grid, mats);
  fixBox(c, Vec3d(-0.1, -0.02, -0.1), Vec3d(0.1, 0.004, 0.1));
  c.params.gravity = Vec3d(0, -9.81, 0);
  return c;
}

/// The 3x3 blocks of the reduced matrix `a` (ImplicitEuler::reducedMatrix) in the slot order of
/// `sp`, its sparsity: the blocks a BlockMatrixView or a block factor of `sp` reads.
inline std::vector<Eigen::Matrix3d> reducedBlocks(const BlockSparsity& sp,
                                                  const Eigen::SparseMatrix<double>& a) {
  std::vector<Eigen::Matrix3d> blocks(sp.blockCount());
  for (std::size_t i = 0; i + 1 < sp.rowStart.size(); ++i)
    for (std::uint32_t slot = sp.rowStart[i]; slot < sp.rowStart[i + 1]; ++slot)
      blocks[slot] = a.block(3 * static_cast<Eigen::Index>(i),
                             3 * static_cast<Eigen::Index>(sp.column[slot]), 3, 3);
  return blocks;
}

/// The scaling case of docs/performance.md, "Deformation solver at scale": the bunny at
/// `resolution`, base fixed, E 1e5 Pa, nu 0.3, rho 1000, Rayleigh damping [0.1, 0.01], dt
/// 10 ms, relative tolerance 1e-6; element level 3 (the deformation octree's defaults).
inline FemCase scalingCase(int resolution) {
  FemCase c = bunnyBody(resolution, {1e5, 0.3, 1000.0, 0.1, 0.01}, false);
  c.params.timeStep = 0.01;
  c.params.tolerance = 1e-6;
  c.params.maxIterations = 2000;
  return c;
}

}  // namespace voxcut::bench
