#include "voxcut/voxel/HermiteMap.h"

#include <algorithm>

namespace voxcut {

void HermiteMap::rehash(std::size_t capacity) {
  std::vector<std::uint64_t> oldKeys(capacity, kEmpty);
  std::vector<Hermite> oldValues(capacity);
  oldKeys.swap(keys_);
  oldValues.swap(values_);
  size_ = 0;
  for (std::size_t i = 0; i < oldKeys.size(); ++i)
    if (oldKeys[i] != kEmpty) set(oldKeys[i], oldValues[i]);
}

void HermiteMap::reserve(std::size_t n) {
  std::size_t cap = keys_.size();
  while (cap < 2 * n) cap *= 2;
  if (cap != keys_.size()) rehash(cap);
}

std::optional<Hermite> HermiteMap::exchange(std::uint64_t link, const Hermite& h) {
  VOXCUT_ASSERT(link != kEmpty, "invalid link id");
  if (2 * (size_ + 1) > keys_.size()) rehash(keys_.size() * 2);
  const std::size_t mask = keys_.size() - 1;
  for (std::size_t i = hash(link) & mask;; i = (i + 1) & mask) {
    if (keys_[i] == link) {
      const Hermite old = values_[i];
      values_[i] = h;
      return old;
    }
    if (keys_[i] == kEmpty) {
      keys_[i] = link;
      values_[i] = h;
      ++size_;
      return std::nullopt;
    }
  }
}

const Hermite* HermiteMap::find(std::uint64_t link) const {
  const std::size_t mask = keys_.size() - 1;
  for (std::size_t i = hash(link) & mask;; i = (i + 1) & mask) {
    if (keys_[i] == link) return &values_[i];
    if (keys_[i] == kEmpty) return nullptr;
  }
}

bool HermiteMap::erase(std::uint64_t link) {
  const std::size_t mask = keys_.size() - 1;
  std::size_t i = hash(link) & mask;
  for (;; i = (i + 1) & mask) {
    if (keys_[i] == kEmpty) return false;
    if (keys_[i] == link) break;
  }
  // Backward-shift deletion keeps probe chains intact without tombstones.
  std::size_t j = i;
  for (;;) {
    j = (j + 1) & mask;
    if (keys_[j] == kEmpty) break;
    const std::size_t home = hash(keys_[j]) & mask;
    const bool movable = (j > i) ? (home <= i || home > j) : (home <= i && home > j);
    if (movable) {
      keys_[i] = keys_[j];
      values_[i] = values_[j];
      i = j;
    }
  }
  keys_[i] = kEmpty;
  --size_;
  return true;
}

std::vector<std::uint64_t> HermiteMap::sortedLinks() const {
  std::vector<std::uint64_t> out;
  out.reserve(size_);
  forEach([&](std::uint64_t k, const Hermite&) { out.push_back(k); });
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace voxcut
