#pragma once
/// @file Parallel.h
/// The one parallel wrapper over oneTBB (STYLE.md item 5). Every parallel loop in voxcut goes
/// through parallelFor; results must never depend on the thread count, so bodies write into
/// fixed slots or their outputs are sorted afterwards.

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <cstddef>
#include <memory>

namespace voxcut {

/// Runs body(begin, end) over sub-ranges of [begin, end). With `threaded` false, or a range
/// no larger than `grain`, it runs serially on the calling thread.
template <class Body>
void parallelFor(std::size_t begin, std::size_t end, std::size_t grain, Body&& body,
                 bool threaded = true) {
  if (end <= begin) return;
  if (!threaded || end - begin <= grain) {
    body(begin, end);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

/// Limits the worker threads for its lifetime (0 = leave the default). Not copyable.
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;
  /// Threads the scheduler may use now.
  [[nodiscard]] static int current();

 private:
  std::unique_ptr<tbb::global_control> control_;
};

}  // namespace voxcut
