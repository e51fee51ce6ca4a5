#pragma once
/// @file TriangleClosestPoint.h
/// The point of a triangle nearest a query point: the kernel of mesh distances
/// (collision/MeshDistance.h). Units: any, consistently (metres in voxcut).
///
/// Thread-safety: a pure function.

#include "voxcut/core/Types.h"

namespace voxcut {

/// The point of the closed triangle abc (its interior and its three edges) nearest `p`: the
/// orthogonal projection of p onto the triangle's plane when that falls inside the triangle,
/// else the nearest point of its three edges (each a segment clamped at its ends). A
/// degenerate triangle (collinear corners, repeated corners) is treated as its edges only, so
/// it comes back as the nearest point of a segment or the point itself, never NaN; the result
/// is finite whenever the inputs are.
[[nodiscard]] Vec3d closestPointOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                           const Vec3d& c);

}  // namespace voxcut
