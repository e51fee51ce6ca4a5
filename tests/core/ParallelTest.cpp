#include <gtest/gtest.h>

#include <atomic>
#include <vector>

#include "voxcut/core/Parallel.h"

namespace voxcut {
namespace {

TEST(Parallel, CoversEveryIndexOnceForAnyThreadCount) {
  for (int threads : {1, 2, 3}) {
    ThreadLimit limit(threads);
    std::vector<int> hits(10007, 0);
    parallelFor(0, hits.size(), 64, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) ++hits[i];
    });
    for (int h : hits) ASSERT_EQ(h, 1);
  }
}

TEST(Parallel, WakingTheWorkersChangesNoResult) {
  for (int threads : {1, 2, 3}) {
    ThreadLimit limit(threads);
    for (int round = 0; round < 20; ++round) {
      wakeWorkers();
      std::vector<int> hits(4099, 0);
      parallelFor(0, hits.size(), 16, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) ++hits[i];
      });
      for (int h : hits) ASSERT_EQ(h, 1);
    }
  }
}

TEST(Parallel, SerialSwitchRunsOnCallingThreadInOrder) {
  std::vector<std::size_t> order;
  parallelFor(
      5, 50, 1,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) order.push_back(i);
      },
      /*threaded=*/false);
  ASSERT_EQ(order.size(), 45u);
  for (std::size_t i = 0; i < order.size(); ++i) EXPECT_EQ(order[i], i + 5);
}

TEST(Parallel, EmptyRangeDoesNothing) {
  bool called = false;
  parallelFor(3, 3, 1, [&](std::size_t, std::size_t) { called = true; });
  EXPECT_FALSE(called);
}

TEST(Parallel, ThreadLimitIsScoped) {
  const int before = ThreadLimit::current();
  {
    ThreadLimit limit(1);
    EXPECT_EQ(ThreadLimit::current(), 1);
  }
  EXPECT_EQ(ThreadLimit::current(), before);
}

}  // namespace
}  // namespace voxcut
