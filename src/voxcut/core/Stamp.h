#pragma once
/// @file Stamp.h
/// Stamps for derived data: a structure takes a new stamp whenever it changes in a way that
/// invalidates what others derived from it, and a holder of derived data keeps the stamp it
/// was derived from. Stamps are unique in the process (copies share theirs, as they share
/// their contents), so a stamp never matches data derived from another structure.

#include <atomic>
#include <cstdint>

namespace voxcut {

/// A stamp never returned before (never 0, which can stand for "nothing derived yet").
inline std::uint64_t newStamp() {
  static std::atomic<std::uint64_t> last{0};
  return last.fetch_add(1, std::memory_order_relaxed) + 1;
}

}  // namespace voxcut
