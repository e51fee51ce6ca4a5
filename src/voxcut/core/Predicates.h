#pragma once
/// @file Predicates.h
/// Exact orientation predicates on double coordinates, and their symbolically perturbed
/// (simulation of simplicity) variant that never returns 0.
///
/// Each predicate first evaluates the determinant in floating point and accepts its sign when
/// it exceeds Shewchuk's a-priori error bound ("Adaptive precision floating-point arithmetic
/// and fast robust geometric predicates", 1997, bounds A: (3 + 16e)e for orient2d,
/// (7 + 56e)e for orient3d, e = 2^-53, times the permanent). Otherwise the determinant is
/// recomputed exactly with floating-point expansions (TwoSum, TwoProduct through std::fma,
/// expansion sums and products) and the sign of the exact value is returned.
///
/// Domain: coordinates must be finite (a programming error otherwise, checked on the exact
/// path). The result is exact whenever the nonzero coordinate magnitudes of the points passed
/// to one call lie within a factor 2^300 of each other (the exact path rescales by a power of
/// two, so the absolute scale does not matter: 1e-200 or 1e200 work). Units do not matter.
///
/// Thread-safety: pure functions without state; safe to call from any number of threads.

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
                              const SymbolicKey& ka, const SymbolicKey& kb,
                              const SymbolicKey& kc, const SymbolicKey& kd);

}  // namespace voxcut
