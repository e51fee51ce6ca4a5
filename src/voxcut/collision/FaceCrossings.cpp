#include "voxcut/collision/FaceCrossings.h"

#include <algorithm>
#include <numeric>

#include "voxcut/core/Parallel.h"
#include "voxcut/core/Predicates.h"

namespace voxcut {
namespace {

struct FaceBox {
  Vec3d lo, hi;
};

bool overlap(const FaceBox& s, const FaceBox& t) {
  return (s.lo.array() <= t.hi.array()).all() && (t.lo.array() <= s.hi.array()).all();
}

/// Whether r, collinear with the segment pq, lies on it.
bool onSegment(const Vec2d& p, const Vec2d& q, const Vec2d& r) {
  return (r.array() >= p.cwiseMin(q).array()).all() && (r.array() <= p.cwiseMax(q).array()).all();
}

/// Whether the closed segments pq and uv share a point (exact).
bool segmentsMeet(const Vec2d& p, const Vec2d& q, const Vec2d& u, const Vec2d& v) {
  const int d1 = orient2d(p, q, u), d2 = orient2d(p, q, v);
  const int d3 = orient2d(u, v, p), d4 = orient2d(u, v, q);
  if (d1 * d2 < 0 && d3 * d4 < 0) return true;
  return (d1 == 0 && onSegment(p, q, u)) || (d2 == 0 && onSegment(p, q, v)) ||
         (d3 == 0 && onSegment(u, v, p)) || (d4 == 0 && onSegment(u, v, q));
}

/// Whether the closed segment pq and the closed triangle abc, all in one plane, share a point:
/// exact, in the projection along the axis the triangle's normal is largest on.
bool coplanarSegmentMeetsTriangle(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b,
                                  const Vec3d& c) {
  int drop = 0;
  (b - a).cross(c - a).cwiseAbs().maxCoeff(&drop);
  const int u = (drop + 1) % 3, v = (drop + 2) % 3;
  const auto flat = [&](const Vec3d& x) { return Vec2d(x[u], x[v]); };
  const Vec2d p2 = flat(p), q2 = flat(q), a2 = flat(a), b2 = flat(b), c2 = flat(c);
  const int turn = orient2d(a2, b2, c2);
  if (turn == 0) return true;  // a projection the rounded normal got wrong: say they may meet
  const auto inside = [&](const Vec2d& x) {
    return orient2d(a2, b2, x) * turn >= 0 && orient2d(b2, c2, x) * turn >= 0 &&
           orient2d(c2, a2, x) * turn >= 0;
  };
  return inside(p2) || inside(q2) || segmentsMeet(p2, q2, a2, b2) || segmentsMeet(p2, q2, b2, c2) ||
         segmentsMeet(p2, q2, c2, a2);
}

}  // namespace

bool segmentMeetsTriangle(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b,
                          const Vec3d& c) {
  const int sp = orient3d(a, b, c, p), sq = orient3d(a, b, c, q);
  if (sp == sq && sp != 0) return false;  // both ends strictly on one side of the plane
  if (sp == 0 && sq == 0) return coplanarSegmentMeetsTriangle(p, q, a, b, c);
  // The segment reaches the plane: it meets the triangle where the line pq passes on the same
  // side of all three edges (or on one of them).
  const int e0 = orient3d(p, q, a, b), e1 = orient3d(p, q, b, c), e2 = orient3d(p, q, c, a);
  const bool positive = e0 > 0 || e1 > 0 || e2 > 0, negative = e0 < 0 || e1 < 0 || e2 < 0;
  return !(positive && negative);
}

std::vector<std::uint8_t> crossedFaces(const TriangleMesh& mesh) {
  const std::size_t n = mesh.faces.size();
  std::vector<FaceBox> boxes(n);
  for (std::size_t f = 0; f < n; ++f) {
    const auto& [i, j, k] = mesh.faces[f];
    const Vec3d &a = mesh.vertices[i], &b = mesh.vertices[j], &c = mesh.vertices[k];
    boxes[f] = {a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c)};
  }
  // Faces by the low end of their boxes along x: the faces whose boxes overlap f's along x are
  // a run before and after f in this order, cut off by the widest box.
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t s, std::uint32_t t) {
    return boxes[s].lo.x() < boxes[t].lo.x() || (boxes[s].lo.x() == boxes[t].lo.x() && s < t);
  });
  double widest = 0.0;
  for (const FaceBox& box : boxes) widest = std::max(widest, box.hi.x() - box.lo.x());

  const auto meets = [&](std::size_t s, std::size_t t) {
    const auto& fs = mesh.faces[s];
    const auto& ft = mesh.faces[t];
    for (int u = 0; u < 3; ++u)
      for (int v = 0; v < 3; ++v)
        if (fs[u] == ft[v]) return false;  // neighbours: they share a corner
    const auto corner = [&](const std::array<int, 3>& f, int u) -> const Vec3d& {
      return mesh.vertices[f[u]];
    };
    for (int u = 0; u < 3; ++u) {
      if (segmentMeetsTriangle(corner(fs, u), corner(fs, (u + 1) % 3), corner(ft, 0), corner(ft, 1),
                               corner(ft, 2)) ||
          segmentMeetsTriangle(corner(ft, u), corner(ft, (u + 1) % 3), corner(fs, 0), corner(fs, 1),
                               corner(fs, 2)))
        return true;
    }
    return false;
  };

  std::vector<std::uint8_t> crossed(n, 0);
  parallelFor(0, n, 256, [&](std::size_t lo, std::size_t hi) {
    for (std::size_t k = lo; k < hi; ++k) {
      const std::uint32_t f = order[k];
      const FaceBox& box = boxes[f];
      bool found = false;
      for (std::size_t m = k + 1; !found && m < n && boxes[order[m]].lo.x() <= box.hi.x(); ++m)
        found = overlap(box, boxes[order[m]]) && meets(f, order[m]);
      for (std::size_t m = k; !found && m-- > 0 && boxes[order[m]].lo.x() >= box.lo.x() - widest;)
        found = overlap(box, boxes[order[m]]) && meets(f, order[m]);
      crossed[f] = found ? 1 : 0;
    }
  });
  return crossed;
}

}  // namespace voxcut
