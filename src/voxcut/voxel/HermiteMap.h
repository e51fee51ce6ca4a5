#pragma once
/// @file HermiteMap.h
/// Sparse Hermite data keyed by link id: an open-addressing hash map (linear probing,
/// power-of-two capacity). Links crossed by a surface, an interface or a cut are a small
/// fraction of all links, so a dense array would waste most of its memory.

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "voxcut/core/Error.h"

namespace voxcut {

/// Hermite data of one link, in the rest (material) frame.
/// `t` in (0,1) is the crossing parameter from the link's low voxel v to v + e_axis.
/// `n` is the unit surface normal, stored with n[axis] >= 0: it is the outward normal of the
/// material at the link's low end (the high end's outward normal is -n).
struct Hermite {
  float t = 0.5f;
  float n[3] = {0.f, 0.f, 0.f};
};

/// Link id -> Hermite. Not thread-safe for concurrent writes; concurrent reads are fine.
class HermiteMap {
 public:
  HermiteMap() { rehash(16); }

  /// Number of stored links.
  [[nodiscard]] std::size_t size() const { return size_; }
  /// Bytes held by the table.
  [[nodiscard]] std::size_t bytes() const {
    return keys_.capacity() * sizeof(std::uint64_t) + values_.capacity() * sizeof(Hermite);
  }

  /// Inserts or replaces the entry of `link`.
  void set(std::uint64_t link, const Hermite& h) { (void)exchange(link, h); }
  /// As set, returning the entry it replaced, if any (one probe instead of find + set).
  std::optional<Hermite> exchange(std::uint64_t link, const Hermite& h);
  /// How many links ahead a loop that sets many links prefetches (the table is large and its
  /// slots scattered: a miss costs about as much as a few dozen exchanges that hit).
  static constexpr std::size_t kPrefetchAhead = 24;
  /// Hints the processor to fetch the table slot where `link` would start its probe (for a
  /// loop that sets many links: their slots are scattered over the table).
  void prefetch(std::uint64_t link) const {
    const std::size_t i = hash(link) & (keys_.size() - 1);
    __builtin_prefetch(&keys_[i]);
    __builtin_prefetch(&values_[i]);
  }
  /// Pointer to the entry of `link`, or nullptr.
  [[nodiscard]] const Hermite* find(std::uint64_t link) const;
  /// Removes `link` if present; returns whether it was.
  bool erase(std::uint64_t link);
  /// Pre-sizes the table for `n` entries.
  void reserve(std::size_t n);

  /// Calls fn(link, hermite) for every entry, in table order (not sorted).
  template <class Fn>
  void forEach(Fn&& fn) const {
    for (std::size_t i = 0; i < keys_.size(); ++i)
      if (keys_[i] != kEmpty) fn(keys_[i], values_[i]);
  }
  /// All stored link ids, sorted ascending.
  [[nodiscard]] std::vector<std::uint64_t> sortedLinks() const;

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  static std::size_t hash(std::uint64_t k) {
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdULL;
    k ^= k >> 33;
    return static_cast<std::size_t>(k);
  }
  void rehash(std::size_t capacity);

  std::vector<std::uint64_t> keys_;
  std::vector<Hermite> values_;
  std::size_t size_ = 0;
};

}  // namespace voxcut
