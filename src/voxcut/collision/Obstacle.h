#pragma once
/// @file Obstacle.h
/// Static obstacles of a world (docs/algorithms.md, "Contact"): an infinite plane, an
/// axis-aligned box or a triangle mesh, and the capsule of a probe, as a signed distance with
/// its outward normal. Units: metres, world frame.
///
/// Thread-safety: plain values (a mesh obstacle shares its immutable MeshDistance among its
/// copies); the functions are pure and may run concurrently.

#include <limits>
#include <memory>
#include <string>

#include "voxcut/collision/MeshDistance.h"
#include "voxcut/core/Types.h"

namespace voxcut {

enum class ObstacleType { Plane, Box, Mesh };

/// A static obstacle. Plane: the points x with normal . (x - point) <= 0 are inside (normal
/// unit). Box: lo <= x <= hi on every axis (lo < hi). Mesh: inside the triangle mesh of
/// `mesh` (MeshDistance: where its generalized winding number exceeds 1/2 in magnitude); make
/// one with meshObstacle. Copies are cheap: they share the mesh's hierarchies.
struct Obstacle {
  ObstacleType type = ObstacleType::Plane;
  Vec3d point = Vec3d::Zero();
  Vec3d normal = Vec3d::UnitY();
  Vec3d lo = Vec3d::Zero();
  Vec3d hi = Vec3d::Zero();
  /// Mesh: the signed distance to its triangles (non-null for ObstacleType::Mesh).
  std::shared_ptr<const MeshDistance> mesh;
  /// Coulomb friction coefficient of contacts with it, >= 0; negative: the world's default.
  double friction = -1.0;
  /// Mesh: the file it was read from (absolute), where it came from one (as read: a scene's
  /// mesh obstacle with a scale or translate leaves it empty); empty otherwise: for writing
  /// scenes (io/SceneWriter.h).
  std::string path;
};

/// A mesh obstacle of the triangle mesh `mesh` (#V vertices, #F faces; metres, world frame),
/// with the world's default friction: builds its MeshDistance (repair, hierarchies; O(F log F)).
/// A mesh with no non-degenerate triangle gives an obstacle that nothing touches; check
/// `obstacle.mesh->triangleCount()` to refuse one.
[[nodiscard]] Obstacle meshObstacle(const TriangleMesh& mesh);

/// The signed distance of `x` from the obstacle's surface (m; negative inside) and, in
/// `normal`, the unit direction in which it grows fastest there (out of the obstacle): for a
/// box, away from the nearest point of its surface outside, along the nearest face's normal
/// inside (ties: the lowest axis; on the box's mid-plane, the high face); for a mesh,
/// MeshDistance::signedDistance.
///
/// `maxDistance` (>= 0) lets a far query stop early: where the signed distance is at least
/// maxDistance, the result may be any value >= maxDistance and `normal` any unit vector (only
/// a mesh uses it; planes and boxes are always exact). Below maxDistance the result is exact.
[[nodiscard]] double signedDistance(const Obstacle& obstacle, const Vec3d& x, Vec3d& normal,
                                    double maxDistance = std::numeric_limits<double>::infinity());

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
