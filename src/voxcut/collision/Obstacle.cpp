#include "voxcut/collision/Obstacle.h"

#include <algorithm>
#include <cmath>

#include "voxcut/core/Error.h"

namespace voxcut {

Obstacle meshObstacle(const TriangleMesh& mesh) {
  Obstacle o;
  o.type = ObstacleType::Mesh;
  o.mesh = std::make_shared<const MeshDistance>(mesh);
  return o;
}

double signedDistance(const Obstacle& o, const Vec3d& x, Vec3d& normal, double maxDistance) {
  if (o.type == ObstacleType::Mesh) {
    VOXCUT_ASSERT(o.mesh != nullptr, "a mesh obstacle needs its MeshDistance (meshObstacle)");
    return o.mesh->signedDistance(x, normal, maxDistance);
  }
  if (o.type == ObstacleType::Plane) {
    normal = o.normal;
    return o.normal.dot(x - o.point);
  }
  // Box: per axis, the distance outside the slab (positive) or the depth inside it.
  const Vec3d centre = 0.5 * (o.lo + o.hi), half = 0.5 * (o.hi - o.lo);
  const Vec3d rel = x - centre;
  Vec3d q;
  for (int a = 0; a < 3; ++a) q[a] = std::abs(rel[a]) - half[a];
  if (q.maxCoeff() > 0.0) {
    Vec3d out = Vec3d::Zero();
    for (int a = 0; a < 3; ++a)
      if (q[a] > 0.0) out[a] = rel[a] < 0.0 ? -q[a] : q[a];
    const double d = out.norm();
    normal = out / d;
    return d;
  }
  int axis = 0;
  for (int a = 1; a < 3; ++a)
    if (q[a] > q[axis]) axis = a;
  normal = Vec3d::Zero();
  normal[axis] = rel[axis] < 0.0 ? -1.0 : 1.0;
  return q[axis];
}

double signedDistance(const Capsule& capsule, const Vec3d& x, Vec3d& normal) {
  const Vec3d axis = capsule.b - capsule.a;
  const double len2 = axis.squaredNorm();
  double s = 0.0;
  if (len2 > 0.0) s = std::clamp((x - capsule.a).dot(axis) / len2, 0.0, 1.0);
  const Vec3d nearest = capsule.a + s * axis;
  const Vec3d rel = x - nearest;
  const double dist = rel.norm();
  if (dist > 0.0) {
    normal = rel / dist;
  } else {
    // On the segment: any direction perpendicular to it is as near; take the one closest to +y.
    const Vec3d up = Vec3d::UnitY();
    normal = len2 > 0.0 ? up - up.dot(axis) / len2 * axis : up;
    if (normal.squaredNorm() < 1e-24) normal = Vec3d::UnitX() - axis.x() / len2 * axis;
    normal.normalize();
  }
  return dist - capsule.radius;
}

}  // namespace voxcut
