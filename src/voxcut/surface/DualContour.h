#pragma once
/// @file DualContour.h
/// Dual contouring of all disconnected links of a linked voxel grid (docs/algorithms.md,
/// "Dual contouring with cuts").
///
/// Each dual cell gets one vertex per surface patch (dualCellPatches), placed by a QEF over the
/// Hermite data of the patch's incidences, solved in cell coordinates with eigenvalues below
/// `qefThreshold` x the largest dropped (so degenerate directions fall back to the mass point)
/// and replaced by the mass point when the solution leaves the cell. Each disconnected link
/// gives one quad per side that holds material, through the 4 cells around it, wound so its
/// normal points out of that side's material; a cut link thus gives two coincident sheets of
/// opposite winding. Quads are split along the diagonal whose two triangles bend least.
/// A *sealed* link (isSealedLink: cut, yet on all 4 faces around it the surface joins its two
/// incidences to each other) has no sheets and its patches no vertices: both sheets would use
/// the same 4 vertices, a closed surface of zero volume that can never open. Every edge of
/// such a pair of sheets is used by the pair alone, so dropping it keeps the rest closed.
/// The result is closed and 2-manifold whatever the link states.

#include "voxcut/surface/SurfaceMesh.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Dual contouring settings.
struct DualContourParams {
  double qefThreshold = 0.1;  ///< relative eigenvalue cut-off of the QEF pseudo-inverse
  bool threaded = true;
};

/// Contours `grid`; positions are in the rest frame (metres). Deterministic for any thread count.
[[nodiscard]] SurfaceMesh dualContour(const VoxelGrid& grid, const DualContourParams& params = {});

}  // namespace voxcut
