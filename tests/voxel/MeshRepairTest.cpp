#include <gtest/gtest.h>

#include <string>

#include "voxcut/core/Error.h"
#include "voxcut/voxel/MeshRepair.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

/// A mesh of the triangle (0,0,0) (1,0,0) (0,1,0) followed by the triangle `a b c`.
TriangleMesh withTriangle(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  TriangleMesh m;
  m.vertices = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0, 1, 0), a, b, c};
  m.faces = {{0, 1, 2}, {3, 4, 5}};
  return m;
}

TEST(MeshRepair, DropsRepeatedIndicesAndCollinearTriangles) {
  TriangleMesh m;
  m.vertices = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(2, 0, 0), Vec3d(0, 0, 0)};
  // A good face, a repeated index, a welded repeat (vertex 4 equals vertex 0), a collinear one.
  m.faces = {{0, 1, 2}, {0, 0, 1}, {4, 0, 2}, {0, 1, 3}};
  RepairReport report;
  const TriangleMesh out = repairMesh(m, &report);
  EXPECT_EQ(out.faces.size(), 1u);
  EXPECT_EQ(report.degenerateFaces, 3);
}

TEST(MeshRepair, CollinearIsDecidedExactly) {
  // Exactly collinear far from the origin: c = a + 2 (b - a), every value a double.
  const Vec3d a(1e7, -3e6, 2.5e5), d(0x1p-20, 3 * 0x1p-20, -0x1p-19);
  RepairReport report;
  (void)repairMesh(withTriangle(a, a + d, a + 2 * d), &report);
  EXPECT_EQ(report.degenerateFaces, 1);
  // Off the line by the smallest step there: kept.
  const Vec3d c = a + 2 * d + Vec3d(0, 0x1p-29, 0);
  EXPECT_EQ(repairMesh(withTriangle(a, a + d, c), &report).faces.size(), 2u);
  EXPECT_EQ(report.degenerateFaces, 0);
  // A tiny triangle whose cross product underflows to 0 in doubles still has an area.
  const TriangleMesh tiny =
      withTriangle(Vec3d(-1e-200, 0, 0), Vec3d(1e-200, 0, 0), Vec3d(0, 1e-200, 0));
  EXPECT_EQ(repairMesh(tiny, &report).faces.size(), 2u);
  EXPECT_EQ(report.degenerateFaces, 0);
}

TEST(MeshRepair, MeshWithOnlyDegenerateTrianglesIsRejectedByName) {
  TriangleMesh flat;
  flat.vertices = {Vec3d(0, 0, 0), Vec3d(1, 1, 1), Vec3d(3, 3, 3), Vec3d(0, 0, 1)};
  flat.faces = {{0, 1, 2}, {2, 1, 0}, {3, 3, 0}};
  VoxelizeParams p;
  p.resolution.resolution = 16;
  try {
    (void)voxelize({{"flat part", flat}}, p);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mesh 'flat part'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace voxcut
