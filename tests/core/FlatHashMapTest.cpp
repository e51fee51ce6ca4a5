#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <random>
#include <vector>

#include "voxcut/core/FlatHashMap.h"

namespace voxcut {
namespace {

/// A hash that sends every key to the same probe start: all keys share one run, so erase
/// must shift entries back across the whole run (and around the end of the table).
struct CollidingHash {
  std::uint64_t operator()(std::uint64_t key) const { return (key & 1) ? ~std::uint64_t{0} : 0; }
};

template <class Map>
void checkAgainstStdMap(Map& map, std::uint64_t keyRange, int steps) {
  std::mt19937_64 rng(11);
  std::map<std::uint64_t, int> ref;
  for (int step = 0; step < steps; ++step) {
    const std::uint64_t key = rng() % keyRange;
    switch (rng() % 5) {
      case 0:
        map.set(key, step);
        ref[key] = step;
        break;
      case 1:
        ASSERT_EQ(map.erase(key), ref.erase(key) == 1);
        break;
      case 2: {
        const auto old = map.exchange(key, step);
        const auto it = ref.find(key);
        ASSERT_EQ(old.has_value(), it != ref.end());
        if (old) {
          ASSERT_EQ(*old, it->second);
        }
        ref[key] = step;
        break;
      }
      case 3:
        ASSERT_EQ(map.insert(key, -step), ref.emplace(key, -step).second);
        break;
      default: {
        const int* v = map.find(key);
        const auto it = ref.find(key);
        ASSERT_EQ(v != nullptr, it != ref.end());
        if (v) {
          ASSERT_EQ(*v, it->second);
        }
      }
    }
    ASSERT_EQ(map.size(), ref.size());
  }
  std::map<std::uint64_t, int> seen;
  map.forEach([&](std::uint64_t k, int v) { seen[k] = v; });
  EXPECT_EQ(seen, ref);
}

TEST(FlatHashMap, MatchesStdMapUnderRandomOperations) {
  FlatHashMap<int> map;
  checkAgainstStdMap(map, 3000, 200000);
}

TEST(FlatHashMap, MatchesStdMapWhenEveryKeyCollides) {
  FlatHashMap<int, CollidingHash> map;
  checkAgainstStdMap(map, 200, 20000);
}

TEST(FlatHashMap, LargeKeysAndIndexing) {
  FlatHashMap<std::uint32_t> map;
  const std::uint64_t big = ~std::uint64_t{0} - 1;  // the largest key that is not reserved
  map[big] = 5;
  map[0] += 2;
  map[0] += 3;
  EXPECT_EQ(map.at(big), 5u);
  EXPECT_EQ(map.at(0), 5u);
  EXPECT_TRUE(map.contains(big));
  EXPECT_FALSE(map.contains(1));
  EXPECT_EQ(map.size(), 2u);
}

TEST(FlatHashMap, ReserveKeepsEntriesAndCapacity) {
  FlatHashMap<int> map;
  for (int k = 0; k < 100; ++k) map.set(static_cast<std::uint64_t>(k) * 7919, k);
  map.reserve(10000);
  const std::size_t bytes = map.bytes();
  EXPECT_GE(bytes, 2 * 10000 * (sizeof(std::uint64_t) + sizeof(int)));
  for (int k = 100; k < 10000; ++k) map.set(static_cast<std::uint64_t>(k) * 7919, k);
  EXPECT_EQ(map.bytes(), bytes);  // no rehash up to the reserved count
  for (int k = 0; k < 10000; ++k) ASSERT_EQ(*map.find(static_cast<std::uint64_t>(k) * 7919), k);
  EXPECT_EQ(map.find(3), nullptr);
}

}  // namespace
}  // namespace voxcut
