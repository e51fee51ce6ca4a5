#pragma once
/// @file RowCoupling.h
/// Symmetric couplings between pairs of sparse row combinations, added to a block matrix's
/// product without entering its sparsity (docs/algorithms.md, "Self contact in one solve").
///
/// Term p couples the combination s_a (rows with weights) to s_b through a symmetric 3x3 C_p:
///   X = -sum_p (s_a C_p s_b^T + s_b C_p s_a^T)   (each s a column of block weights),
/// the off-diagonal part of the pair matrix (s_a - s_b) C_p (s_a - s_b)^T whose diagonal parts
/// (s_a C s_a^T and s_b C s_b^T) the caller has put into the block matrix itself. So A + X is
/// what a spring between two points of one body adds, and its preconditioner can keep A's
/// sparsity: a contact that couples two distant elements changes no pattern, factor or
/// hierarchy.
///
/// The product runs in two passes, each in parallel when asked: every term's C_p s_b^T x and
/// C_p s_a^T x, then every row's sum of what its entries receive, in the terms' order. So the
/// result does not depend on the thread count. It costs a few operations per weight of each
/// term; the rows' lists (the entries transposed) are made once after the terms change.
///
/// Thread-safety: one product at a time per object (it keeps its scratch).

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/core/Types.h"

namespace voxcut {

/// A sparse combination of block rows: (row, weight) pairs.
using RowWeights = std::vector<std::pair<std::uint32_t, double>>;

class RowCoupling {
 public:
  void clear() {
    start_.assign(1, 0);
    split_.clear();
    entries_.clear();
    matrices_.clear();
    prepared_ = false;
  }
  [[nodiscard]] bool empty() const { return matrices_.empty(); }
  [[nodiscard]] std::size_t size() const { return matrices_.size(); }

  /// Adds the term coupling `a` to `b` through the symmetric `c`.
  void add(const RowWeights& a, const RowWeights& b, const Eigen::Matrix3d& c) {
    if (start_.empty()) start_.push_back(0);
    entries_.insert(entries_.end(), a.begin(), a.end());
    split_.push_back(static_cast<std::uint32_t>(entries_.size()));
    entries_.insert(entries_.end(), b.begin(), b.end());
    start_.push_back(static_cast<std::uint32_t>(entries_.size()));
    matrices_.push_back(c);
    prepared_ = false;
  }

  /// Calls f(aBegin, aEnd, bBegin, bEnd, c) for every term in order, the ranges over its
  /// (row, weight) entries of s_a and s_b.
  template <class F>
  void forEachTerm(F&& f) const {
    for (std::size_t p = 0; p < matrices_.size(); ++p)
      f(entries_.data() + start_[p], entries_.data() + split_[p], entries_.data() + split_[p],
        entries_.data() + start_[p + 1], matrices_[p]);
  }

  /// y += X x (x and y one 3-vector per block row; every row named by a term is < x.size()).
  /// `threaded`: both passes in parallel; the result is the same.
  void multiplyAdd(const std::vector<Vec3d>& x, std::vector<Vec3d>& y,
                   bool threaded = false) const {
    accumulate(x, y, -1.0, threaded);
  }
  /// r -= X x (a residual brought up to date), as multiplyAdd with the opposite sign.
  void multiplySubtract(const std::vector<Vec3d>& x, std::vector<Vec3d>& r,
                        bool threaded = false) const {
    accumulate(x, r, 1.0, threaded);
  }

 private:
  /// y += sign sum_p (s_a C_p s_b^T + s_b C_p s_a^T) x: the two passes.
  void accumulate(const std::vector<Vec3d>& x, std::vector<Vec3d>& y, double sign,
                  bool threaded) const {
    if (matrices_.empty()) return;
    prepare();
    received_.resize(2 * matrices_.size());
    parallelFor(
        0, matrices_.size(), 64,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t p = b; p < e; ++p) {
            Vec3d ua = Vec3d::Zero(), ub = Vec3d::Zero();
            for (std::uint32_t k = start_[p]; k < split_[p]; ++k)
              ua += entries_[k].second * x[entries_[k].first];
            for (std::uint32_t k = split_[p]; k < start_[p + 1]; ++k)
              ub += entries_[k].second * x[entries_[k].first];
            received_[2 * p] = matrices_[p] * ub;  // by s_a's rows
            received_[2 * p + 1] = matrices_[p] * ua;  // by s_b's rows
          }
        },
        threaded);
    parallelFor(
        0, rows_.size(), 256,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t r = b; r < e; ++r) {
            Vec3d sum = Vec3d::Zero();
            for (std::uint32_t k = rowStart_[r]; k < rowStart_[r + 1]; ++k)
              sum += byRow_[k].second * received_[byRow_[k].first];
            y[rows_[r]] += sign * sum;
          }
        },
        threaded);
  }

  std::vector<std::uint32_t> start_{0};  ///< per term + 1: its entries' range
  std::vector<std::uint32_t> split_;     ///< per term: where s_b's entries begin
  RowWeights entries_;
  std::vector<Eigen::Matrix3d> matrices_;

  /// The entries by row (a counting sort, so each row's in the terms' order): rows_ the rows
  /// named, ascending; row r's entries in byRow_[rowStart_[r], rowStart_[r + 1]), each the slot
  /// of received_ it takes (2p: s_a of term p, 2p + 1: s_b) and its weight.
  void prepare() const {
    if (prepared_) return;
    std::uint32_t rows = 0;
    for (const auto& e : entries_) rows = std::max(rows, e.first + 1);
    std::vector<std::uint32_t> count(rows + 1, 0);
    for (const auto& e : entries_) ++count[e.first + 1];
    rows_.clear();
    rowStart_.assign(1, 0);
    std::vector<std::uint32_t> compact(rows, 0);
    for (std::uint32_t r = 0; r < rows; ++r)
      if (count[r + 1] > 0) {
        compact[r] = static_cast<std::uint32_t>(rows_.size());
        rows_.push_back(r);
        rowStart_.push_back(rowStart_.back() + count[r + 1]);
      }
    std::vector<std::uint32_t> next(rowStart_.begin(), rowStart_.end() - 1);
    byRow_.resize(entries_.size());
    for (std::size_t p = 0; p < matrices_.size(); ++p)
      for (std::uint32_t k = start_[p]; k < start_[p + 1]; ++k) {
        const auto slot = static_cast<std::uint32_t>(2 * p + (k < split_[p] ? 0 : 1));
        byRow_[next[compact[entries_[k].first]]++] = {slot, entries_[k].second};
      }
    prepared_ = true;
  }

  mutable bool prepared_ = false;
  mutable std::vector<std::uint32_t> rows_, rowStart_;
  mutable RowWeights byRow_;
  mutable std::vector<Vec3d> received_;
};

}  // namespace voxcut
