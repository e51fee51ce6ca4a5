#pragma once
/// @file Fragments.h
/// Small fragments left by a frame's cuts. A blade of zero thickness that crosses material
/// moving under it (a flapping part, the strip of sweeps from the carried blade front;
/// sim/BladeFront.h) can cut every link around a voxel or two: debris that no user asked for,
/// that the deformation must still carry (an element copy of one voxel), and that adds to the
/// piece count. healSmallFragments undoes the fewest of this frame's cuts that keep every such
/// fragment attached.
///
/// Rule: for each endpoint voxel of this frame's cut links (links ascending, lower voxel
/// first), while the voxels connected to it number fewer than `minVoxels`, the lowest-id link
/// of this frame's cuts with exactly one voxel in that fragment is reconnected and gets back
/// the Hermite data it had before the cut (an interface's) or none. Fragments that were
/// already apart before this frame are left alone, and so is a fragment that no link of this
/// frame bounds. Deterministic (no dependence on threads).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "voxcut/voxel/LinkCut.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Applies the rule above to `grid` after `cuts` (this frame's, sorted by link id, already
/// applied to the grid); removes the reconnected links from `cuts` and returns their ids,
/// ascending. minVoxels <= 1 does nothing.
std::vector<std::uint64_t> healSmallFragments(VoxelGrid& grid, std::vector<LinkCut>& cuts,
                                              std::size_t minVoxels);

}  // namespace voxcut
