#pragma once
/// @file SceneBodies.h
/// The voxel grids of a scene's bodies: each body's model loaded (loadBodyModel: built-in or
/// mesh file, offset applied, material names checked) and voxelized at its resolution. What
/// `voxcut run` and the scene tests hand to Simulation.

#include <vector>

#include "voxcut/core/Progress.h"
#include "voxcut/sim/Scene.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Voxelizes every body of `scene`, in order (grids[i] for scene.bodies[i], world frame).
/// Throws InputError naming the body's key path for a model that cannot be loaded, unknown
/// material names, a resolution the voxelizer refuses, or a model that voxelizes to no voxels
/// (requireVoxels, e.g. "scene.json: bodies[1] (model '/data/plate.obj'): voxelizes to no
/// voxels at resolution 101 ..."). Deterministic for any thread count.
[[nodiscard]] std::vector<VoxelGrid> voxelizeSceneBodies(const Scene& scene, bool threaded = true,
                                                         const ProgressCallback& progress = {});

}  // namespace voxcut
