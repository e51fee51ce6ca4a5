#pragma once
/// @file LinkCut.h
/// A link of the voxel grid that a blade crossed, with the Hermite data the cut gives it, and
/// how a batch of cuts is written into the grid's Hermite table.

#include <cstdint>
#include <optional>

#include "voxcut/voxel/HermiteMap.h"

namespace voxcut {

/// A link the blade crossed, with its Hermite data in the rest frame.
struct LinkCut {
  std::uint64_t link = 0;  ///< link id 3 * voxel + axis (VoxelGrid::linkId)
  Hermite hermite;
  /// The link's Hermite data before the cut replaced it (a material interface), if any; set
  /// when the cut is applied, so that the cut can be undone (cutting/Fragments.h).
  std::optional<Hermite> previous;
};

/// Sets the Hermite data of the cuts [first, last) in `hermite`, each LinkCut::previous taking
/// the entry it replaced (the table's slots fetched ahead: they are scattered). Not
/// thread-safe: it writes the table.
void storeHermite(HermiteMap& hermite, LinkCut* first, LinkCut* last);

}  // namespace voxcut
