#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "voxcut/collision/FaceCrossings.h"
#include "voxcut/voxel/BuiltinModels.h"

namespace voxcut {
namespace {

TEST(FaceCrossings, SegmentAndTriangle) {
  const Vec3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  // Through the interior, beside it, ending on it, along its plane above it.
  EXPECT_TRUE(segmentMeetsTriangle(Vec3d(0.2, 0.2, -1), Vec3d(0.2, 0.2, 1), a, b, c));
  EXPECT_FALSE(segmentMeetsTriangle(Vec3d(0.8, 0.8, -1), Vec3d(0.8, 0.8, 1), a, b, c));
  EXPECT_TRUE(segmentMeetsTriangle(Vec3d(0.2, 0.2, 0), Vec3d(0.2, 0.2, 1), a, b, c));
  EXPECT_FALSE(segmentMeetsTriangle(Vec3d(0, 0, 1), Vec3d(1, 1, 1), a, b, c));
  // Through an edge and through a corner.
  EXPECT_TRUE(segmentMeetsTriangle(Vec3d(0.5, 0, -1), Vec3d(0.5, 0, 1), a, b, c));
  EXPECT_TRUE(segmentMeetsTriangle(Vec3d(1, 0, -1), Vec3d(1, 0, 1), a, b, c));
  // In the plane: across an edge, wholly inside, wholly outside, touching a corner.
  EXPECT_TRUE(segmentMeetsTriangle(Vec3d(0.2, -1, 0), Vec3d(0.2, 1, 0), a, b, c));
  EXPECT_TRUE(segmentMeetsTriangle(Vec3d(0.1, 0.1, 0), Vec3d(0.2, 0.3, 0), a, b, c));
  EXPECT_FALSE(segmentMeetsTriangle(Vec3d(1, 1, 0), Vec3d(2, 0.5, 0), a, b, c));
  EXPECT_TRUE(segmentMeetsTriangle(Vec3d(1, 0, 0), Vec3d(2, 0, 0), a, b, c));
}

TriangleMesh boxMesh(const Vec3d& lo, const Vec3d& hi) {
  TriangleMesh m = makeBox(hi - lo);
  for (Vec3d& v : m.vertices) v += 0.5 * (lo + hi);
  return m;
}

TriangleMesh joined(TriangleMesh a, const TriangleMesh& b) {
  const int base = static_cast<int>(a.vertices.size());
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (const auto& f : b.faces) a.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
  return a;
}

// Closed surfaces that do not pass through themselves have no crossed face: a sphere, a box
// with another inside it, two boxes apart, a flat grid of triangles.
TEST(FaceCrossings, CleanMeshesHaveNone) {
  TriangleMesh grid;
  constexpr int kN = 8;
  for (int j = 0; j <= kN; ++j)
    for (int i = 0; i <= kN; ++i) grid.vertices.push_back(Vec3d(i, 0, j));
  for (int j = 0; j < kN; ++j)
    for (int i = 0; i < kN; ++i) {
      const int v = j * (kN + 1) + i;
      grid.faces.push_back({v, v + kN + 1, v + 1});
      grid.faces.push_back({v + 1, v + kN + 1, v + kN + 2});
    }
  const Vec3d o = Vec3d::Zero(), one = Vec3d::Ones();
  for (const TriangleMesh& mesh :
       {makeSphere(1.0, 3), joined(boxMesh(o, one), boxMesh(0.2 * one, 0.6 * one)),
        joined(boxMesh(o, one), boxMesh(2.0 * one, 3.0 * one)), grid}) {
    const std::vector<std::uint8_t> crossed = crossedFaces(mesh);
    ASSERT_EQ(crossed.size(), mesh.faces.size());
    EXPECT_EQ(std::count(crossed.begin(), crossed.end(), 1), 0);
  }
}

// Two boxes that overlap: the faces of one that the other passes through are crossed, the far
// faces are not.
TEST(FaceCrossings, OverlappingBoxesCrossEachOther) {
  const TriangleMesh mesh = joined(boxMesh(Vec3d(0, 0, 0), Vec3d(1, 1, 1)),
                                   boxMesh(Vec3d(0.5, 0.3, 0.2), Vec3d(1.5, 1.2, 0.9)));
  const std::vector<std::uint8_t> crossed = crossedFaces(mesh);
  int nearFace = 0, farFace = 0;
  for (std::size_t f = 0; f < 12; ++f) {  // the first box's faces
    const auto& face = mesh.faces[f];
    const auto all = [&](auto pred) {
      return pred(mesh.vertices[face[0]]) && pred(mesh.vertices[face[1]]) &&
             pred(mesh.vertices[face[2]]);
    };
    if (all([](const Vec3d& v) { return v.x() == 1.0; })) nearFace += crossed[f];
    if (all([](const Vec3d& v) { return v.x() == 0.0; })) farFace += crossed[f];
  }
  EXPECT_EQ(nearFace, 2);  // both triangles of the face x = 1
  EXPECT_EQ(farFace, 0);
  // A triangle lying over another in its plane, sharing no corner, meets it.
  TriangleMesh flat;
  flat.vertices = {Vec3d(0, 0, 0),     Vec3d(1, 0, 0),     Vec3d(0, 1, 0),
                   Vec3d(0.1, 0.1, 0), Vec3d(0.5, 0.1, 0), Vec3d(0.1, 0.5, 0)};
  flat.faces = {{0, 1, 2}, {3, 4, 5}};
  EXPECT_EQ(crossedFaces(flat), (std::vector<std::uint8_t>{1, 1}));
}

}  // namespace
}  // namespace voxcut
