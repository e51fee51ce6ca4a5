#include <gtest/gtest.h>

#include <random>

#include "voxcut/collision/SpatialHash.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/topology/PrescribedDeformation.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

using Box = Eigen::AlignedBox3d;

std::vector<Box> randomBoxes(unsigned seed, std::size_t n, double maxSide) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-1.0, 1.0), side(0.0, maxSide);
  std::vector<Box> boxes(n);
  for (auto& b : boxes) {
    const Vec3d lo(pos(rng), pos(rng), pos(rng));
    b = Box(lo, lo + Vec3d(side(rng), side(rng), side(rng)));
  }
  return boxes;
}

std::vector<std::uint32_t> bruteForce(const std::vector<Box>& boxes, const Box& q) {
  std::vector<std::uint32_t> out;
  for (std::size_t e = 0; e < boxes.size(); ++e)
    if (!boxes[e].isEmpty() && boxes[e].intersects(q)) out.push_back(static_cast<std::uint32_t>(e));
  return out;
}

/// Elements registered in some cell of their own box's range that is also in the query's
/// range and passes the test.
template <class Test>
std::vector<std::uint32_t> bruteForceCells(const SpatialHash& h, const std::vector<Box>& boxes,
                                           const Box& q, Test test) {
  const Index3 qlo = h.cellOf(q.min()), qhi = h.cellOf(q.max());
  std::vector<std::uint32_t> out;
  for (std::size_t e = 0; e < boxes.size(); ++e) {
    if (boxes[e].isEmpty()) continue;
    const Index3 lo = h.cellOf(boxes[e].min()), hi = h.cellOf(boxes[e].max());
    bool hit = false;
    for (int z = std::max(lo.z, qlo.z); z <= std::min(hi.z, qhi.z) && !hit; ++z)
      for (int y = std::max(lo.y, qlo.y); y <= std::min(hi.y, qhi.y) && !hit; ++y)
        for (int x = std::max(lo.x, qlo.x); x <= std::min(hi.x, qhi.x) && !hit; ++x)
          hit = test(h.cellBox({x, y, z}));
    if (hit) out.push_back(static_cast<std::uint32_t>(e));
  }
  return out;
}

TEST(SpatialHash, BoxQueriesMatchBruteForce) {
  std::vector<Box> boxes = randomBoxes(1, 3000, 0.15);
  boxes[17] = Box();  // an empty box is never found
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> pos(-1.3, 1.3), side(0.0, 0.8);
  for (double cell : {0.0, 0.05, 0.37}) {
    SpatialHash h;
    h.build(boxes, cell);
    if (cell == 0.0) {
      double largest = 0;
      for (const auto& b : boxes)
        if (!b.isEmpty()) largest = std::max(largest, b.sizes().maxCoeff());
      EXPECT_EQ(h.cellSize(), largest);
    }
    for (int i = 0; i < 300; ++i) {
      const Vec3d lo(pos(rng), pos(rng), pos(rng));
      const Box q(lo, lo + Vec3d(side(rng), side(rng), side(rng)));
      ASSERT_EQ(h.elementsInBox(q), bruteForce(boxes, q)) << "cell " << cell << " query " << i;
    }
    // Touching counts as overlapping; far, empty and infinite queries behave.
    EXPECT_EQ(h.elementsInBox(Box(boxes[3].max(), boxes[3].max() + Vec3d::Constant(1e-3))),
              bruteForce(boxes, Box(boxes[3].max(), boxes[3].max() + Vec3d::Constant(1e-3))));
    EXPECT_TRUE(h.elementsInBox(Box(Vec3d::Constant(50), Vec3d::Constant(51))).empty());
    EXPECT_TRUE(h.elementsInBox(Box()).empty());
    const Box all(Vec3d::Constant(-1e300), Vec3d::Constant(1e300));
    EXPECT_EQ(h.elementsInBox(all).size(), boxes.size() - 1);
  }
}

TEST(SpatialHash, CellPredicateQueriesAndMarks) {
  const std::vector<Box> boxes = randomBoxes(3, 2000, 0.2);
  SpatialHash h;
  h.build(boxes);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> pos(-1.2, 1.2), r(0.05, 0.6);
  std::vector<std::uint8_t> mark;
  for (int i = 0; i < 200; ++i) {
    // A ball standing in for an OBB: cells whose box comes within r of the centre.
    const Vec3d c(pos(rng), pos(rng), pos(rng));
    const double rad = r(rng);
    auto nearBall = [&](const Box& cellBox) { return cellBox.exteriorDistance(c) <= rad; };
    const Box bounds(c - Vec3d::Constant(rad), c + Vec3d::Constant(rad));
    const auto got = h.elements(bounds, nearBall);
    ASSERT_EQ(got, bruteForceCells(h, boxes, bounds, nearBall)) << "query " << i;
    // Every element whose box meets the ball is among them.
    for (std::size_t e = 0; e < boxes.size(); ++e)
      if (boxes[e].exteriorDistance(c) <= rad) {
        ASSERT_TRUE(std::binary_search(got.begin(), got.end(), static_cast<std::uint32_t>(e)));
      }
    mark.clear();
    h.markElements(bounds, nearBall, mark);
    ASSERT_EQ(mark.size(), boxes.size());
    std::vector<std::uint32_t> marked;
    for (std::size_t e = 0; e < mark.size(); ++e)
      if (mark[e]) marked.push_back(static_cast<std::uint32_t>(e));
    ASSERT_EQ(marked, got);
  }
  // Marks accumulate over queries of the same size.
  mark.assign(boxes.size(), 0);
  auto yes = [](const Box&) { return true; };
  h.markElements(boxes[0], yes, mark);
  h.markElements(boxes[1], yes, mark);
  EXPECT_EQ(mark[0], 1);
  EXPECT_EQ(mark[1], 1);
}

TEST(SpatialHash, SameForAnyThreadCount) {
  const std::vector<Box> boxes = randomBoxes(9, 20000, 0.1);
  SpatialHash one, two;
  {
    ThreadLimit limit(1);
    one.build(boxes);
  }
  {
    ThreadLimit limit(2);
    two.build(boxes);
  }
  ASSERT_EQ(one.entryCount(), two.entryCount());
  const Index3 lo = one.cellOf(Vec3d::Constant(-1.0)), hi = one.cellOf(Vec3d::Constant(1.1));
  std::size_t seen = 0;
  for (int z = lo.z; z <= hi.z; ++z)
    for (int y = lo.y; y <= hi.y; ++y)
      for (int x = lo.x; x <= hi.x; ++x) {
        const auto a = one.cellElements({x, y, z});
        ASSERT_EQ(a, two.cellElements({x, y, z}));
        ASSERT_TRUE(std::is_sorted(a.begin(), a.end()));
        ASSERT_EQ(std::adjacent_find(a.begin(), a.end()), a.end());
        seen += a.size();
      }
  EXPECT_EQ(seen, one.entryCount());
}

TEST(SpatialHash, EmptyAndUnbuilt) {
  SpatialHash h;
  EXPECT_TRUE(h.elementsInBox(Box(Vec3d::Zero(), Vec3d::Ones())).empty());
  h.build({});
  EXPECT_EQ(h.elementCount(), 0u);
  EXPECT_TRUE(h.elementsInBox(Box(Vec3d::Zero(), Vec3d::Ones())).empty());
  h.build({Box(), Box(Vec3d::Ones(), Vec3d::Ones())});  // one empty box, one point
  EXPECT_EQ(h.cellSize(), 1.0);
  EXPECT_EQ(h.elementsInBox(Box(Vec3d::Zero(), Vec3d::Ones())), (std::vector<std::uint32_t>{1}));
}

TEST(SpatialHash, DeformedBunnyElements) {
  VoxelizeParams p;
  p.resolution.resolution = 101;
  const VoxelGrid g = voxelize(loadModel("bunny").materials, p);
  DeformationOctree oc = buildDeformationOctree(g);
  applyDeformation(oc, Deformation::Twist);
  std::vector<Box> boxes;
  oc.updateElementBounds(boxes);
  SpatialHash h;
  h.build(boxes);
  const Box all = oc.restVoxelBounds();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    const Vec3d a = all.min() + all.sizes().cwiseProduct(Vec3d(u(rng), u(rng), u(rng)));
    const Vec3d b = a + 0.3 * all.sizes().cwiseProduct(Vec3d(u(rng), u(rng), u(rng)));
    ASSERT_EQ(h.elementsInBox(Box(a, b)), bruteForce(boxes, Box(a, b)));
  }
}

}  // namespace
}  // namespace voxcut
