#pragma once
/// @file Fnv.h
/// The 64-bit FNV-1a hash over 64-bit values, each fed as its 8 bytes from the lowest: the
/// hash of cut sets (cutting/CutStep.h, cutSetHash) and of several bodies' hashes together
/// (World::cutSetHash). Equal sequences give equal hashes on every platform.

#include <cstdint>

namespace voxcut {

class Fnv1a {
 public:
  /// Feeds the value's 8 bytes (two's complement for negative ones), lowest first.
  void add(std::uint64_t value) {
    for (int i = 0; i < 8; ++i) {
      hash_ ^= (value >> (8 * i)) & 0xffu;
      hash_ *= kPrime;
    }
  }
  void add(std::int64_t value) { add(static_cast<std::uint64_t>(value)); }
  [[nodiscard]] std::uint64_t value() const { return hash_; }

 private:
  static constexpr std::uint64_t kOffset = 0xcbf29ce484222325ULL;
  static constexpr std::uint64_t kPrime = 0x100000001b3ULL;
  std::uint64_t hash_ = kOffset;
};

}  // namespace voxcut
