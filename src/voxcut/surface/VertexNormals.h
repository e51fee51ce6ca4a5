#pragma once
/// @file VertexNormals.h
/// Area-weighted per-vertex normals of a triangle surface. Pure; safe to call concurrently.

#include <array>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

/// Unit normal of every vertex: the normalised sum of the (unnormalised) cross products
/// (V[b] - V[a]) x (V[c] - V[a]) of the triangles {a, b, c} that use it, so each triangle
/// weighs by twice its area.
///
/// V: #V positions. F: #F triangles, vertex indices into V, counter-clockwise seen from the
/// side the normals point to. Returns #V unit normals; a vertex that no triangle of non-zero
/// area touches gets `isolated` (zero by default). O(#V + #F).
[[nodiscard]] std::vector<Vec3d> vertexNormals(const std::vector<Vec3d>& V,
                                               const std::vector<std::array<int, 3>>& F,
                                               const Vec3d& isolated = Vec3d::Zero());

}  // namespace voxcut
