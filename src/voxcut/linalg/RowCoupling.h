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
/// The product runs over the terms in order, on one thread: the result does not depend on the
/// thread count. It costs a few operations per weight of each term.

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

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
  void multiplyAdd(const std::vector<Vec3d>& x, std::vector<Vec3d>& y) const {
    for (std::size_t p = 0; p < matrices_.size(); ++p) {
      Vec3d ua = Vec3d::Zero(), ub = Vec3d::Zero();
      for (std::uint32_t k = start_[p]; k < split_[p]; ++k)
        ua += entries_[k].second * x[entries_[k].first];
      for (std::uint32_t k = split_[p]; k < start_[p + 1]; ++k)
        ub += entries_[k].second * x[entries_[k].first];
      const Vec3d ca = matrices_[p] * ua, cb = matrices_[p] * ub;
      for (std::uint32_t k = start_[p]; k < split_[p]; ++k)
        y[entries_[k].first] -= entries_[k].second * cb;
      for (std::uint32_t k = split_[p]; k < start_[p + 1]; ++k)
        y[entries_[k].first] -= entries_[k].second * ca;
    }
  }

 private:
  std::vector<std::uint32_t> start_{0};  ///< per term + 1: its entries' range
  std::vector<std::uint32_t> split_;     ///< per term: where s_b's entries begin
  RowWeights entries_;
  std::vector<Eigen::Matrix3d> matrices_;
};

}  // namespace voxcut
