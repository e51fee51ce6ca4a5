#include <gtest/gtest.h>

#include <vector>

#include "voxcut/collision/RestDistance.h"

namespace voxcut {
namespace {

// A solid block of 10 x 8 x 6 voxels (one empty voxel around it), every link inside connected.
VoxelGrid block() {
  VoxelGrid g(Index3{12, 10, 8}, Vec3d::Zero(), 0.01);
  for (int z = 1; z <= 6; ++z)
    for (int y = 1; y <= 8; ++y)
      for (int x = 1; x <= 10; ++x) g.setMaterial(g.index(x, y, z), 1);
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a)
      if (g.occupied(v) && g.hasLink(v, a) && g.occupied(v + g.stride(a)))
        g.setConnected(v, a, true);
  return g;
}

// The field gives voxel v's point at offset (from its centre) a depth within 1e-7 m of
// `depth`, with the normal `normal` when one is given.
void expectDepth(const RestDistanceField& f, const VoxelGrid& g, std::size_t v, const Vec3d& offset,
                 double depth, const Vec3d* normal = nullptr) {
  double d = 0.0;
  Vec3d n;
  ASSERT_TRUE(f.depth(g, v, g.position(v) + offset, d, n));
  EXPECT_NEAR(d, depth, 1e-7);
  if (normal != nullptr) {
    EXPECT_TRUE(n.isApprox(*normal, 1e-6));
  }
}

TEST(RestDistance, DepthBelowTheNearestFace) {
  const VoxelGrid g = block();
  RestDistanceField f;
  f.build(g, 4);
  const Vec3d px = Vec3d::UnitX(), mz = -Vec3d::UnitZ(), centre = Vec3d::Zero();
  // Next to the +x face (at x = 10.5 voxels).
  expectDepth(f, g, g.index(10, 4, 3), centre, 0.005, &px);
  // Three voxels from the -z face (at z = 0.5) and farther from the others.
  const std::size_t v = g.index(5, 4, 3);
  expectDepth(f, g, v, centre, 0.025, &mz);
  // A point off the centre: its own depth below that plane.
  expectDepth(f, g, v, Vec3d(0.003, 0.002, 0.004), 0.029);
  // Beyond the band (it and its neighbours): unknown. Empty voxels: none.
  double d = 0.0;
  Vec3d n;
  RestDistanceField narrow;
  narrow.build(g, 1);
  EXPECT_FALSE(narrow.depth(g, v, g.position(v), d, n));
  EXPECT_FALSE(f.depth(g, g.index(0, 0, 0), g.position(0), d, n));
}

TEST(RestDistance, EachSideOfACutSeesItAndUpdateMatchesBuild) {
  VoxelGrid g = block();
  RestDistanceField f;
  f.build(g, 4);
  // Cut the block across x between voxels 5 and 6.
  std::vector<std::uint64_t> cut;
  for (int z = 1; z <= 6; ++z)
    for (int y = 1; y <= 8; ++y) {
      const std::size_t v = g.index(5, y, z);
      g.setConnected(v, 0, false);
      cut.push_back(VoxelGrid::linkId(v, 0));
    }
  f.update(g, cut);
  const std::size_t left = g.index(5, 4, 3), right = g.index(6, 4, 3);
  const Vec3d px = Vec3d::UnitX(), mx = -Vec3d::UnitX(), centre = Vec3d::Zero();
  expectDepth(f, g, left, centre, 0.005, &px);
  expectDepth(f, g, right, centre, 0.005, &mx);
  // A point of the right side pushed past the cut into the left side is below the left
  // side's cut face by as much.
  expectDepth(f, g, left, Vec3d(0.002, 0, 0), 0.003);
  RestDistanceField fresh;
  fresh.build(g, 4);
  ASSERT_EQ(fresh.size(), f.size());
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    double d1 = 0.0, d2 = 0.0;
    Vec3d n1, n2;
    const bool a = f.depth(g, v, g.position(v), d1, n1),
               b = fresh.depth(g, v, g.position(v), d2, n2);
    ASSERT_EQ(a, b) << v;
    if (a) {
      EXPECT_NEAR(d1, d2, 1e-7) << v;
    }
  }
}

}  // namespace
}  // namespace voxcut
