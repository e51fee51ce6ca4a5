#include <gtest/gtest.h>

#include <map>
#include <random>

#include "voxcut/voxel/HermiteMap.h"

namespace voxcut {
namespace {

TEST(HermiteMap, MatchesStdMapUnderRandomInsertEraseFind) {
  std::mt19937_64 rng(7);
  HermiteMap map;
  std::map<std::uint64_t, float> ref;
  for (int step = 0; step < 200000; ++step) {
    const std::uint64_t key = rng() % 5000;
    const int op = static_cast<int>(rng() % 3);
    if (op == 0) {
      Hermite h;
      h.t = static_cast<float>(step % 997) / 1000.f;
      map.set(key, h);
      ref[key] = h.t;
    } else if (op == 1) {
      EXPECT_EQ(map.erase(key), ref.erase(key) == 1);
    } else {
      const Hermite* h = map.find(key);
      const auto it = ref.find(key);
      ASSERT_EQ(h != nullptr, it != ref.end());
      if (h) {
        EXPECT_EQ(h->t, it->second);
      }
    }
    ASSERT_EQ(map.size(), ref.size());
  }
  std::vector<std::uint64_t> keys;
  for (const auto& [k, v] : ref) keys.push_back(k);
  EXPECT_EQ(map.sortedLinks(), keys);
}

TEST(HermiteMap, ReserveKeepsEntries) {
  HermiteMap map;
  for (std::uint64_t k = 0; k < 100; ++k) map.set(k * 7919, Hermite{0.25f, {0, 0, 1}});
  map.reserve(100000);
  EXPECT_EQ(map.size(), 100u);
  for (std::uint64_t k = 0; k < 100; ++k) ASSERT_NE(map.find(k * 7919), nullptr);
  EXPECT_EQ(map.find(3), nullptr);
}

}  // namespace
}  // namespace voxcut
