#pragma once
/// @file SpatialHash.h
/// Spatial hash of element bounding boxes (docs/algorithms.md, "Culling"), shared by the
/// cutting tool, the probe and object collisions. Space is cut into cubic cells of edge `cellSize`
/// (metres); cell (i, j, k) is [i, i+1) x [j, j+1) x [k, k+1) times cellSize, and a box is
/// registered in every cell its closed extent touches. Cells are hashed into a table of about twice
/// as many buckets as (cell, element) entries, so memory follows the content, not the space it
/// spans.
///
/// Rebuilt each frame with build(): per-box work runs in parallel into fixed slots, then one
/// stable counting sort by bucket, so the contents of every cell are in increasing element id
/// whatever the thread count. Queries are const and may run concurrently with each other, not
/// with build().

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

/// Spatial hash of axis-aligned boxes, identified by their index in the built list.
class SpatialHash {
 public:
  SpatialHash() = default;

  /// Rebuilds the hash over `boxes` (metres; element e is boxes[e]). Empty or non-finite boxes
  /// are not registered. cellSize <= 0 picks the largest side of any registered box (1 when
  /// every box is a point). O(#boxes + #entries); deterministic for any thread count.
  void build(const std::vector<Eigen::AlignedBox3d>& boxes, double cellSize = 0.0,
             bool threaded = true);

  [[nodiscard]] double cellSize() const { return cellSize_; }
  /// Number of boxes given to the last build (registered or not).
  [[nodiscard]] std::size_t elementCount() const { return boxes_.size(); }
  /// Number of (cell, element) entries.
  [[nodiscard]] std::size_t entryCount() const { return entries_.size(); }
  [[nodiscard]] const Eigen::AlignedBox3d& elementBox(std::uint32_t e) const { return boxes_[e]; }

  /// The cell holding point p (coordinates clamped to +-2^30).
  [[nodiscard]] Index3 cellOf(const Vec3d& p) const;
  /// The extent of a cell, padded by 1e-9 of a cell (and of its distance from 0) so that
  /// rounding never makes a touching box miss it.
  [[nodiscard]] Eigen::AlignedBox3d cellBox(const Index3& cell) const;
  /// Elements registered in `cell`, in increasing id.
  [[nodiscard]] std::vector<std::uint32_t> cellElements(const Index3& cell) const;
  /// Calls fn(element) for each element registered in `cell`, in increasing id (no
  /// allocation).
  template <class Fn>
  void forEachInCell(const Index3& cell, Fn&& fn) const {
    const std::uint64_t b = bucketOf(cell);
    for (std::uint32_t k = bucketStart_[b]; k < bucketStart_[b + 1]; ++k)
      if (entries_[k].cell == cell) fn(entries_[k].element);
  }

  /// How many cells a query over `bounds` visits: those touching it, clipped to the cells
  /// holding entries (0 when none). A double: the count may exceed any integer type.
  [[nodiscard]] double cellsTouching(const Eigen::AlignedBox3d& bounds) const {
    Index3 lo, hi;
    if (!cellRange(bounds, lo, hi)) return 0.0;
    return (hi.x - lo.x + 1.0) * (hi.y - lo.y + 1.0) * (hi.z - lo.z + 1.0);
  }

  /// Elements whose box overlaps `box` (closed boxes), sorted and unique.
  [[nodiscard]] std::vector<std::uint32_t> elementsInBox(const Eigen::AlignedBox3d& box) const;

  /// Elements registered in any non-empty cell that touches `bounds` and for which
  /// overlapsCell(cellBox(cell)) is true (e.g. an OBB test), sorted and unique. The element
  /// boxes themselves are not tested. overlapsCell: bool(const Eigen::AlignedBox3d&), called
  /// once per non-empty cell.
  template <class CellTest>
  [[nodiscard]] std::vector<std::uint32_t> elements(const Eigen::AlignedBox3d& bounds,
                                                    CellTest&& overlapsCell) const {
    std::vector<std::uint32_t> out;
    visitCells(bounds, overlapsCell, [&](std::uint32_t e) { out.push_back(e); });
    sortUnique(out);
    return out;
  }

  /// As elements(), but sets mark[e] = 1 for each element found instead of listing them. When
  /// mark.size() != elementCount() it is first reset to that many zeros; otherwise marks are
  /// only ever set, so consecutive queries accumulate (the caller clears).
  template <class CellTest>
  void markElements(const Eigen::AlignedBox3d& bounds, CellTest&& overlapsCell,
                    std::vector<std::uint8_t>& mark) const {
    if (mark.size() != boxes_.size()) mark.assign(boxes_.size(), 0);
    visitCells(bounds, overlapsCell, [&](std::uint32_t e) { mark[e] = 1; });
  }

 private:
  struct Entry {
    Index3 cell;
    std::uint32_t element = 0;
  };

  [[nodiscard]] std::uint64_t bucketOf(const Index3& cell) const;
  /// Cells of `bounds` clipped to the cells that hold entries; false when none.
  [[nodiscard]] bool cellRange(const Eigen::AlignedBox3d& bounds, Index3& lo, Index3& hi) const;
  static void sortUnique(std::vector<std::uint32_t>& ids);

  /// For each non-empty cell touching `bounds` that passes `test`, emit(element) for each of
  /// its elements (an element in several cells is emitted once per cell).
  template <class CellTest, class Emit>
  void visitCells(const Eigen::AlignedBox3d& bounds, CellTest& test, Emit&& emit) const {
    visitCellsWithCell(bounds, test, [&](const Index3&, std::uint32_t e) { emit(e); });
  }
  /// As visitCells, with emit(cell, element).
  template <class CellTest, class Emit>
  void visitCellsWithCell(const Eigen::AlignedBox3d& bounds, CellTest& test, Emit&& emit) const {
    Index3 lo, hi;
    if (!cellRange(bounds, lo, hi)) return;
    for (int z = lo.z; z <= hi.z; ++z)
      for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
          const Index3 c{x, y, z};
          const std::uint64_t b = bucketOf(c);
          const Entry* first = entries_.data() + bucketStart_[b];
          const Entry* last = entries_.data() + bucketStart_[b + 1];
          const Entry* hit = first;
          while (hit != last && !(hit->cell == c)) ++hit;
          if (hit == last || !test(cellBox(c))) continue;
          for (const Entry* p = hit; p != last; ++p)
            if (p->cell == c) emit(c, p->element);
        }
  }

  double cellSize_ = 1.0;
  double invCellSize_ = 1.0;
  std::vector<Eigen::AlignedBox3d> boxes_;
  std::vector<std::uint32_t> bucketStart_ = std::vector<std::uint32_t>(2, 0);  ///< #buckets + 1
  std::vector<Entry> entries_;  ///< grouped by bucket, increasing element id within a bucket
  std::uint64_t mask_ = 0;      ///< #buckets - 1 (a power of two)
  Index3 cellMin_{0, 0, 0}, cellMax_{-1, -1, -1};  ///< cells holding entries (empty when max < min)
};

}  // namespace voxcut
