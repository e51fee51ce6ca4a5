#include <gtest/gtest.h>

#include <cmath>

#include "voxcut/collision/Obstacle.h"

namespace voxcut {
namespace {

TEST(Obstacle, PlaneDistanceIsSignedAlongItsNormal) {
  Obstacle plane;
  plane.type = ObstacleType::Plane;
  plane.point = Vec3d(0.0, 0.5, 0.0);
  plane.normal = Vec3d(0.0, 1.0, 0.0);
  Vec3d n;
  EXPECT_DOUBLE_EQ(signedDistance(plane, Vec3d(3.0, 0.75, -2.0), n), 0.25);
  EXPECT_EQ(n, Vec3d(0.0, 1.0, 0.0));
  EXPECT_DOUBLE_EQ(signedDistance(plane, Vec3d(0.0, 0.25, 0.0), n), -0.25);
}

TEST(Obstacle, BoxDistanceOutsideInsideAndAtACorner) {
  Obstacle box;
  box.type = ObstacleType::Box;
  box.lo = Vec3d(-1.0, 0.0, -1.0);
  box.hi = Vec3d(1.0, 0.5, 1.0);
  Vec3d n;
  // Above the top face.
  EXPECT_NEAR(signedDistance(box, Vec3d(0.2, 0.7, 0.3), n), 0.2, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3d(0.0, 1.0, 0.0)));
  // Inside, nearest the top face.
  EXPECT_NEAR(signedDistance(box, Vec3d(0.0, 0.4, 0.0), n), -0.1, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3d(0.0, 1.0, 0.0)));
  // Inside, nearest the -x face.
  EXPECT_NEAR(signedDistance(box, Vec3d(-0.95, 0.25, 0.0), n), -0.05, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3d(-1.0, 0.0, 0.0)));
  // Beyond an edge: the distance to the edge, the normal from it.
  EXPECT_NEAR(signedDistance(box, Vec3d(1.3, 0.9, 0.0), n), 0.5, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3d(0.6, 0.8, 0.0)));
  // Beyond a corner.
  EXPECT_NEAR(signedDistance(box, Vec3d(-2.0, -1.0, 2.0), n), std::sqrt(3.0), 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3d(-1.0, -1.0, 1.0).normalized()));
}

}  // namespace
}  // namespace voxcut
