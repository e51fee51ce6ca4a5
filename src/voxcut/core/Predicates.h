#pragma once
/// @file Predicates.h
/// Exact orientation predicates on double coordinates, and their symbolically perturbed
/// (simulation of simplicity) variant that never returns 0.
///
/// Each predicate first evaluates the determinant in floating point and accepts its sign when
/// it exceeds Shewchuk's a-priori error bound ("Adaptive precision floating-point arithmetic
/// and fast robust geometric predicates", 1997, bounds A: (3 + 16e)e for orient2d,
/// (7 + 56e)e for orient3d, e = 2^-53, times the permanent, with a guard against underflow).
/// Otherwise, unless a shared zero coordinate of the differences makes the determinant
/// exactly 0, the determinant is recomputed exactly as a floating-point expansion: each
/// difference split exactly into two doubles (TwoSum), each product of differences split
/// exactly (TwoProduct through std::fma), all parts summed exactly (Shewchuk's
/// GROW-EXPANSION); the sign of the largest component is the sign of the determinant.
///
/// Domain: coordinates must be finite (a programming error otherwise, checked on the exact
/// path). The result is exact whenever the nonzero coordinate magnitudes of the points passed
/// to one call lie within a factor 2^300 of the largest (the exact path rescales by a power
/// of two, so the absolute scale does not matter: 1e-300 or 1e300 work). Units do not matter.
///
/// Thread-safety: pure functions without state; safe to call from any number of threads.

#include <cmath>
#include <compare>
#include <cstdint>

#include "voxcut/core/Types.h"

namespace voxcut {

using Vec2d = Eigen::Vector2d;

/// Sign of det[b - a, c - a]: +1 when a, b, c turn counter-clockwise (c left of the directed
/// line a -> b, with x to the right and y up), -1 clockwise, 0 when exactly collinear.
[[nodiscard]] int orient2d(const Vec2d& a, const Vec2d& b, const Vec2d& c);

/// Sign of det[b - a, c - a, d - a] = ((b - a) x (c - a)) . (d - a): +1 when d lies on the
/// side of the plane through a, b, c that the normal (b - a) x (c - a) points to (that is,
/// a, b, c turn counter-clockwise seen from d), -1 on the other side, 0 when the four points
/// are exactly coplanar. Example: orient3d(0, e_x, e_y, e_z) = +1. Note that this is the
/// opposite sign of Shewchuk's orient3d.
[[nodiscard]] int orient3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d);

/// Same as orient3d but always through the exact expansion arithmetic (no filter). Slower;
/// meant for tests and as a reference.
[[nodiscard]] int orient3dExact(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d);

/// Same as orient2d but always through the exact expansion arithmetic (no filter).
[[nodiscard]] int orient2dExact(const Vec2d& a, const Vec2d& b, const Vec2d& c);

namespace predicates_detail {
// Shewchuk's bound A for orient3d, relative to the permanent, plus an allowance for underflow:
// the filter is trusted only when the permanent is at least kMinPermanent (1 + |outer|_1), so
// that products that underflow (absolute error below 2^-1070 (1 + |outer|_1)) stay below
// 2^-270 of the permanent. Fused multiply-adds contracted by the compiler only remove
// roundings, so the bound stays valid.
inline constexpr double kEps = 0x1p-53;
inline constexpr double kUnderflowSlack = 0x1p-260;
inline constexpr double kOrient2dBound = (3.0 + 16.0 * kEps) * kEps + kUnderflowSlack;
inline constexpr double kOrient3dBound = (7.0 + 56.0 * kEps) * kEps + kUnderflowSlack;
inline constexpr double kMinPermanent = 0x1p-800;

/// The certified sign of x . m, given m's components (each y_j z_k - y_k z_j of rounded
/// differences) and their permanents |y_j z_k| + |y_k z_j|; 0 when uncertain.
inline int filteredSign(const Vec3d& x, const Vec3d& m, const Vec3d& permanents) {
  const double det = x.x() * m.x() + x.y() * m.y() + x.z() * m.z();
  const double ax = std::abs(x.x()), ay = std::abs(x.y()), az = std::abs(x.z());
  const double permanent = ax * permanents.x() + ay * permanents.y() + az * permanents.z();
  if (!(permanent >= kMinPermanent * (1.0 + ax + ay + az))) return 0;
  const double bound = kOrient3dBound * permanent;
  return det > bound ? 1 : (-det > bound ? -1 : 0);
}
}  // namespace predicates_detail

/// The filter stage of orient3d alone, from the differences u = b - a, v = c - a, w = d - a,
/// each computed by one floating-point subtraction (or exactly): the sign of
/// det[u, v, w] = u . (v x w) when Shewchuk's error bound certifies it, 0 when it cannot
/// decide (then call orient3d or orient3dSoS). Inline, for loops that share differences.
inline int orient3dFilter(const Vec3d& u, const Vec3d& v, const Vec3d& w) {
  const double vywz = v.y() * w.z(), vzwy = v.z() * w.y();
  const double vzwx = v.z() * w.x(), vxwz = v.x() * w.z();
  const double vxwy = v.x() * w.y(), vywx = v.y() * w.x();
  return predicates_detail::filteredSign(
      u, Vec3d(vywz - vzwy, vzwx - vxwz, vxwy - vywx),
      Vec3d(std::abs(vywz) + std::abs(vzwy), std::abs(vzwx) + std::abs(vxwz),
            std::abs(vxwy) + std::abs(vywx)));
}

/// orient3d(a, b, c, d) for one fixed a, b, c and many d: the minors that depend only on
/// a, b, c are computed once. filter(d) is the certified sign or 0 when undecided (then call
/// orient3d or orient3dSoS). A plain value; const use is thread-safe.
struct OrientPlane {
  Vec3d origin = Vec3d::Zero();      ///< a
  Vec3d minors = Vec3d::Zero();      ///< (b - a) x (c - a), each component rounded as computed
  Vec3d permanents = Vec3d::Zero();  ///< the permanents of those components

  OrientPlane() = default;
  OrientPlane(const Vec3d& a, const Vec3d& b, const Vec3d& c) : origin(a) {
    const Vec3d u = b - a, v = c - a;
    const double uyvz = u.y() * v.z(), uzvy = u.z() * v.y();
    const double uzvx = u.z() * v.x(), uxvz = u.x() * v.z();
    const double uxvy = u.x() * v.y(), uyvx = u.y() * v.x();
    minors = Vec3d(uyvz - uzvy, uzvx - uxvz, uxvy - uyvx);
    permanents = Vec3d(std::abs(uyvz) + std::abs(uzvy), std::abs(uzvx) + std::abs(uxvz),
                       std::abs(uxvy) + std::abs(uyvx));
  }
  /// det[b - a, c - a, d - a] = (d - a) . ((b - a) x (c - a)), when certified; else 0.
  [[nodiscard]] int filter(const Vec3d& d) const {
    return predicates_detail::filteredSign(d - origin, minors, permanents);
  }
};

/// Symbolic identity of a point for simulation of simplicity. Keys are ordered by (group, id)
/// lexicographically; a point with a smaller key receives a larger infinitesimal
/// displacement. The same point must carry the same key in every call whose results have to
/// agree, and the points of one call must carry distinct keys.
struct SymbolicKey {
  std::uint64_t group = 0;
  std::uint64_t id = 0;
  friend auto operator<=>(const SymbolicKey&, const SymbolicKey&) = default;
};

/// orient3d of symbolically perturbed points; never 0.
///
/// Simulation of simplicity (Edelsbrunner & Muecke 1990): the point of rank i (0-based,
/// ranks by increasing key among all points ever used together) is moved by
/// (eps^(2^(3i+2)), eps^(2^(3i+1)), eps^(2^(3i))) for an infinitesimal eps > 0. Hence the
/// smallest key dominates, and within one point z is displaced most, then y, then x. When
/// orient3d(a, b, c, d) != 0 the result is that sign; otherwise it is the sign of the first
/// nonzero term of the perturbed determinant's expansion (exact 2D orientations of
/// projections, exact coordinate comparisons, finally a constant). Consequences used by
/// callers: if d has the smallest key and lies on the plane of a, b, c, then d is treated as
/// displaced towards +z (towards +y if the plane contains the z direction, then +x).
/// Antisymmetric: swapping two arguments (with their keys) negates the result.
/// The four keys must be distinct (checked).
[[nodiscard]] int orient3dSoS(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d,
                              const SymbolicKey& ka, const SymbolicKey& kb, const SymbolicKey& kc,
                              const SymbolicKey& kd);

}  // namespace voxcut
