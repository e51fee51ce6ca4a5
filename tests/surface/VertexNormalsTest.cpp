#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "voxcut/surface/VertexNormals.h"

namespace voxcut {
namespace {

TEST(VertexNormals, WeightsTrianglesByArea) {
  // Two triangles at vertex 0: a unit right triangle in the xy plane (normal +z, area 1/2) and
  // a 2x2 right triangle in the xz plane (normal +y, area 2).
  const std::vector<Vec3d> V = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 2}, {2, 0, 0}};
  const std::vector<std::array<int, 3>> F = {{0, 1, 2}, {0, 3, 4}};
  const std::vector<Vec3d> N = vertexNormals(V, F);
  ASSERT_EQ(N.size(), V.size());
  // Cross products: (1,0,0)x(0,1,0) = (0,0,1); (0,0,2)x(2,0,0) = (0,4,0).
  EXPECT_TRUE(N[0].isApprox(Vec3d(0, 4, 1).normalized(), 1e-15));
  EXPECT_TRUE(N[1].isApprox(Vec3d::UnitZ(), 1e-15));
  EXPECT_TRUE(N[3].isApprox(Vec3d::UnitY(), 1e-15));
}

TEST(VertexNormals, IsolatedAndDegenerateVerticesGetTheFallback) {
  const std::vector<Vec3d> V = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {5, 5, 5}};
  const std::vector<std::array<int, 3>> F = {{0, 1, 2}};  // collinear: zero area
  for (const Vec3d& n : vertexNormals(V, F)) EXPECT_EQ(n, Vec3d::Zero());
  for (const Vec3d& n : vertexNormals(V, F, Vec3d::UnitZ())) EXPECT_EQ(n, Vec3d::UnitZ());
}

TEST(VertexNormals, ClosedTetrahedronNormalsPointOutwards) {
  const std::vector<Vec3d> V = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  // Counter-clockwise seen from outside.
  const std::vector<std::array<int, 3>> F = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  const std::vector<Vec3d> N = vertexNormals(V, F);
  const Vec3d centre(0.25, 0.25, 0.25);
  for (std::size_t v = 0; v < V.size(); ++v) {
    EXPECT_NEAR(N[v].norm(), 1.0, 1e-15);
    EXPECT_GT(N[v].dot(V[v] - centre), 0.0);
  }
}

}  // namespace
}  // namespace voxcut
