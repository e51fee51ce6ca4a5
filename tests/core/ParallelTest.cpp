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

// Both halves run once, each with loops of its own, and the call returns after both; without
// threads, the first then the second on the calling thread.
TEST(Parallel, InvokeRunsBothSidesOnceWithTheirOwnLoops) {
  for (int threads : {1, 2, 3}) {
    ThreadLimit limit(threads);
    std::vector<int> left(5003, 0), right(7001, 0);
    parallelInvoke(
        [&] {
          parallelFor(0, left.size(), 16, [&](std::size_t b, std::size_t e) {
            for (std::size_t i = b; i < e; ++i) ++left[i];
          });
        },
        [&] {
          parallelFor(0, right.size(), 16, [&](std::size_t b, std::size_t e) {
            for (std::size_t i = b; i < e; ++i) ++right[i];
          });
        });
    for (int h : left) ASSERT_EQ(h, 1);
    for (int h : right) ASSERT_EQ(h, 1);
  }
  std::vector<int> order;
  parallelInvoke([&] { order.push_back(1); }, [&] { order.push_back(2); }, /*threaded=*/false);
  EXPECT_EQ(order, (std::vector<int>{1, 2}));
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
