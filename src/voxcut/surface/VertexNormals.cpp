#include "voxcut/surface/VertexNormals.h"

namespace voxcut {

void vertexNormals(std::span<const Vec3d> V, std::span<const std::array<int, 3>> F,
                   std::vector<Vec3d>& N, const Vec3d& isolated) {
  N.assign(V.size(), Vec3d::Zero());
  for (const std::array<int, 3>& t : F) {
    if (t[0] < 0) continue;
    const Vec3d& p0 = V[static_cast<std::size_t>(t[0])];
    const Vec3d n = (V[static_cast<std::size_t>(t[1])] - p0).cross(V[static_cast<std::size_t>(t[2])] - p0);
    for (const int k : t) N[static_cast<std::size_t>(k)] += n;
  }
  for (Vec3d& n : N) {
    const double length = n.norm();
    n = length > 0.0 ? Vec3d(n / length) : isolated;
  }
}

}  // namespace voxcut
