#pragma once
/// @file ModelBuild.h
/// The path from material meshes or a label volume to a linked voxel model and its surface: voxelize, apply
/// planar cuts, dual-contour, count pieces, with the time of each stage. What `voxcut info`
/// and `voxcut surface` run; a library function so that every front end gets the same thing.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "voxcut/core/Timer.h"
#include "voxcut/octree/VoxelOctree.h"
#include "voxcut/sim/MemoryEstimate.h"
#include "voxcut/surface/SurfaceMesh.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/voxel/Model.h"
#include "voxcut/voxel/PlaneCut.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {

/// Settings of buildModel.
struct ModelBuildParams {
  VoxelizeParams voxelize;
  std::vector<Plane> cuts;
  OctreeParams octree;  ///< empty: max internal level 4, boundary level 0
  DeformationOctreeParams deformation;
  bool octrees = true;  ///< build both octrees to report them
  bool threaded = true;
  /// Refuse (InputError) when the memory estimate (MemoryEstimate.h) exceeds this many bytes;
  /// 0: no limit.
  std::size_t maxMemory = 0;
};

/// Counts describing a voxel model and its surface.
struct ModelStats {
  std::vector<std::pair<std::string, std::size_t>> voxelsPerMaterial;
  std::size_t voxels = 0;
  std::size_t connectedLinks = 0;
  std::size_t surfaceLinks = 0;    ///< disconnected, material on one side only
  std::size_t cutLinks = 0;        ///< disconnected, material on both sides
  std::size_t interfaceLinks = 0;  ///< connected, two different materials
  int pieces = 0;                  ///< connected voxel components
  SurfaceTopology topology;
  std::size_t bytes = 0;                          ///< memory held by the voxel grid
  std::vector<std::size_t> octreeCubes;           ///< voxel octree cubes, level 1 up
  std::size_t activeVoxels = 0, activeLinks = 0;  ///< marked by the voxel octree
  std::vector<std::size_t> deformationElements;   ///< per level, level 0 up
  std::vector<std::size_t> deformationNodes;      ///< per level (finest adjacent element)
  std::size_t hangingNodes = 0;
};

/// A built model.
struct ModelBuild {
  VoxelGrid grid;
  SurfaceMesh surface;
  ModelStats stats;
  VoxelizeReport voxelizeReport;        ///< for meshes
  LabelResampleReport resampleReport;   ///< for a label volume
  std::shared_ptr<const LabelVolume> volume;  ///< the label volume built from, if any
  StageTimings timings;   ///< voxelize (or resample), cut, contour, pieces, topology, octrees (ms)
  MemoryEstimate memory;  ///< the estimate made before building
};

/// Counts links by kind and voxels by material. Deterministic.
[[nodiscard]] ModelStats countModel(const VoxelGrid& grid, bool threaded = true);

/// Runs the whole path. First estimates the memory it will take (estimateModelMemory) and
/// refuses with InputError when that exceeds params.maxMemory. Throws InputError on bad input
/// (see voxelize, cutWithPlane) and Interrupted when the progress callback asks to stop.
[[nodiscard]] ModelBuild buildModel(const Model& model, const ModelBuildParams& params);

/// estimateModelMemory of the model's meshes or of its label volume with its chosen labels.
[[nodiscard]] MemoryEstimate estimateModelMemory(const Model& model,
                                                 const MemoryEstimateParams& params);

}  // namespace voxcut
