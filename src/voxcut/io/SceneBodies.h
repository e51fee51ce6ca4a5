#pragma once
/// @file SceneBodies.h
/// The voxel grids of a scene's bodies: each body's model loaded (loadBodyModel: built-in or
/// mesh file, offset applied, material names checked) and voxelized at its resolution. What
/// `voxcut run` and the scene tests hand to World::fromScene.

#include <cstddef>
#include <vector>

#include "voxcut/core/Progress.h"
#include "voxcut/sim/Scene.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Settings of voxelizeSceneBodies.
struct SceneBodiesParams {
  bool threaded = true;
  ProgressCallback progress;  ///< progress and interruption of the voxelizer, optional
  /// Refuse (InputError) when the memory the simulation of the bodies is estimated to need
  /// (sim/MemoryEstimate.h, summed over the bodies) exceeds this many bytes; 0: no limit.
  std::size_t maxMemory = 0;
  bool useOctree = true;  ///< as the simulation will run (the baseline keeps more per voxel)
};

/// Voxelizes every body of `scene`, in order (grids[i] for scene.bodies[i], world frame).
/// Every body's model is loaded and the memory check made before any is voxelized.
/// Throws InputError naming the body's key path for a model that cannot be loaded, unknown
/// material names, a resolution the voxelizer refuses, or a model that voxelizes to no voxels
/// (requireVoxels, e.g. "scene.json: bodies[1] (model '/data/plate.obj'): voxelizes to no
/// voxels at resolution 101 ..."), and naming the largest body when the memory estimate
/// exceeds the limit; Interrupted when the progress callback asks to stop. Deterministic for
/// any thread count.
[[nodiscard]] std::vector<VoxelGrid> voxelizeSceneBodies(const Scene& scene,
                                                         const SceneBodiesParams& params);

/// The same with no memory limit.
[[nodiscard]] std::vector<VoxelGrid> voxelizeSceneBodies(const Scene& scene, bool threaded = true,
                                                         const ProgressCallback& progress = {});

}  // namespace voxcut
