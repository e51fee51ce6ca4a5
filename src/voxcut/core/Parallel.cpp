#include "voxcut/core/Parallel.h"

namespace voxcut {

ThreadLimit::ThreadLimit(int threads) {
  if (threads > 0)
    control_ = std::make_unique<tbb::global_control>(
        tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
}

int ThreadLimit::current() {
  return static_cast<int>(
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

}  // namespace voxcut
