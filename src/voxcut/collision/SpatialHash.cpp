#include "voxcut/collision/SpatialHash.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"

namespace voxcut {

namespace {

constexpr double kCellLimit = 1073741824.0;  // 2^30: cell coordinates stay far from int overflow

int cellCoordinate(double x, double inv) {
  const double c = std::floor(x * inv);
  if (!(c >= -kCellLimit)) return -(1 << 30);  // also NaN
  return static_cast<int>(std::min(c, kCellLimit));
}

bool registrable(const Eigen::AlignedBox3d& b) {
  return !b.isEmpty() && b.min().allFinite() && b.max().allFinite();
}

}  // namespace

Index3 SpatialHash::cellOf(const Vec3d& p) const {
  return {cellCoordinate(p.x(), invCellSize_), cellCoordinate(p.y(), invCellSize_),
          cellCoordinate(p.z(), invCellSize_)};
}

Eigen::AlignedBox3d SpatialHash::cellBox(const Index3& cell) const {
  const Vec3d lo = cellSize_ * Vec3d(cell.x, cell.y, cell.z);
  const Vec3d hi = lo + Vec3d::Constant(cellSize_);
  const Vec3d pad = (1e-9 * cellSize_) * Vec3d::Ones() + 1e-9 * lo.cwiseAbs();
  return {lo - pad, hi + pad};
}

std::uint64_t SpatialHash::bucketOf(const Index3& c) const {
  std::uint64_t h =
      static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.x)) * 0x9E3779B97F4A7C15ull;
  h ^= static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.y)) * 0xC2B2AE3D27D4EB4Full;
  h ^= static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.z)) * 0x165667B19E3779F9ull;
  h ^= h >> 29;
  return h & mask_;
}

bool SpatialHash::cellRange(const Eigen::AlignedBox3d& bounds, Index3& lo, Index3& hi) const {
  // Infinite bounds are fine: cellOf saturates and the range is clipped to the content.
  if (bounds.isEmpty() || cellMax_.x < cellMin_.x) return false;
  lo = cellOf(bounds.min());
  hi = cellOf(bounds.max());
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::max(lo[a], cellMin_[a]);
    hi[a] = std::min(hi[a], cellMax_[a]);
    if (lo[a] > hi[a]) return false;
  }
  return true;
}

void SpatialHash::sortUnique(std::vector<std::uint32_t>& ids) {
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
}

void SpatialHash::build(const std::vector<Eigen::AlignedBox3d>& boxes, double cellSize,
                        bool threaded) {
  VOXCUT_ASSERT(boxes.size() < 0xffffffffull, "too many boxes for 32-bit element ids");
  boxes_ = boxes;
  const std::size_t n = boxes_.size();

  if (!(cellSize > 0.0) || !std::isfinite(cellSize)) {
    cellSize = 0.0;
    for (const auto& b : boxes_)
      if (registrable(b)) cellSize = std::max(cellSize, b.sizes().maxCoeff());
    if (!(cellSize > 0.0) || !std::isfinite(cellSize)) cellSize = 1.0;
  }
  cellSize_ = cellSize;
  invCellSize_ = 1.0 / cellSize;

  // Per box: its cell range and entry count (fixed slots). Both passes over the boxes run
  // serially for a few thousand boxes (a model's elements before it is cut up: the bunny has
  // 534), where waking the workers would cost more than the pass.
  std::vector<std::array<Index3, 2>> range(n);
  std::vector<std::uint64_t> offset(n + 1, 0);
  parallelFor(
      0, n, 2048,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          if (!registrable(boxes_[i])) {
            offset[i + 1] = 0;
            continue;
          }
          range[i] = {cellOf(boxes_[i].min()), cellOf(boxes_[i].max())};
          std::uint64_t count = 1;
          for (int a = 0; a < 3; ++a)
            count *= static_cast<std::uint64_t>(range[i][1][a] - range[i][0][a] + 1);
          offset[i + 1] = count;
        }
      },
      threaded);
  cellMin_ = {1 << 30, 1 << 30, 1 << 30};
  cellMax_ = {-(1 << 30), -(1 << 30), -(1 << 30)};
  for (std::size_t i = 0; i < n; ++i) {
    if (offset[i + 1] != 0)
      for (int a = 0; a < 3; ++a) {
        cellMin_[a] = std::min(cellMin_[a], range[i][0][a]);
        cellMax_[a] = std::max(cellMax_[a], range[i][1][a]);
      }
    offset[i + 1] += offset[i];
  }
  if (offset[n] == 0) cellMax_ = {-1, -1, -1}, cellMin_ = {0, 0, 0};
  const std::uint64_t total = offset[n];
  VOXCUT_ASSERT(total < 0x7fffffffull, "spatial hash cell size too small for the boxes");

  std::uint64_t buckets = 16;
  while (buckets < 2 * total) buckets *= 2;
  mask_ = buckets - 1;

  // Entries in element order, each with its bucket (fixed slots).
  std::vector<Entry> unsorted(total);
  std::vector<std::uint32_t> bucket(total);
  parallelFor(
      0, n, 2048,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          std::uint64_t k = offset[i];
          if (offset[i + 1] == k) continue;
          const auto& [lo, hi] = range[i];
          for (int z = lo.z; z <= hi.z; ++z)
            for (int y = lo.y; y <= hi.y; ++y)
              for (int x = lo.x; x <= hi.x; ++x, ++k) {
                unsorted[k] = {Index3{x, y, z}, static_cast<std::uint32_t>(i)};
                bucket[k] = static_cast<std::uint32_t>(bucketOf(unsorted[k].cell));
              }
        }
      },
      threaded);

  // Stable counting sort by bucket: within a bucket (so within a cell) element ids increase.
  bucketStart_.assign(buckets + 1, 0);
  for (std::uint64_t k = 0; k < total; ++k) ++bucketStart_[bucket[k] + 1];
  for (std::uint64_t b = 0; b < buckets; ++b) bucketStart_[b + 1] += bucketStart_[b];
  entries_.resize(total);
  std::vector<std::uint32_t> cursor(bucketStart_.begin(), bucketStart_.end() - 1);
  for (std::uint64_t k = 0; k < total; ++k) entries_[cursor[bucket[k]]++] = unsorted[k];
}

std::vector<std::uint32_t> SpatialHash::cellElements(const Index3& cell) const {
  std::vector<std::uint32_t> out;
  forEachInCell(cell, [&](std::uint32_t e) { out.push_back(e); });
  return out;
}

std::vector<std::uint32_t> SpatialHash::elementsInBox(const Eigen::AlignedBox3d& box) const {
  std::vector<std::uint32_t> out;
  auto any = [](const Eigen::AlignedBox3d&) { return true; };
  // An element registered in several of the cells visited is listed from one only: the cell
  // holding the low corner of its overlap with the box (which it is registered in, and which
  // the box touches), so no duplicates need sorting out.
  Index3 cell{0, 0, 0};
  visitCellsWithCell(box, any, [&](const Index3& c, std::uint32_t e) {
    const Eigen::AlignedBox3d& b = boxes_[e];
    if (!b.intersects(box)) return;
    cell = cellOf(b.min().cwiseMax(box.min()));
    if (cell == c) out.push_back(e);
  });
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace voxcut
