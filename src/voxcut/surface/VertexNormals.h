#pragma once
/// @file VertexNormals.h
/// Area-weighted per-vertex normals of a triangle surface: the one kernel every reader of a
/// surface's normals uses (the world's surface views and meshes, the contoured and dual
/// contoured surfaces). Pure; safe to call concurrently.

#include <array>
#include <span>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

/// Unit normal of every vertex: the normalised sum of the (unnormalised) cross products
/// (V[b] - V[a]) x (V[c] - V[a]) of the triangles {a, b, c} that use it, in the triangles'
/// order, so each triangle weighs by twice its area.
///
/// V: #V positions. F: #F triangles, vertex indices into V, counter-clockwise seen from the
/// side the normals point to; a triangle whose first index is negative is a dead slot and is
/// skipped. Writes #V unit normals into N (resized); a vertex that no triangle of non-zero area
/// touches gets `isolated` (zero by default). O(#V + #F).
void vertexNormals(std::span<const Vec3d> V, std::span<const std::array<int, 3>> F,
                   std::vector<Vec3d>& N, const Vec3d& isolated = Vec3d::Zero());

/// The same, returned.
[[nodiscard]] inline std::vector<Vec3d> vertexNormals(std::span<const Vec3d> V,
                                                      std::span<const std::array<int, 3>> F,
                                                      const Vec3d& isolated = Vec3d::Zero()) {
  std::vector<Vec3d> N;
  vertexNormals(V, F, N, isolated);
  return N;
}

}  // namespace voxcut
