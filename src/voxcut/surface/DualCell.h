#pragma once
/// @file DualCell.h
/// A dual cell is the cube whose 8 corners are voxel centres (min corner (x,y,z)); its 12
/// edges are links. Its occupied corners, joined by its connected links, fall into
/// components; the surface crossing it falls into patches (one dual-contouring vertex each).
/// The components are also the level-0 case of the deformation octree's node rule
/// (docs/algorithms.md, "Element copies and the node rule").
///
/// Numbering: corner c = bx + 2*by + 4*bz. Edge e = 4*a + ou + 2*ow runs along axis a from the
/// corner with offset 0 to offset 1 along a, with offsets ou along u = (a+1)%3 and ow along
/// w = (a+2)%3. An incidence slot 2*e + side is edge e seen from its corner at `side` (0 = low).

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Occupancy and connectivity of one dual cell.
struct DualCell {
  std::uint8_t occupied = 0;    ///< bit c: corner c holds material
  std::uint16_t connected = 0;  ///< bit e: edge e is a connected link

  /// Whether some edge is disconnected and has an occupied end (the cell holds surface).
  [[nodiscard]] bool hasSurface() const;
};

/// Corner at `side` (0 low, 1 high) of edge e.
[[nodiscard]] int edgeCorner(int edge, int side);
/// Offset (0/1) of corner c along axis a.
[[nodiscard]] inline int cornerBit(int corner, int a) {
  return (corner >> a) & 1;
}

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

/// The cell across face f of the cell with min corner `m` in `grid` (for dualCellPatches).
/// Borrows `grid`; the result must not outlive it.
[[nodiscard]] NeighbourCell gridNeighbour(const VoxelGrid& grid, const Index3& m);

// ---- Pieces of dual contouring shared by dualContour and ContouredSurface ------------------
// Both must produce bit-identical vertices and triangles, so each step is written once here.

/// Dual-contouring vertices of one cell: one per surface patch, sealed links' excepted.
struct DualCellVertices {
  std::array<std::int8_t, 24> patch{};    ///< patch of each incidence slot, -1 for none or sealed
  int count = 0;                          ///< number of patches (at most 12)
  std::array<Vec3d, 12> position;         ///< per patch: rest-frame position (metres)
  std::array<std::uint64_t, 12> voxel{};  ///< per patch: lowest material voxel of its incidences
};

/// Whether link (v, a) is *sealed*: cut with material on both sides, and on each of the 4
/// faces around it (those between consecutive cells of cellsAroundLink) the surface joins its
/// two incidences to each other, so that in each of its 4 cells the patch of its two
/// incidences holds nothing else. Both its sheets would then use the same 4 vertices: a
/// closed surface of zero volume that no deformation can open. A sealed link has no sheets
/// and its patches no vertices (docs/algorithms.md, "Sealed links"). Reads only the 4 cells
/// around the link (the ring rule on those faces reads nothing else). False for a link
/// without both voxels inside the grid's interior. Thread-safe (reads `grid` only).
[[nodiscard]] bool isSealedLink(const VoxelGrid& grid, std::size_t v, int a);

/// Drops from `patch`, the `count` patches of the cell with min corner `m`, the patches of
/// sealed links (isSealedLink), setting their slots to -1 and renumbering the others, still in
/// order of their lowest slot. Returns the new count. Thread-safe (reads `grid` only).
int dropSealedPatches(const VoxelGrid& grid, const Index3& m, std::array<std::int8_t, 24>& patch,
                      int count);

/// Patches of the cell with min corner `m` (all 8 corners inside `grid`), less those of sealed
/// links (dropSealedPatches), and one vertex each: the QEF minimiser of the patch's Hermite
/// planes (points and outward normals of its incidences), solved in cell coordinates (cell
/// size 1) as x = c + (AᵀA)⁺(Aᵀb − AᵀA c) with c the mass point and eigenvalues below
/// `qefThreshold` x the largest dropped; c when x leaves the cell by more than 1e-9.
/// `segments`, when given, receives the face segments (sealed links' included);
/// `neighbourFaces`, when given, bit f set for each face f whose neighbour cell the ring rule
/// read (the patches can change when that neighbour does). Thread-safe (reads `grid` only).
[[nodiscard]] DualCellVertices dualCellVertices(const VoxelGrid& grid, const Index3& m,
                                                double qefThreshold,
                                                std::array<FaceSegments, 6>* segments = nullptr,
                                                std::uint8_t* neighbourFaces = nullptr);

/// The 4 cells around link (v, a), counter-clockwise about +a: min corners v − e_u − e_w,
/// v − e_w, v, v − e_u (u = (a+1)%3, w = (a+2)%3), as voxel indices, and the link's edge number
/// in each. The caller checks that the cells lie inside the grid.
void cellsAroundLink(const VoxelGrid& grid, std::size_t v, int a, std::array<std::size_t, 4>& cells,
                     std::array<int, 4>& edges);

/// The face between cells k and k+1 (mod 4) of cellsAroundLink: it is the +`axis` face of cell
/// `lower` (an index 0..3 into those cells).
struct LinkFace {
  int lower;
  int axis;
};
[[nodiscard]] LinkFace linkFace(int a, int k);

/// Key of incidence `slot` on the +a face of cell `cell` (a voxel index), unique per grid.
[[nodiscard]] inline std::uint64_t faceSlotKey(std::size_t cell, int a, int slot) {
  return (static_cast<std::uint64_t>(cell) * 3 + static_cast<std::uint64_t>(a)) * 24 +
         static_cast<std::uint64_t>(slot);
}

/// The slot of the same incidence seen from the cell across the +a face (slot on that face).
[[nodiscard]] int slotAcross(int slot, int a);

/// Two surface segments of one face can join the same two patches (one in each cell); their
/// dual edges would coincide and carry four triangles. Each such segment but the first gets a
/// split vertex, at the middle of the two cells' vertices, owned by the lower cell's voxel.
/// Lists those segments of the +a face of a cell with patches `lower`, whose neighbour across
/// the face has patches `upper`; `fs` are the lower cell's segments on that face. Returns the
/// count; out[i] = {segment's two slots (lower cell), lower patch, upper patch}. Segments of a
/// sealed link (patch -1) are skipped: they carry no surface.
struct DoubledSegment {
  std::array<std::int8_t, 2> slots;
  int lowerPatch;
  int upperPatch;
};
int doubledSegments(const FaceSegments& fs, int a, const std::array<std::int8_t, 24>& lower,
                    const std::array<std::int8_t, 24>& upper, std::array<DoubledSegment, 4>& out);

/// Vertices around one disconnected link: for each side s (0: the low voxel v, 1: v + e_a)
/// that holds material (and neither when the link is sealed), the vertex of the side's patch in
/// each cell of cellsAroundLink, and the split vertex on the face between cells k and k+1, or -1.
struct LinkRing {
  std::array<bool, 2> sheet{};
  std::array<std::array<int, 4>, 2> vertex{};
  std::array<std::array<int, 4>, 2> split{};
};

/// The surface of one side of a link: two triangles of the quad, or (when the ring has split
/// vertices) a polygon to fan around its centre (polygonCentre) with triangles
/// (polygon[i], polygon[i+1], centre). Counter-clockwise seen from outside the side's material.
struct LinkSheet {
  int triangleCount = 0;
  std::array<std::array<int, 3>, 2> triangles{};
  int polygonSize = 0;
  std::array<int, 8> polygon{};
};

/// Triangulates both sheets of a link: a quad is split along the diagonal whose two triangles
/// bend least (ties to cells 0-2); when both sheets would share the vertices of that diagonal
/// (a crack front) the high side takes the other one. `positions` are indexed by vertex id.
void triangulateLink(const LinkRing& ring, const std::vector<Vec3d>& positions,
                     std::array<LinkSheet, 2>& out);

/// Centre of a split polygon: the mean of its vertices, summed in polygon order.
[[nodiscard]] Vec3d polygonCentre(const LinkSheet& sheet, const std::vector<Vec3d>& positions);

}  // namespace voxcut
