#include "voxcut/cutting/Blade.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "voxcut/core/CoordinateRange.h"
#include "voxcut/core/Error.h"

namespace voxcut {
namespace {

// Symbolic key groups: voxels (segment endpoints) rank before blade corners, so a voxel on
// the blade's plane is decided by its own displacement (see Blade.h).
constexpr std::uint64_t kVoxelGroup = 0;
constexpr std::uint64_t kBladeGroup = 1;

constexpr double kMinT = 1e-6;
constexpr double kMaxT = 1.0 - 1e-6;

// Relative size of the allowances for rounding in the box tests (the computations err by a
// few units of 2^-53 relative to the coordinates' magnitude).
constexpr double kRelativeSlack = 1e-12;

/// Unit normal (q - p) x (r - p), or nullopt when the triangle is degenerate to working
/// precision (sine of its angle at p below 1e-12).
std::optional<Vec3d> triangleNormal(const Vec3d& p, const Vec3d& q, const Vec3d& r) {
  const Vec3d u = q - p, v = r - p;
  const Vec3d n = u.cross(v);
  const double len = n.norm();
  if (!(len > 1e-12 * u.norm() * v.norm()) || !std::isfinite(len)) return std::nullopt;
  return n / len;
}

Vec3d perpendicularTo(const Vec3d& d) {
  if (d.squaredNorm() > 0.0 && d.allFinite()) return d.unitOrthogonal();
  return Vec3d::UnitZ();
}

}  // namespace

BladeSweep makeSweep(const BladePose& from, const BladePose& to, std::uint64_t frame) {
  VOXCUT_ASSERT(frame < (std::uint64_t{1} << 62), "makeSweep: frame index too large");
  return makeSweep(from, to, {2 * frame, 2 * frame + 1, 2 * frame + 3, 2 * frame + 2}, frame);
}

BladeSweep makeSweep(const BladePose& from, const BladePose& to,
                     const std::array<std::uint64_t, 4>& ids, std::uint64_t frame) {
  VOXCUT_ASSERT(ids[0] != ids[1] && ids[0] != ids[2] && ids[0] != ids[3] && ids[1] != ids[2] &&
                    ids[1] != ids[3] && ids[2] != ids[3],
                "makeSweep: the corners' ids must be distinct");
  // The predicates are exact only for coordinates of comparable scale (core/Predicates.h);
  // readers and the command line hold input to half this range.
  VOXCUT_ASSERT(isKernelCoordinate(from.a) && isKernelCoordinate(from.b) &&
                    isKernelCoordinate(to.a) && isKernelCoordinate(to.b),
                "makeSweep: a blade corner outside the coordinate range (|x| <= 2e6 m)");
  BladeSweep s;
  s.frame = frame;
  s.corners = {from.a, from.b, to.b, to.a};
  s.ids = ids;
  std::array<std::optional<Vec3d>, 2> n;
  for (int t = 0; t < 2; ++t) {
    const auto& idx = BladeSweep::kTriangles[t];
    const Vec3d& p = s.corners[idx[0]];
    const Vec3d& q = s.corners[idx[1]];
    const Vec3d& r = s.corners[idx[2]];
    s.bounds[t] = Eigen::AlignedBox3d(p);
    s.bounds[t].extend(q);
    s.bounds[t].extend(r);
    s.planes[t] = OrientPlane(p, q, r);
    // With the voxel's key below the corners', the perturbed orientation of a voxel on the
    // plane is decided by the voxel's own displacement and the triangle's projections alone,
    // unless all projections are degenerate; evaluate it once with a stand-in voxel at p.
    const auto proj = [&](int i, int j) {
      return orient2d(Vec2d(p[i], p[j]), Vec2d(q[i], q[j]), Vec2d(r[i], r[j]));
    };
    if (proj(0, 1) != 0 || proj(0, 2) != 0 || proj(1, 2) != 0) {
      s.onPlaneSide[t] =
          orient3dSoS(p, q, r, p, SymbolicKey{kBladeGroup, s.ids[idx[0]]},
                      SymbolicKey{kBladeGroup, s.ids[idx[1]]},
                      SymbolicKey{kBladeGroup, s.ids[idx[2]]}, SymbolicKey{kVoxelGroup, 0});
    }
    n[t] = triangleNormal(p, q, r);
  }
  // Flat: the four corners coplanar, and the triangles (c0, c1, c2), (c0, c2, c3) turning the
  // same way in a coordinate plane where the first does not degenerate (a projection that
  // keeps the plane's orientations, up to one sign for both), so c1 and c3 lie on either side
  // of the diagonal c0-c2. All exact.
  if (orient3d(s.corners[0], s.corners[1], s.corners[2], s.corners[3]) == 0) {
    for (int i = 0; i < 3 && !s.flat; ++i) {
      const int j = (i + 1) % 3;
      const auto proj = [&](int k) { return Vec2d(s.corners[k][i], s.corners[k][j]); };
      const int first = orient2d(proj(0), proj(1), proj(2));
      if (first == 0) continue;
      s.flat = orient2d(proj(0), proj(2), proj(3)) == first;
      break;
    }
  }
  const Vec3d blade =
      (from.b - from.a).squaredNorm() > 0.0 ? Vec3d(from.b - from.a) : Vec3d(to.b - to.a);
  for (int t = 0; t < 2; ++t) {
    s.normals[t] = n[t] ? *n[t] : (n[1 - t] ? *n[1 - t] : perpendicularTo(blade));
  }
  return s;
}

namespace {

/// Whether the segment's box and the triangle's box are separated by a positive gap. Exact;
/// such boxes stay separated under the infinitesimal perturbation, so rejecting on this never
/// changes a decision.
inline bool boxesSeparated(const Eigen::AlignedBox3d& box, const Vec3d& p0, const Vec3d& p1) {
  return std::max(p0.x(), p1.x()) < box.min().x() || std::min(p0.x(), p1.x()) > box.max().x() ||
         std::max(p0.y(), p1.y()) < box.min().y() || std::min(p0.y(), p1.y()) > box.max().y() ||
         std::max(p0.z(), p1.z()) < box.min().z() || std::min(p0.z(), p1.z()) > box.max().z();
}

/// The exact sign of orient3d(a, b, c, p) for triangle `triangle` = (a, b, c) of the sweep,
/// filter first: 0 when p lies exactly on its plane.
int planeSide(const BladeSweep& sweep, int triangle, const Vec3d& p) {
  const int f = sweep.planes[triangle].filter(p);
  if (f != 0) return f;
  const auto& idx = BladeSweep::kTriangles[triangle];
  return orient3d(sweep.corners[idx[0]], sweep.corners[idx[1]], sweep.corners[idx[2]], p);
}

/// orient3d(p0, p1, x, y), never 0 (perturbed where it is), from u = p1 - p0, wx = x - p0 and
/// wy = y - p0, filter first.
int lineEdgeSide(const Vec3d& p0, const Vec3d& p1, const Vec3d& x, const Vec3d& y, const Vec3d& u,
                 const Vec3d& wx, const Vec3d& wy, const SymbolicKey& k0, const SymbolicKey& k1,
                 const SymbolicKey& kx, const SymbolicKey& ky) {
  const int f = orient3dFilter(u, wx, wy);
  return f != 0 ? f : orient3dSoS(p0, p1, x, y, k0, k1, kx, ky);
}

/// The exact crossing decision of intersectTriangle (see Blade.h), filters first, for
/// segments whose box meets the triangle's.
bool crosses(const BladeSweep& sweep, int triangle, const Vec3d& p0, const Vec3d& p1,
             std::uint64_t id0, std::uint64_t id1) {
  const auto& idx = BladeSweep::kTriangles[triangle];
  const Vec3d& a = sweep.corners[idx[0]];
  const Vec3d& b = sweep.corners[idx[1]];
  const Vec3d& c = sweep.corners[idx[2]];
  const SymbolicKey ka{kBladeGroup, sweep.ids[idx[0]]};
  const SymbolicKey kb{kBladeGroup, sweep.ids[idx[1]]};
  const SymbolicKey kc{kBladeGroup, sweep.ids[idx[2]]};
  const SymbolicKey k0{kVoxelGroup, id0};
  const SymbolicKey k1{kVoxelGroup, id1};

  // The ends must lie strictly on opposite sides of the plane (never 0 under perturbation).
  const auto side = [&](const Vec3d& p, const SymbolicKey& kp) {
    const int exact = planeSide(sweep, triangle, p);
    if (exact != 0) return exact;
    const int onPlane = sweep.onPlaneSide[triangle];
    return onPlane != 0 ? onPlane : orient3dSoS(a, b, c, p, ka, kb, kc, kp);
  };
  if (side(p0, k0) == side(p1, k1)) return false;

  // The line p0 p1 must pass on the same side of the three directed edges:
  // orient3d(p0, p1, x, y) = det[p1 - p0, x - p0, y - p0].
  const Vec3d u = p1 - p0, wa = a - p0, wb = b - p0, wc = c - p0;
  const auto edge = [&](const Vec3d& wx, const Vec3d& wy, const Vec3d& x, const Vec3d& y,
                        const SymbolicKey& kx, const SymbolicKey& ky) {
    return lineEdgeSide(p0, p1, x, y, u, wx, wy, k0, k1, kx, ky);
  };
  const int e0 = edge(wa, wb, a, b, ka, kb);
  return edge(wb, wc, b, c, kb, kc) == e0 && edge(wc, wa, c, a, kc, ka) == e0;
}

/// The hit record of a decided crossing: t in floating point against the triangle's plane.
SweepHit hitOf(const BladeSweep& sweep, int triangle, const Vec3d& p0, const Vec3d& p1) {
  SweepHit hit;
  hit.triangle = triangle;
  hit.normal = sweep.normals[triangle];
  const Vec3d& a = sweep.corners[BladeSweep::kTriangles[triangle][0]];
  const double d0 = hit.normal.dot(p0 - a);
  const double d1 = hit.normal.dot(p1 - a);
  double t = 0.5;
  if (d0 != d1) {
    t = d0 / (d0 - d1);
    if (!std::isfinite(t)) t = 0.5;
  }
  hit.t = std::clamp(t, kMinT, kMaxT);
  return hit;
}

constexpr int kNoTriangle = -1;
constexpr int kUndecided = -2;

/// crosses() for both triangles of a flat sweep at once: the triangle the segment crosses,
/// kNoTriangle, or kUndecided when an end lies exactly on the plane (the symbolic side of
/// such an end may differ between the triangles: the caller tests them one by one). With both
/// ends strictly off the common plane, both triangles see the same sides; the segment's line
/// meets the plane at one point, on one side of the diagonal's line or on it, where the
/// diagonal's orientation (perturbed if need be) is the same test, with opposite signs, for
/// both triangles, so it lies in at most one of them. The tests made are those crosses()
/// makes, each once (the diagonal's is shared), so the decisions are the same.
int flatCrossing(const BladeSweep& sweep, const Vec3d& p0, const Vec3d& p1, std::uint64_t id0,
                 std::uint64_t id1, bool near0, bool near1) {
  const auto& c = sweep.corners;
  const int s0 = planeSide(sweep, 0, p0);
  if (s0 == 0) return kUndecided;
  const int s1 = planeSide(sweep, 0, p1);
  if (s1 == 0) return kUndecided;
  if (s0 == s1) return kNoTriangle;
  const Vec3d u = p1 - p0;
  const std::array<Vec3d, 4> w{c[0] - p0, c[1] - p0, c[2] - p0, c[3] - p0};
  const SymbolicKey k0{kVoxelGroup, id0};
  const SymbolicKey k1{kVoxelGroup, id1};
  // orient3d(p0, p1, c_x, c_y), as crosses() computes it.
  const auto edge = [&](int x, int y) {
    return lineEdgeSide(p0, p1, c[x], c[y], u, w[x], w[y], k0, k1,
                        SymbolicKey{kBladeGroup, sweep.ids[x]},
                        SymbolicKey{kBladeGroup, sweep.ids[y]});
  };
  const int diagonal = edge(2, 0);  // triangle 0's edge c2 -> c0; triangle 1 runs c0 -> c2
  if (near0 && edge(0, 1) == diagonal && edge(1, 2) == diagonal) return 0;
  if (near1 && edge(2, 3) == -diagonal && edge(3, 0) == -diagonal) return 1;
  return kNoTriangle;
}

}  // namespace

std::optional<SweepHit> intersectTriangle(const BladeSweep& sweep, int triangle, const Vec3d& p0,
                                          const Vec3d& p1, std::uint64_t id0, std::uint64_t id1) {
  VOXCUT_ASSERT(triangle == 0 || triangle == 1, "intersectTriangle: triangle is 0 or 1");
  VOXCUT_ASSERT(id0 != id1, "intersectTriangle: the segment's ends need distinct ids");
  if (boxesSeparated(sweep.bounds[triangle], p0, p1) ||
      !crosses(sweep, triangle, p0, p1, id0, id1)) {
    return std::nullopt;
  }
  return hitOf(sweep, triangle, p0, p1);
}

std::optional<SweepHit> intersectSegment(const BladeSweep& sweep, const Vec3d& p0, const Vec3d& p1,
                                         std::uint64_t id0, std::uint64_t id1) {
  VOXCUT_ASSERT(id0 != id1, "intersectSegment: the segment's ends need distinct ids");
  const bool near0 = !boxesSeparated(sweep.bounds[0], p0, p1);
  const bool near1 = !boxesSeparated(sweep.bounds[1], p0, p1);
  if (!near0 && !near1) return std::nullopt;
  if (sweep.flat) {
    const int t = flatCrossing(sweep, p0, p1, id0, id1, near0, near1);
    if (t == kNoTriangle) return std::nullopt;
    if (t != kUndecided) return hitOf(sweep, t, p0, p1);
  }
  const bool c0 = near0 && crosses(sweep, 0, p0, p1, id0, id1);
  const bool c1 = near1 && crosses(sweep, 1, p0, p1, id0, id1);
  if (!c0 && !c1) return std::nullopt;
  if (c0 != c1) return hitOf(sweep, c0 ? 0 : 1, p0, p1);
  const SweepHit h0 = hitOf(sweep, 0, p0, p1), h1 = hitOf(sweep, 1, p0, p1);
  return h1.t < h0.t ? h1 : h0;
}

Obb sweepObb(const BladeSweep& sweep, double margin) {
  VOXCUT_ASSERT(margin >= 0.0, "sweepObb: margin must be non-negative");
  const auto& c = sweep.corners;
  const Vec3d blade = (c[1] - c[0]) + (c[2] - c[3]);   // b0 - a0 + b1 - a1
  const Vec3d motion = (c[3] - c[0]) + (c[2] - c[1]);  // a1 - a0 + b1 - b0
  // Any orthonormal frame bounds the corners correctly; these axes make the box tight.
  Vec3d e1 = Vec3d::UnitX();
  if (blade.squaredNorm() > 0.0 && blade.allFinite()) {
    e1 = blade.normalized();
  } else if (motion.squaredNorm() > 0.0 && motion.allFinite()) {
    e1 = motion.normalized();
  }
  const Vec3d m = motion - motion.dot(e1) * e1;
  Vec3d e2 = (m.squaredNorm() > 0.0 && m.allFinite()) ? Vec3d(m.normalized()) : perpendicularTo(e1);
  const Vec3d e3 = e1.cross(e2).normalized();
  e2 = e3.cross(e1);  // re-orthogonalise against rounding in m

  Obb obb;
  obb.axes.col(0) = e1;
  obb.axes.col(1) = e2;
  obb.axes.col(2) = e3;
  Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::infinity());
  Vec3d hi = -lo;
  double scale = 0.0;
  for (const Vec3d& p : c) {
    const Vec3d s = obb.axes.transpose() * p;
    lo = lo.cwiseMin(s);
    hi = hi.cwiseMax(s);
    scale = std::max(scale, p.cwiseAbs().maxCoeff());
  }
  obb.centre = obb.axes * (0.5 * (lo + hi));
  const Vec3d half = 0.5 * (hi - lo);
  const double slack = kRelativeSlack * (scale + half.sum());
  obb.halfExtents = half + Vec3d::Constant(margin + slack);
  return obb;
}

bool overlaps(const Obb& obb, const Eigen::AlignedBox3d& box) {
  if (box.isEmpty()) return false;
  const Vec3d ca = box.center();
  const Vec3d ea = 0.5 * box.sizes();
  const Vec3d t = obb.centre - ca;
  const Eigen::Matrix3d& b = obb.axes;
  const Vec3d& eb = obb.halfExtents;
  const double tol = kRelativeSlack * (ca.cwiseAbs().maxCoeff() + obb.centre.cwiseAbs().maxCoeff() +
                                       ea.sum() + eb.sum());
  // Separated along L when the projected centre distance exceeds the projected radii. Any
  // direction L is a valid test, so rounding in L itself is harmless; `tol` covers the
  // rounding of the projections (scaled by |L|_1), so touching boxes are never separated.
  const auto separatedAlong = [&](const Vec3d& l) {
    const double ra = ea.dot(l.cwiseAbs());
    const double rb = eb.dot((b.transpose() * l).cwiseAbs());
    return std::abs(t.dot(l)) > ra + rb + tol * l.cwiseAbs().sum();
  };
  for (int i = 0; i < 3; ++i) {
    if (separatedAlong(Vec3d::Unit(i)) || separatedAlong(b.col(i))) return false;
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (separatedAlong(Vec3d::Unit(i).cross(b.col(j)))) return false;
    }
  }
  return true;
}

bool contains(const Obb& obb, const Vec3d& p) {
  const Vec3d s = obb.axes.transpose() * (p - obb.centre);
  const double tol = kRelativeSlack * (obb.centre.cwiseAbs().maxCoeff() + obb.halfExtents.sum());
  return (s.cwiseAbs() - obb.halfExtents).maxCoeff() <= tol;
}

}  // namespace voxcut
