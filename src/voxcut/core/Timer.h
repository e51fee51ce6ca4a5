#pragma once
/// @file Timer.h
/// Wall-clock stage timings.

#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace voxcut {

/// Measures elapsed wall time from construction or the last restart.
class Timer {
 public:
  Timer() : start_(std::chrono::steady_clock::now()) {}
  void restart() { start_ = std::chrono::steady_clock::now(); }
  /// Milliseconds since start.
  [[nodiscard]] double ms() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
        .count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

/// Ordered list of (stage name, milliseconds).
using StageTimings = std::vector<std::pair<std::string, double>>;

}  // namespace voxcut
