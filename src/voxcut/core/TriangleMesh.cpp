#include "voxcut/core/TriangleMesh.h"

#include <limits>

namespace voxcut {

std::array<Vec3d, 2> TriangleMesh::bounds() const {
  const double inf = std::numeric_limits<double>::infinity();
  Vec3d lo(inf, inf, inf), hi(-inf, -inf, -inf);
  for (const auto& f : faces)
    for (int k = 0; k < 3; ++k) {
      lo = lo.cwiseMin(vertices[f[k]]);
      hi = hi.cwiseMax(vertices[f[k]]);
    }
  return {lo, hi};
}

double TriangleMesh::signedVolume() const {
  // Relative to the bounds centre to keep the sum well conditioned.
  const auto [lo, hi] = bounds();
  const Vec3d c = 0.5 * (lo + hi);
  double v = 0.0;
  for (const auto& f : faces) {
    const Vec3d a = vertices[f[0]] - c, b = vertices[f[1]] - c, d = vertices[f[2]] - c;
    v += a.dot(b.cross(d));
  }
  return v / 6.0;
}

}  // namespace voxcut
