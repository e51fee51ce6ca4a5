#pragma once
/// @file FaceCrossings.h
/// Where a triangle mesh passes through itself: the faces that another face meets. A mesh
/// obstacle (collision/MeshDistance.h) takes the inside and outside next to a face from that
/// face's two sides only where no other face meets it, since a face that another one crosses
/// has more than one region on each side.
///
/// Thread-safety: pure functions (crossedFaces runs in parallel inside).

#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/core/TriangleMesh.h"

namespace voxcut {

/// Whether the closed segment pq and the non-degenerate closed triangle abc share a point,
/// decided with exact orientation predicates (core/Predicates.h); a segment in the triangle's
/// plane is tested in the projection along the normal's largest axis.
[[nodiscard]] bool segmentMeetsTriangle(const Vec3d& p, const Vec3d& q, const Vec3d& a,
                                        const Vec3d& b, const Vec3d& c);

/// Per face of `mesh` (#F; non-degenerate faces, as repairMesh leaves them), 1 where a face
/// that shares no vertex index with it meets it (crosses it, touches it, or overlaps it in
/// its plane: two triangles meet where an edge of one meets the other), 0 elsewhere. Faces sharing
/// a vertex are not compared, so a fold between neighbours goes unseen. Candidate pairs come from a
/// sweep over the faces' bounding boxes along x; O(F log F + pairs whose boxes overlap) time.
/// Deterministic for any thread count.
[[nodiscard]] std::vector<std::uint8_t> crossedFaces(const TriangleMesh& mesh);

}  // namespace voxcut
