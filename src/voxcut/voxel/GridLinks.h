#pragma once
/// @file GridLinks.h
/// The links of a linked voxel grid from its materials, shared by the voxelizer (meshes) and
/// the label resampler (volumes): links between two voxels of one material are connected;
/// between two materials, connected and carrying Hermite data (an interface); between
/// material and empty, disconnected with Hermite data (docs/algorithms.md, "Linked voxel
/// model").

#include <cstddef>
#include <functional>

#include "voxcut/core/Types.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// The Hermite data of the link from voxel `c` along axis `a`, whose low end holds material
/// `m0` and high end `m1` (m0 != m1, one of them possibly 0). Called concurrently from several
/// threads (one z slice each): must be thread-safe.
using LinkHermiteFn = std::function<Hermite(const Index3& c, int a, std::uint8_t m0,
                                            std::uint8_t m1)>;

/// Clears the materials of the grid's six boundary planes (the padding stays empty).
void clearPadding(VoxelGrid& grid);

/// Writes every voxel's link bits from the materials and inserts the Hermite data of every
/// link between different materials, from `hermiteOf`. Entries go into the table in link
/// order of z slices, so the table is the same for any thread count.
void buildLinks(VoxelGrid& grid, const LinkHermiteFn& hermiteOf, bool threaded);

}  // namespace voxcut
