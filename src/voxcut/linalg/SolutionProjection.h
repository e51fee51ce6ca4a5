#pragma once
/// @file SolutionProjection.h
/// Starting guesses for a sequence of solves A_t x_t = b_t whose matrices and right-hand sides
/// change a little from one solve to the next (the implicit steps of a moving body): the start
/// is the vector of the span of the last few solutions that is closest to the new solution in
/// the A-norm (Fischer 1998, "Projection techniques for iterative solution of Ax = b with
/// successive right-hand sides"; docs/algorithms.md, "Projection onto earlier solutions").
///
/// With W the kept solutions (columns), the start x0 = W c solves the Galerkin problem
/// (W^T A W) c = W^T b, so the A-norm error of x0 is the least over the span: never worse than
/// any one earlier solution, the usual warm start, and often far better when the solutions
/// follow a smooth motion (a body swinging or settling). It costs one product with A per kept
/// solution and a few dot products.
///
/// Determinism: the products run row by row and the dot products in fixed chunks
/// (ChunkedSum.h), so the start does not depend on the thread count.
///
/// Thread-safety: one call at a time per object.

#include <cstddef>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/linalg/BlockMatrix.h"
#include "voxcut/linalg/RowCoupling.h"

namespace voxcut {

/// The last `capacity` solutions of a sequence of solves, and the start they give.
class SolutionProjection {
 public:
  explicit SolutionProjection(std::size_t capacity = 0) : capacity_(capacity) {}

  /// Solutions kept at most; dropping to fewer forgets the oldest.
  void setCapacity(std::size_t capacity);
  [[nodiscard]] std::size_t capacity() const { return capacity_; }
  /// Solutions kept now.
  [[nodiscard]] std::size_t size() const { return kept_; }
  /// Forgets every solution (the rows changed meaning: a new sparsity).
  void clear() { kept_ = 0; }

  /// Keeps x (one row per block row, the rows of every kept solution) as the newest,
  /// forgetting the oldest when full. A different row count than the kept ones clears them
  /// first.
  void add(const std::vector<Vec3d>& x);

  /// Applies f(std::vector<Vec3d>&) to every kept solution, oldest first: a change of rows
  /// (f must leave every solution with the same row count).
  template <class F>
  void transform(F&& f) {
    for (std::size_t k = kept_; k-- > 0;) f(slots_[(newest_ + capacity_ - k) % capacity_]);
  }

  /// x = W c with (W^T A W) c = W^T b over the kept solutions W (a pseudo-inverse: directions
  /// the kept solutions repeat, to round-off, are left out). `a` must be symmetric positive
  /// definite with the kept solutions' rows (with `coupling`, A + X: RowCoupling.h). False,
  /// with x untouched, when nothing is kept or no direction is left.
  bool project(const BlockMatrixView& a, const std::vector<Vec3d>& b, std::vector<Vec3d>& x,
               bool threaded, const RowCoupling* coupling = nullptr);

 private:
  std::size_t capacity_ = 0;
  std::size_t kept_ = 0;
  std::size_t newest_ = 0;                   ///< slot of the newest solution (a ring)
  std::vector<std::vector<Vec3d>> slots_;    ///< capacity_ solution buffers
  std::vector<std::vector<Vec3d>> product_;  ///< A times each kept solution (scratch)
  std::vector<double> partial_;              ///< per chunk and sum (scratch)
};

}  // namespace voxcut
