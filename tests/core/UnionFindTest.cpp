#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "voxcut/core/UnionFind.h"

namespace voxcut {
namespace {

TEST(UnionFind, RootIsTheLowestElementWhateverTheOrderOfUnions) {
  const std::uint32_t n = 2000;
  std::mt19937 rng(3);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (int i = 0; i < 1500; ++i) pairs.emplace_back(rng() % n, rng() % n);
  // Reference: labels by repeated relaxation to the minimum over the pairs.
  std::vector<std::uint32_t> label(n);
  std::iota(label.begin(), label.end(), 0u);
  for (bool changed = true; changed;) {
    changed = false;
    for (const auto& [a, b] : pairs) {
      const std::uint32_t m = std::min(label[a], label[b]);
      changed |= label[a] != m || label[b] != m;
      label[a] = label[b] = m;
    }
  }
  for (int order = 0; order < 3; ++order) {
    UnionFind sets(n);
    for (const auto& [a, b] : pairs) sets.unite(a, b);
    for (std::uint32_t i = 0; i < n; ++i) ASSERT_EQ(sets.find(i), label[i]);
    std::shuffle(pairs.begin(), pairs.end(), rng);
  }
}

TEST(UnionFind, UniteReportsWhetherSetsWereApartAndResetReuses) {
  UnionFind sets(4);
  EXPECT_TRUE(sets.unite(3, 1));
  EXPECT_FALSE(sets.unite(1, 3));
  EXPECT_TRUE(sets.same(1, 3));
  EXPECT_FALSE(sets.same(0, 3));
  EXPECT_EQ(sets.find(3), 1u);
  sets.reset(3);
  EXPECT_EQ(sets.size(), 3u);
  for (std::uint32_t i = 0; i < 3; ++i) EXPECT_EQ(sets.find(i), i);
}

}  // namespace
}  // namespace voxcut
