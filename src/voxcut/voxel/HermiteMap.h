#pragma once
/// @file HermiteMap.h
/// Sparse Hermite data keyed by link id, in a flat hash map. Links crossed by a surface, an
/// interface or a cut are a small fraction of all links, so a dense array would waste most of its
/// memory.

#include <cstdint>
#include <optional>
#include <vector>

#include "voxcut/core/FlatHashMap.h"

namespace voxcut {

/// Hermite data of one link, in the rest (material) frame.
/// `t` in (0,1) is the crossing parameter from the link's low voxel v to v + e_axis.
/// `n` is the unit surface normal, stored with n[axis] >= 0: it is the outward normal of the
/// material at the link's low end (the high end's outward normal is -n).
struct Hermite {
  float t = 0.5f;
  float n[3] = {0.f, 0.f, 0.f};
};

/// Link id -> Hermite: a FlatHashMap (core/FlatHashMap.h) with the link-specific calls. Not
/// thread-safe for concurrent writes; concurrent reads are fine.
class HermiteMap {
 public:
  /// Number of stored links.
  [[nodiscard]] std::size_t size() const { return map_.size(); }
  /// Bytes held by the table.
  [[nodiscard]] std::size_t bytes() const { return map_.bytes(); }

  /// Inserts or replaces the entry of `link`.
  void set(std::uint64_t link, const Hermite& h) { map_.set(link, h); }
  /// As set, returning the entry it replaced, if any (one probe instead of find + set).
  std::optional<Hermite> exchange(std::uint64_t link, const Hermite& h) {
    return map_.exchange(link, h);
  }
  /// How many links ahead a loop that sets many links prefetches (the table is large and its
  /// slots scattered: a miss costs about as much as a few dozen exchanges that hit).
  static constexpr std::size_t kPrefetchAhead = 24;
  /// Hints the processor to fetch the table slot where `link` would start its probe (for a
  /// loop that sets many links: their slots are scattered over the table).
  void prefetch(std::uint64_t link) const { map_.prefetch(link); }
  /// Pointer to the entry of `link`, or nullptr.
  [[nodiscard]] const Hermite* find(std::uint64_t link) const { return map_.find(link); }
  /// Removes `link` if present; returns whether it was.
  bool erase(std::uint64_t link) { return map_.erase(link); }
  /// Pre-sizes the table for `n` entries.
  void reserve(std::size_t n) { map_.reserve(n); }

  /// Calls fn(link, hermite) for every entry, in table order (not sorted).
  template <class Fn>
  void forEach(Fn&& fn) const {
    map_.forEach(fn);
  }
  /// All stored link ids, sorted ascending.
  [[nodiscard]] std::vector<std::uint64_t> sortedLinks() const;

 private:
  FlatHashMap<Hermite> map_;
};

}  // namespace voxcut
