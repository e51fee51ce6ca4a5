#pragma once
// Small FEM test bodies shared by the fem tests: hand-filled grids, composite materials.

#include <Eigen/Core>
#include <cmath>
#include <random>
#include <vector>

#include "voxcut/fem/ElasticModel.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut::test {

/// Random 3-vectors with entries in [-1, 1], one per row.
inline std::vector<Vec3d> randomVector(std::size_t rows, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3d> r(rows);
  for (Vec3d& v : r) v = Vec3d(u(rng), u(rng), u(rng));
  return r;
}

/// The 3-vectors one after the other, as one vector.
inline Eigen::VectorXd flat(const std::vector<Vec3d>& v) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(3 * v.size()));
  for (std::size_t i = 0; i < v.size(); ++i)
    out.segment<3>(3 * static_cast<Eigen::Index>(i)) = v[i];
  return out;
}

/// A grid filled by `material(x, y, z)` (0 = empty), links between occupied voxels connected.
template <class Fn>
inline VoxelGrid makeGrid(const Index3& dims, double h, Fn&& material) {
  VoxelGrid g(dims, Vec3d(0.05, -0.1, 0.2), h);
  for (int z = 0; z < dims.z; ++z)
    for (int y = 0; y < dims.y; ++y)
      for (int x = 0; x < dims.x; ++x)
        g.setMaterial(g.index(x, y, z), static_cast<std::uint8_t>(material(x, y, z)));
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a)
      g.setConnected(v, a, g.occupied(v) && g.hasLink(v, a) && g.occupied(v + g.stride(a)));
  return g;
}

inline DeformationOctree makeOctree(const VoxelGrid& g, int start, int max, bool merge = true) {
  DeformationOctreeParams p;
  p.startLevel = start;
  p.maxLevel = max;
  p.merge = merge;
  return buildDeformationOctree(g, p);
}

/// Three materials with one Poisson ratio and different E and density.
inline std::vector<ElasticMaterial> layeredMaterials(double nu) {
  std::vector<ElasticMaterial> m(4);
  m[1] = {1e5, nu, 1000.0, 0.0, 0.0};
  m[2] = {7e5, nu, 1500.0, 0.0, 0.0};
  m[3] = {3e4, nu, 800.0, 0.0, 0.0};
  return m;
}

/// A composite, partly filled box with hanging nodes: materials vary with x and z only, a
/// tunnel along y; y spans [0, 32), aligned to every element level.
inline VoxelGrid compositeBox() {
  return makeGrid({24, 34, 22}, 0.002, [](int x, int y, int z) {
    if (x >= 21 || z >= 19 || y >= 32) return 0;
    if (x >= 9 && x < 11 && z >= 13 && z < 16) return 0;  // a tunnel along y
    if (z < 5) return 1;
    return (x + 2 * z) % 7 < 3 ? 2 : 3;
  });
}

/// A small composite body with hanging nodes and partly filled elements for the dynamics.
struct Body {
  VoxelGrid grid;
  DeformationOctree octree;
  ElasticModel model;
};

inline Body smallBody(double alpha, double beta) {
  Body b;
  b.grid = makeGrid({12, 17, 10}, 0.004, [](int x, int y, int z) {
    if (x >= 11 || y >= 16 || z >= 9) return 0;
    if (x >= 9 && y < 3) return 0;
    return z < 3 ? 1 : (x + y) % 5 < 2 ? 2 : 3;
  });
  b.octree = makeOctree(b.grid, 1, 2);
  auto mats = layeredMaterials(0.35);
  for (std::size_t m = 1; m < mats.size(); ++m) {
    mats[m].dampingMass = alpha;
    mats[m].dampingStiffness = beta * static_cast<double>(m);
  }
  b.model = ElasticModel(b.octree, b.grid, mats);
  return b;
}

/// A fixed SPD system on a body's reduced sparsity: P^T K P (rest stiffness) scaled by 1e-5
/// plus 1e-3 on the diagonal, densely and as one 3x3 block per slot.
struct BlockSystem {
  Eigen::MatrixXd dense;
  std::vector<Eigen::Matrix3d> blocks;
};

inline BlockSystem restBlockSystem(const ElasticModel& model) {
  const BlockSparsity& sp = model.sparsity();
  const Eigen::SparseMatrix<double> p = prolongationMatrix(model);
  BlockSystem out;
  out.dense = Eigen::MatrixXd(p.transpose() * restStiffnessMatrix(model) * p) * 1e-5;
  for (Eigen::Index i = 0; i < out.dense.rows(); ++i) out.dense(i, i) += 1e-3;
  out.blocks.resize(sp.blockCount());
  for (std::size_t i = 0; i + 1 < sp.rowStart.size(); ++i)
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s)
      out.blocks[s] = out.dense.block<3, 3>(3 * static_cast<Eigen::Index>(i), 3 * sp.column[s]);
  return out;
}

/// smallBody(0, 0) with node 0 fixed: a reduced sparsity with hanging and fixed nodes.
inline Body smallBodyWithAFixedNode() {
  Body b = smallBody(0.0, 0.0);
  std::vector<std::uint8_t> fixed(b.octree.nodeCount(), 0);
  fixed.at(0) = 1;
  b.model.setFixed(fixed);
  return b;
}

/// Smooth perturbation of the nodes (metres) except those flagged in `keep`; hanging nodes
/// then follow their masters.
inline void perturb(DeformationOctree& oc, double amplitude,
                    const std::vector<std::uint8_t>& keep = {}) {
  for (std::size_t n = 0; n < oc.nodeCount(); ++n) {
    const Vec3d& x = oc.restPositions()[n];
    if (n < keep.size() && keep[n]) {
      oc.positions()[n] = x;
      continue;
    }
    oc.positions()[n] = x + amplitude * Vec3d(std::sin(40 * x.y() + 1), std::cos(30 * x.z()),
                                              std::sin(50 * x.x() - 2 * x.y()));
  }
  oc.updateHangingNodes();
}

}  // namespace voxcut::test
