#pragma once
/// @file SlotTable.h
/// What turns the world's typed handles into positions in its dense arrays of bodies, tools
/// and obstacles (sim/WorldTypes.h, Handle). Internal to the world.
///
/// Each handle names a slot and the slot's generation when it was made. A slot holds the
/// position of its object in the dense array (the order of addition) or nothing once removed;
/// a later addition may take the slot again under a new generation. Generations come from one
/// counter of the process that only grows, so no two handles ever made are equal: an old
/// handle is refused, never taken for a newer object, and a handle of another world names
/// nothing in this one (unless this world restored that world's snapshot).

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "voxcut/sim/WorldTypes.h"

namespace voxcut {

/// A handle generation never given out before in this process (SlotTable::add).
inline std::uint32_t newHandleGeneration() {
  static std::atomic<std::uint32_t> last{0};
  return last.fetch_add(1, std::memory_order_relaxed);
}

template <class Tag>
class SlotTable {
 public:
  using Id = Handle<Tag>;

  /// A handle for a new object appended at the end of the dense array.
  Id add() {
    std::uint32_t slot;
    if (!free_.empty()) {
      slot = free_.back();
      free_.pop_back();
    } else {
      slot = static_cast<std::uint32_t>(generation_.size());
      generation_.push_back(0);
      position_.push_back(kDead);
    }
    generation_[slot] = newHandleGeneration();
    position_[slot] = static_cast<std::uint32_t>(order_.size());
    order_.push_back(slot);
    return Id(slot, generation_[slot]);
  }

  /// The dense position of the object `id` names, or nothing for an unknown or stale handle.
  [[nodiscard]] std::optional<std::size_t> find(Id id) const {
    if (!id.valid() || id.slot() >= generation_.size()) return std::nullopt;
    if (generation_[id.slot()] != id.generation() || position_[id.slot()] == kDead)
      return std::nullopt;
    return position_[id.slot()];
  }

  /// Removes the object at dense position `p` (the caller erases it from its array): later
  /// objects move one position down.
  void removeAt(std::size_t p) {
    const std::uint32_t slot = order_[p];
    position_[slot] = kDead;
    free_.push_back(slot);
    order_.erase(order_.begin() + static_cast<std::ptrdiff_t>(p));
    for (std::size_t q = p; q < order_.size(); ++q)
      position_[order_[q]] = static_cast<std::uint32_t>(q);
  }

  /// The handle of the object at dense position `p`.
  [[nodiscard]] Id at(std::size_t p) const { return Id(order_[p], generation_[order_[p]]); }

  /// Every live handle, in dense order.
  [[nodiscard]] std::vector<Id> all() const {
    std::vector<Id> out;
    out.reserve(order_.size());
    for (std::size_t p = 0; p < order_.size(); ++p) out.push_back(at(p));
    return out;
  }

  [[nodiscard]] std::size_t size() const { return order_.size(); }

  /// Becomes `earlier` (a copy of this table from before): its objects' handles are valid
  /// again, and every handle made since is refused (its generation is one `earlier` never
  /// had).
  void restoreFrom(const SlotTable& earlier) { *this = earlier; }

 private:
  static constexpr std::uint32_t kDead = 0xffffffffu;
  std::vector<std::uint32_t> generation_;  ///< per slot
  std::vector<std::uint32_t> position_;    ///< per slot: dense position, or kDead
  std::vector<std::uint32_t> order_;       ///< per dense position: its slot
  std::vector<std::uint32_t> free_;        ///< removed slots, taken again last in, first out
};

}  // namespace voxcut
