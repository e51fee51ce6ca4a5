#pragma once
/// @file FlatHashMap.h
/// The one hash map of voxcut: 64-bit keys (link, voxel, cube, cell, face or node-grid point
/// ids) to small values, stored flat. Open addressing with linear probing over a power-of-two
/// table at most half full; the probe starts at the high bits of the hashed key; erase shifts
/// later entries of the run back, so there are no tombstones. A lookup touches one or two cache
/// lines where std::unordered_map follows a pointer to a node.
///
/// Thread safety: const members may run concurrently; a non-const member needs exclusive
/// access. Pointers into the table stay valid until the next insertion (which may rehash) or
/// erase.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "voxcut/core/Error.h"

namespace voxcut {

/// Fibonacci hashing: the key times 2^64 / golden ratio; the map reads the high bits.
struct FibonacciHash {
  [[nodiscard]] std::uint64_t operator()(std::uint64_t key) const {
    return key * 0x9E3779B97F4A7C15ull;
  }
};

/// Hash map from 64-bit keys to values of type T (default-constructible and copyable). The key
/// ~0 is reserved (it marks an empty slot). Hash maps a key to 64 bits whose high bits are well
/// mixed. Iteration order is the table order: it depends on the history of insertions and
/// erasures, so a result that must be deterministic sorts the keys (or never iterates).
template <class T, class Hash = FibonacciHash>
class FlatHashMap {
 public:
  /// The reserved key (an empty slot).
  static constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};

  FlatHashMap() { rehash(kMinCapacity); }

  /// Number of stored keys.
  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  /// Bytes held by the table.
  [[nodiscard]] std::size_t bytes() const {
    return keys_.capacity() * sizeof(std::uint64_t) + values_.capacity() * sizeof(T);
  }

  /// The value of `key`, or nullptr.
  [[nodiscard]] T* find(std::uint64_t key) {
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) return &values_[i];
      if (keys_[i] == kEmptyKey) return nullptr;
    }
  }
  [[nodiscard]] const T* find(std::uint64_t key) const {
    return const_cast<FlatHashMap*>(this)->find(key);
  }
  [[nodiscard]] bool contains(std::uint64_t key) const { return find(key) != nullptr; }
  /// The value of `key`, which must be present (checked).
  [[nodiscard]] const T& at(std::uint64_t key) const {
    const T* v = find(key);
    VOXCUT_ASSERT(v != nullptr, "key not in the map");
    return *v;
  }

  /// The value of `key`, default-constructed when absent.
  T& operator[](std::uint64_t key) {
    const std::size_t i = slotOf(key).first;
    return values_[i];
  }
  /// Inserts `key` with `value` or overwrites its value.
  void set(std::uint64_t key, const T& value) {
    const std::size_t i = slotOf(key).first;
    values_[i] = value;
  }
  /// As set, returning the value it replaced, if any (one probe instead of find + set).
  std::optional<T> exchange(std::uint64_t key, const T& value) {
    const auto [i, inserted] = slotOf(key);
    std::optional<T> old;
    if (!inserted) old = values_[i];
    values_[i] = value;
    return old;
  }
  /// Inserts (key, value) when `key` is absent; returns whether it did.
  bool insert(std::uint64_t key, const T& value = T{}) {
    const auto [i, inserted] = slotOf(key);
    if (inserted) values_[i] = value;
    return inserted;
  }
  /// Removes `key` if present; returns whether it was.
  bool erase(std::uint64_t key) {
    std::size_t i = home(key);
    for (; keys_[i] != key; i = (i + 1) & mask_)
      if (keys_[i] == kEmptyKey) return false;
    // Shift back each later entry of the run whose home does not lie in (i, j].
    for (std::size_t j = (i + 1) & mask_; keys_[j] != kEmptyKey; j = (j + 1) & mask_) {
      if (((j - home(keys_[j])) & mask_) >= ((j - i) & mask_)) {
        keys_[i] = keys_[j];
        values_[i] = std::move(values_[j]);
        i = j;
      }
    }
    keys_[i] = kEmptyKey;
    --size_;
    return true;
  }
  /// Pre-sizes the table for `n` keys (no rehash until more are stored).
  void reserve(std::size_t n) {
    std::size_t c = keys_.size();
    while (c < 2 * n) c *= 2;
    if (c > keys_.size()) rehash(c);
  }

  /// Hints the processor to fetch the slot where the probe for `key` starts (for a loop over
  /// many scattered keys of a large table).
  void prefetch(std::uint64_t key) const {
    const std::size_t i = home(key);
    __builtin_prefetch(&keys_[i]);
    __builtin_prefetch(&values_[i]);
  }

  /// Calls fn(key, value) for every entry, in table order (see the class comment).
  template <class Fn>
  void forEach(Fn&& fn) const {
    for (std::size_t i = 0; i < keys_.size(); ++i)
      if (keys_[i] != kEmptyKey) fn(keys_[i], values_[i]);
  }

 private:
  static constexpr std::size_t kMinCapacity = 16;

  [[nodiscard]] std::size_t home(std::uint64_t key) const {
    return static_cast<std::size_t>(Hash{}(key) >> shift_);
  }
  /// The slot of `key`, inserting it (with a default value) when absent; whether it did.
  std::pair<std::size_t, bool> slotOf(std::uint64_t key) {
    VOXCUT_ASSERT(key != kEmptyKey, "the reserved key ~0 stored in a FlatHashMap");
    if (2 * (size_ + 1) > keys_.size()) rehash(2 * keys_.size());
    std::size_t i = home(key);
    for (; keys_[i] != kEmptyKey; i = (i + 1) & mask_)
      if (keys_[i] == key) return {i, false};
    keys_[i] = key;
    values_[i] = T{};
    ++size_;
    return {i, true};
  }
  void rehash(std::size_t capacity) {
    std::vector<std::uint64_t> keys(capacity, kEmptyKey);
    std::vector<T> values(capacity);
    keys.swap(keys_);
    values.swap(values_);
    mask_ = capacity - 1;
    shift_ = 64;
    for (std::size_t c = capacity; c > 1; c /= 2) --shift_;
    for (std::size_t k = 0; k < keys.size(); ++k) {
      if (keys[k] == kEmptyKey) continue;
      std::size_t j = home(keys[k]);
      while (keys_[j] != kEmptyKey) j = (j + 1) & mask_;
      keys_[j] = keys[k];
      values_[j] = std::move(values[k]);
    }
  }

  std::vector<std::uint64_t> keys_;
  std::vector<T> values_;
  std::size_t mask_ = 0;
  std::size_t size_ = 0;
  int shift_ = 64;
};

}  // namespace voxcut
