#pragma once
// Closed components of a surface and what they enclose: for tests that look for degenerate
// pieces of surface (zero volume, all vertices at one point, inside out).

#include <algorithm>
#include <cstddef>
#include <numeric>
#include <vector>

#include "voxcut/surface/SurfaceMesh.h"

namespace voxcut::test {

/// One connected component of a surface (through shared vertices).
struct SurfaceComponent {
  std::size_t triangles = 0;
  std::size_t vertices = 0;
  double volume = 0.0;  ///< signed enclosed volume in voxels^3 (positive: encloses material)
  double extent = 0.0;  ///< largest distance of a vertex from the first one, in voxels
  std::size_t firstVertex = 0;
};

/// Components of `m`, whose positions are in metres on a grid of voxel edge `h`. The volume
/// is the divergence theorem's sum over triangles, taken about each component's first vertex
/// so that a flat component comes out zero to rounding.
inline std::vector<SurfaceComponent> surfaceComponents(const SurfaceMesh& m, double h) {
  const std::size_t nv = m.positions.size();
  std::vector<std::size_t> parent(nv);
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  auto find = [&](std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  std::vector<char> used(nv, 0);
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) {
      used[static_cast<std::size_t>(t[k])] = 1;
      const std::size_t a = find(static_cast<std::size_t>(t[k]));
      const std::size_t b = find(static_cast<std::size_t>(t[(k + 1) % 3]));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<std::ptrdiff_t> label(nv, -1);
  std::vector<SurfaceComponent> out;
  for (std::size_t v = 0; v < nv; ++v) {
    if (!used[v]) continue;
    const std::size_t r = find(v);
    if (label[r] < 0) {
      label[r] = static_cast<std::ptrdiff_t>(out.size());
      out.push_back({});
      out.back().firstVertex = v;
    }
    SurfaceComponent& c = out[static_cast<std::size_t>(label[r])];
    ++c.vertices;
    c.extent = std::max(c.extent, (m.positions[v] - m.positions[c.firstVertex]).norm() / h);
  }
  for (const auto& t : m.triangles) {
    SurfaceComponent& c =
        out[static_cast<std::size_t>(label[find(static_cast<std::size_t>(t[0]))])];
    const Vec3d& o = m.positions[c.firstVertex];
    const Vec3d p0 = (m.positions[static_cast<std::size_t>(t[0])] - o) / h;
    const Vec3d p1 = (m.positions[static_cast<std::size_t>(t[1])] - o) / h;
    const Vec3d p2 = (m.positions[static_cast<std::size_t>(t[2])] - o) / h;
    c.volume += p0.dot(p1.cross(p2)) / 6.0;
    ++c.triangles;
  }
  return out;
}

}  // namespace voxcut::test
