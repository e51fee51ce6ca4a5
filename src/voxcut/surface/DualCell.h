#pragma once
/// @file DualCell.h
/// A dual cell is the cube whose 8 corners are voxel centres (min corner (x,y,z)); its 12
/// edges are links. Its occupied corners, joined by its connected links, fall into
/// components; the surface crossing it falls into patches (one dual-contouring vertex each).
/// Both serve the surface now and node duplication of the deformation octree later.
///
/// Numbering: corner c = bx + 2*by + 4*bz. Edge e = 4*a + ou + 2*ow runs along axis a from the
/// corner with offset 0 to offset 1 along a, with offsets ou along u = (a+1)%3 and ow along
/// w = (a+2)%3. An incidence slot 2*e + side is edge e seen from its corner at `side` (0 = low).

#include <array>
#include <cstdint>
#include <functional>

#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Occupancy and connectivity of one dual cell.
struct DualCell {
  std::uint8_t occupied = 0;     ///< bit c: corner c holds material
  std::uint16_t connected = 0;   ///< bit e: edge e is a connected link

  /// Whether some edge is disconnected and has an occupied end (the cell holds surface).
  [[nodiscard]] bool hasSurface() const;
};

/// Corner at `side` (0 low, 1 high) of edge e.
[[nodiscard]] int edgeCorner(int edge, int side);
/// Offset (0/1) of corner c along axis a.
[[nodiscard]] inline int cornerBit(int corner, int a) { return (corner >> a) & 1; }

/// Reads the cell with min corner `m` from the grid (all 8 corners must be inside the grid).
[[nodiscard]] DualCell gatherDualCell(const VoxelGrid& grid, const Index3& m);

/// Components of occupied corners joined by connected edges: comp[c] = 0..n-1, or -1 for an
/// empty corner. Returns n. Components are numbered in order of their lowest corner.
int dualCellComponents(const DualCell& cell, std::array<std::int8_t, 8>& comp);

/// The cell across face f = 2*a + s (s = 0: the -a side, 1: the +a side); an empty cell when
/// it lies outside the grid.
using NeighbourCell = std::function<DualCell(int face)>;

/// Surface patches: patch[slot] = 0..n-1 for every incidence (a disconnected edge seen from an
/// occupied end), -1 otherwise. On each face, the surface joins the two incidences that bound a
/// run of occupied corners joined by connected face edges, so two incidences share a patch
/// when a chain of such joins links them; each patch is then one disk of surface, and the two
/// cells sharing a face agree because the rule reads only that face. One exception keeps the
/// contour free of doubled edges: when a face has exactly two runs and they are connected
/// through the cell on each side of it (a ring of voxels around the face centre), the surface
/// joins the end of each run to the start of the other instead. `neighbour` supplies the cell
/// across a face for that test (only called for such faces). Returns n; patches are numbered
/// in order of their lowest slot.
/// Surface segments on one face of a dual cell: each joins two incidence slots.
struct FaceSegments {
  int count = 0;
  std::array<std::array<std::int8_t, 2>, 4> slots{};
};

int dualCellPatches(const DualCell& cell, std::array<std::int8_t, 24>& patch,
                    const NeighbourCell& neighbour,
                    std::array<FaceSegments, 6>* segments = nullptr);

}  // namespace voxcut
