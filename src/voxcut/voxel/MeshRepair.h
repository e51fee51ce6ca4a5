#pragma once
/// @file MeshRepair.h
/// Cleans an imperfect triangle mesh before voxelizing: welds coincident vertices, drops
/// degenerate and duplicate faces, and makes the orientation consistent per connected patch
/// (docs/algorithms.md, "Mesh repair").

#include "voxcut/core/TriangleMesh.h"

namespace voxcut {

/// What repairMesh found and did.
struct RepairReport {
  int weldedVertices = 0;    ///< vertices merged into an identical earlier one
  int degenerateFaces = 0;   ///< faces dropped for a repeated vertex or exactly collinear corners
  int duplicateFaces = 0;    ///< faces dropped for using the same three vertices as another
  int flippedFaces = 0;      ///< faces whose winding was reversed to agree with their patch
  int boundaryEdges = 0;     ///< edges with one face (holes)
  int nonManifoldEdges = 0;  ///< edges with three or more faces
  /// Closed and consistently oriented: every edge has exactly two faces, used in opposite
  /// directions. Then the crossing-count winding number is exact.
  bool watertight = false;
};

/// Returns the repaired mesh; coordinates must be finite. Degenerate faces (zero area: a
/// repeated vertex, or corners that are exactly collinear, decided by exact predicates) are
/// dropped, so the result may have no face at all, which the caller must reject (voxelize
/// throws InputError naming the mesh). Orientation: faces are flipped to agree with their
/// neighbours across manifold edges; each connected patch then keeps the orientation of the
/// (area-weighted) majority of its original faces, so a few flipped faces are fixed while a
/// deliberately inverted shell (a cavity) stays inverted.
[[nodiscard]] TriangleMesh repairMesh(const TriangleMesh& in, RepairReport* report = nullptr);

}  // namespace voxcut
