#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "voxcut/collision/LayeredHash.h"
#include "voxcut/core/Parallel.h"

namespace voxcut {
namespace {

using Box = Eigen::AlignedBox3d;

// Boxes whose sides span four orders of magnitude (a body refined along a cut: many fine
// elements among a few coarse ones), plus an empty and a non-finite one.
std::vector<Box> mixedBoxes(unsigned seed, std::size_t n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-1.0, 1.0), exponent(-4.0, 0.0), unit(0.5, 1.0);
  std::vector<Box> boxes(n);
  for (auto& b : boxes) {
    const Vec3d lo(pos(rng), pos(rng), pos(rng));
    const double side = std::pow(10.0, exponent(rng));
    b = Box(lo, lo + side * Vec3d(unit(rng), unit(rng), unit(rng)));
  }
  boxes[3] = Box();
  boxes[5] = Box(Vec3d::Zero(), Vec3d(std::numeric_limits<double>::infinity(), 1, 1));
  return boxes;
}

std::vector<std::uint32_t> bruteForce(const std::vector<Box>& boxes, const Box& q) {
  std::vector<std::uint32_t> out;
  for (std::size_t e = 0; e < boxes.size(); ++e)
    if (!boxes[e].isEmpty() && boxes[e].min().allFinite() && boxes[e].max().allFinite() &&
        boxes[e].intersects(q))
      out.push_back(static_cast<std::uint32_t>(e));
  return out;
}

TEST(LayeredHash, BoxQueriesMatchBruteForceAcrossSizes) {
  const std::vector<Box> boxes = mixedBoxes(3, 3000);
  LayeredHash h;
  h.build(boxes);
  EXPECT_EQ(h.elementCount(), boxes.size());
  EXPECT_GE(h.layerCount(), 10u);  // sides from 1e-4 to 1: some 13 powers of two
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> pos(-1.2, 1.2), exponent(-4.0, 0.0);
  for (int i = 0; i < 300; ++i) {
    const Vec3d lo(pos(rng), pos(rng), pos(rng));
    const Box q(lo, lo + Vec3d::Constant(std::pow(10.0, exponent(rng))));
    ASSERT_EQ(h.elementsInBox(q), bruteForce(boxes, q)) << "query " << i;
  }
  EXPECT_TRUE(h.elementsInBox(Box()).empty());
}

// elements() lists a superset of the boxes that meet the query's cells (the boxes are not
// tested), sorted and unique; a test that refuses every cell lists nothing.
TEST(LayeredHash, CellQueriesHoldEveryOverlapAndAreSortedAndUnique) {
  const std::vector<Box> boxes = mixedBoxes(5, 2000);
  LayeredHash h;
  h.build(boxes);
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> pos(-1.0, 1.0);
  for (int i = 0; i < 100; ++i) {
    const Vec3d lo(pos(rng), pos(rng), pos(rng));
    const Box q(lo, lo + Vec3d::Constant(0.05));
    const auto got = h.elements(q, [](const Box&) { return true; });
    EXPECT_TRUE(std::is_sorted(got.begin(), got.end()));
    EXPECT_EQ(std::adjacent_find(got.begin(), got.end()), got.end());
    for (const std::uint32_t e : bruteForce(boxes, q))
      ASSERT_TRUE(std::binary_search(got.begin(), got.end(), e)) << e;
    EXPECT_TRUE(h.elements(q, [](const Box&) { return false; }).empty());
  }
}

// forEachNear calls every box that holds the point, each once.
TEST(LayeredHash, PointQueriesReachEveryBoxHoldingThePoint) {
  const std::vector<Box> boxes = mixedBoxes(7, 2000);
  LayeredHash h;
  h.build(boxes);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> pos(-1.0, 1.0);
  for (int i = 0; i < 500; ++i) {
    const Vec3d p(pos(rng), pos(rng), pos(rng));
    std::vector<std::uint32_t> got;
    h.forEachNear(p, [&](std::uint32_t e) { got.push_back(e); });
    std::vector<std::uint32_t> sorted = got;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
    for (const std::uint32_t e : bruteForce(boxes, Box(p, p)))
      ASSERT_TRUE(std::binary_search(sorted.begin(), sorted.end(), e)) << e;
  }
}

TEST(LayeredHash, SameAnswersForAnyThreadCount) {
  const std::vector<Box> boxes = mixedBoxes(9, 5000);
  LayeredHash one, two;
  {
    ThreadLimit limit(1);
    one.build(boxes);
  }
  {
    ThreadLimit limit(2);
    two.build(boxes);
  }
  const Box q(Vec3d::Constant(-0.3), Vec3d::Constant(0.4));
  const auto all = [](const Box&) { return true; };
  EXPECT_EQ(one.elements(q, all), two.elements(q, all));
  std::vector<std::uint32_t> a, b;
  one.forEachNear(Vec3d(0.1, 0.2, 0.3), [&](std::uint32_t e) { a.push_back(e); });
  two.forEachNear(Vec3d(0.1, 0.2, 0.3), [&](std::uint32_t e) { b.push_back(e); });
  EXPECT_EQ(a, b);
}

TEST(LayeredHash, EmptyAndDegenerateInputs) {
  LayeredHash h;
  h.build({});
  EXPECT_EQ(h.layerCount(), 0u);
  EXPECT_TRUE(h.elementsInBox(Box(Vec3d::Zero(), Vec3d::Ones())).empty());
  // Points only (zero sides): one layer, found by a box around them.
  h.build({Box(Vec3d::Zero(), Vec3d::Zero()), Box(Vec3d::Ones(), Vec3d::Ones())});
  EXPECT_EQ(h.layerCount(), 1u);
  EXPECT_EQ(h.elementsInBox(Box(Vec3d::Constant(-0.5), Vec3d::Constant(0.5))),
            std::vector<std::uint32_t>{0});
}

}  // namespace
}  // namespace voxcut
