#pragma once
// A surface up to the order of its vertices and triangles, to compare an updated surface with
// a full rebuild.

#include <algorithm>
#include <array>
#include <cstdint>
#include <tuple>
#include <vector>

#include "voxcut/surface/SurfaceMesh.h"

namespace voxcut::test {

/// A vertex as its exact position and voxel.
using VertexKey = std::tuple<double, double, double, std::uint64_t>;

/// Vertices as keys, triangles as their vertices' keys rotated so that the smallest comes
/// first (orientation kept); both sorted.
struct Canonical {
  std::vector<VertexKey> vertices;
  std::vector<std::array<VertexKey, 3>> triangles;
  bool operator==(const Canonical&) const = default;
};

inline Canonical canonical(const SurfaceMesh& m) {
  Canonical c;
  auto key = [&](int v) {
    const Vec3d& p = m.positions[static_cast<std::size_t>(v)];
    return VertexKey{p[0], p[1], p[2], m.vertexVoxel[static_cast<std::size_t>(v)]};
  };
  for (std::size_t v = 0; v < m.positions.size(); ++v)
    c.vertices.push_back(key(static_cast<int>(v)));
  for (const auto& t : m.triangles) {
    std::array<VertexKey, 3> k = {key(t[0]), key(t[1]), key(t[2])};
    std::rotate(k.begin(), std::min_element(k.begin(), k.end()), k.end());
    c.triangles.push_back(k);
  }
  std::sort(c.vertices.begin(), c.vertices.end());
  std::sort(c.triangles.begin(), c.triangles.end());
  return c;
}

}  // namespace voxcut::test
