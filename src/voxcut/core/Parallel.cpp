#include "voxcut/core/Parallel.h"

#include <tbb/task_arena.h>

namespace voxcut {

ThreadLimit::ThreadLimit(int threads) {
  if (threads > 0)
    control_ = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                     static_cast<std::size_t>(threads));
}

int threadSlots() {
  return tbb::this_task_arena::max_concurrency();
}

int threadSlot() {
  // Outside any arena (a serial caller) the index is negative: slot 0, which no task of a
  // running parallelFor uses at the same time as its caller runs serially.
  const int i = tbb::this_task_arena::current_thread_index();
  return i >= 0 ? i : 0;
}

void wakeWorkers() {
  if (ThreadLimit::current() > 1) tbb::this_task_arena::enqueue([] {});
}

int ThreadLimit::current() {
  return static_cast<int>(
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

}  // namespace voxcut
