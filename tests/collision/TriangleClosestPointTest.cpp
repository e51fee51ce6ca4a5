#include <gtest/gtest.h>

#include <random>

#include "voxcut/collision/TriangleClosestPoint.h"

namespace voxcut {
namespace {

TEST(TriangleClosestPoint, InteriorEdgeAndCornerRegions) {
  const Vec3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  // Above the interior: the projection.
  EXPECT_TRUE(closestPointOnTriangle(Vec3d(0.2, 0.3, 0.7), a, b, c).isApprox(Vec3d(0.2, 0.3, 0)));
  // Beside the hypotenuse: its nearest point.
  EXPECT_TRUE(closestPointOnTriangle(Vec3d(1, 1, -2), a, b, c).isApprox(Vec3d(0.5, 0.5, 0)));
  // Below the edge ab: a point of it.
  EXPECT_TRUE(closestPointOnTriangle(Vec3d(0.4, -1, 3), a, b, c).isApprox(Vec3d(0.4, 0, 0)));
  // Beyond the corners.
  EXPECT_EQ(closestPointOnTriangle(Vec3d(-1, -1, 1), a, b, c), a);
  EXPECT_EQ(closestPointOnTriangle(Vec3d(2, -0.5, 0), a, b, c), b);
  EXPECT_EQ(closestPointOnTriangle(Vec3d(-0.2, 3, 0), a, b, c), c);
}

// No point sampled on the triangle is nearer than the one returned, which lies on it.
TEST(TriangleClosestPoint, NoSampleIsNearer) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto random = [&] { return Vec3d(u(rng), u(rng), u(rng)); };
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3d a = random(), b = random(), c = random(), p = 2.0 * random();
    const Vec3d q = closestPointOnTriangle(p, a, b, c);
    const double d = (p - q).norm();
    // In the triangle's plane.
    const Vec3d n = (b - a).cross(c - a);
    EXPECT_NEAR((q - a).dot(n.normalized()), 0.0, 1e-12);
    constexpr int kSteps = 40;
    for (int i = 0; i <= kSteps; ++i)
      for (int j = 0; i + j <= kSteps; ++j) {
        const Vec3d s = a + (double(i) / kSteps) * (b - a) + (double(j) / kSteps) * (c - a);
        ASSERT_GE((p - s).norm(), d - 1e-12) << "trial " << trial;
      }
  }
}

TEST(TriangleClosestPoint, DegenerateTrianglesGiveTheirSegmentOrPoint) {
  const Vec3d p(0.3, 2.0, -1.0);
  // All three corners at one point.
  const Vec3d o(1, 1, 1);
  EXPECT_EQ(closestPointOnTriangle(p, o, o, o), o);
  // Collinear corners: the segment from (0,0,0) to (2,0,0).
  const Vec3d q = closestPointOnTriangle(p, Vec3d(0, 0, 0), Vec3d(2, 0, 0), Vec3d(1, 0, 0));
  EXPECT_TRUE(q.isApprox(Vec3d(0.3, 0, 0)));
  // A repeated corner.
  const Vec3d r = closestPointOnTriangle(p, Vec3d(0, 0, 0), Vec3d(0, 0, 0), Vec3d(0, 0, 4));
  EXPECT_TRUE(r.isApprox(Vec3d(0, 0, 0)));
  // A sliver whose cross product underflows: finite, on its edge.
  const Vec3d s =
      closestPointOnTriangle(p, Vec3d(0, 0, 0), Vec3d(1e-200, 0, 0), Vec3d(0, 1e-200, 0));
  EXPECT_TRUE(s.allFinite());
  EXPECT_LT(s.norm(), 1e-199);
}

}  // namespace
}  // namespace voxcut
