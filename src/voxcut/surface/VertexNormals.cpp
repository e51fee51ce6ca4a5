#include "voxcut/surface/VertexNormals.h"

namespace voxcut {

std::vector<Vec3d> vertexNormals(const std::vector<Vec3d>& V,
                                 const std::vector<std::array<int, 3>>& F, const Vec3d& isolated) {
  std::vector<Vec3d> N(V.size(), Vec3d::Zero());
  for (const auto& t : F) {
    const Vec3d n = (V[t[1]] - V[t[0]]).cross(V[t[2]] - V[t[0]]);
    for (int k = 0; k < 3; ++k) N[t[k]] += n;
  }
  for (Vec3d& n : N) {
    const double length = n.norm();
    n = length > 0 ? Vec3d(n / length) : isolated;
  }
  return N;
}

}  // namespace voxcut
