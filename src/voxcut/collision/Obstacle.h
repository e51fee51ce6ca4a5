#pragma once
/// @file Obstacle.h
/// Static obstacles of a world (docs/algorithms.md, "Contact"): an infinite plane or an
/// axis-aligned box, and the capsule of a probe, as a signed distance with its outward normal.
/// Units: metres, world frame.
///
/// Thread-safety: plain values; the functions are pure.

#include "voxcut/core/Types.h"

namespace voxcut {

enum class ObstacleType { Plane, Box };

/// A static obstacle. Plane: the points x with normal . (x - point) <= 0 are inside (normal
/// unit). Box: lo <= x <= hi on every axis (lo < hi).
struct Obstacle {
  ObstacleType type = ObstacleType::Plane;
  Vec3d point = Vec3d::Zero();
  Vec3d normal = Vec3d::UnitY();
  Vec3d lo = Vec3d::Zero();
  Vec3d hi = Vec3d::Zero();
  /// Coulomb friction coefficient of contacts with it, >= 0; negative: the world's default.
  double friction = -1.0;
};

/// The signed distance of `x` from the obstacle's surface (m; negative inside) and, in
/// `normal`, the unit direction in which it grows fastest there (out of the obstacle): for a
/// box, away from the nearest point of its surface outside, along the nearest face's normal
/// inside (ties: the lowest axis; on the box's mid-plane, the high face).
[[nodiscard]] double signedDistance(const Obstacle& obstacle, const Vec3d& x, Vec3d& normal);

/// A capsule: the points within `radius` of the segment a-b (a sphere when a == b).
struct Capsule {
  Vec3d a = Vec3d::Zero();
  Vec3d b = Vec3d::Zero();
  double radius = 0.0;
};

/// The signed distance of `x` from the capsule's surface (m; negative inside) and, in
/// `normal`, the unit direction away from the nearest point of its segment (on the segment
/// itself, the direction perpendicular to it closest to +y, or +y for a sphere).
[[nodiscard]] double signedDistance(const Capsule& capsule, const Vec3d& x, Vec3d& normal);

}  // namespace voxcut
