#include "voxcut/collision/TriangleClosestPoint.h"

#include <algorithm>
#include <limits>

namespace voxcut {
namespace {

/// The point of the segment from `a` along `d` (a + t d, t in [0, 1]) nearest p; a when d = 0.
Vec3d closestOnSegment(const Vec3d& p, const Vec3d& a, const Vec3d& d) {
  const double dd = d.squaredNorm();
  if (!(dd > 0.0)) return a;
  return a + std::clamp((p - a).dot(d) / dd, 0.0, 1.0) * d;
}

}  // namespace

Vec3d closestPointOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const Vec3d n = ab.cross(ac);
  const double nn = n.squaredNorm();
  // Barycentric coordinates of the projection of p onto the plane, p' = a + s ab + t ac:
  // (ap x ac) . n = s (ab x ac) . n = s |n|^2, and likewise for t. On a sliver the quotients
  // may be huge or NaN; every comparison below is then false and all three edges decide.
  double s = 0.0, t = 0.0;
  if (nn > 0.0) {
    s = ap.cross(ac).dot(n) / nn;
    t = ab.cross(ap).dot(n) / nn;
    if (s >= 0.0 && t >= 0.0 && s + t <= 1.0) return a + s * ab + t * ac;
  }
  // Outside: the nearest point is on an edge whose line separates p' from the triangle (its
  // opposite coordinate is negative); degenerate: on any edge.
  const bool any = !(nn > 0.0) || !(s < 0.0 || t < 0.0 || s + t > 1.0);
  Vec3d best = a;
  double best2 = std::numeric_limits<double>::infinity();
  const auto tryEdge = [&](bool use, const Vec3d& from, const Vec3d& d) {
    if (!use && !any) return;
    const Vec3d q = closestOnSegment(p, from, d);
    const double d2 = (p - q).squaredNorm();
    if (d2 < best2) {
      best2 = d2;
      best = q;
    }
  };
  tryEdge(t < 0.0, a, ab);         // t = 0: the edge ab
  tryEdge(s + t > 1.0, b, c - b);  // the edge bc
  tryEdge(s < 0.0, c, a - c);      // s = 0: the edge ca
  return best;
}

}  // namespace voxcut
