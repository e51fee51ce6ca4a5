#pragma once
/// @file LinearPreconditioner.h
/// The interface of a preconditioner M ~ A of the conjugate gradients on a symmetric block
/// matrix (ConjugateGradients.h), in the shape of mfem's Solver (linalg/solvers.hpp:
/// SetOperator, then Mult): setOperator prepares M for a matrix, apply computes z = M^-1 r.
/// Unlike mfem's, an implementation keeps no status for the caller to read afterwards:
/// setOperator returns whether M could be made, and the solver returns its own status.
///
/// Thread-safety: one call at a time per object (implementations own scratch vectors).

#include <Eigen/Core>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/linalg/BlockMatrix.h"

namespace voxcut {

/// A symmetric positive definite preconditioner for the conjugate gradients.
class LinearPreconditioner {
 public:
  LinearPreconditioner() = default;
  LinearPreconditioner(const LinearPreconditioner&) = default;
  LinearPreconditioner& operator=(const LinearPreconditioner&) = default;
  LinearPreconditioner(LinearPreconditioner&&) noexcept = default;
  LinearPreconditioner& operator=(LinearPreconditioner&&) noexcept = default;
  virtual ~LinearPreconditioner() = default;

  /// Prepares M for the matrix `a` (factors, coarse levels), which apply() then uses: `a` is
  /// borrowed and must stay valid until the next setOperator. `threaded` runs the set-up and
  /// later applications in parallel (results do not depend on it). Returns false, and apply()
  /// must not be called, when M cannot be made for `a` (a factor that is not positive
  /// definite).
  [[nodiscard]] virtual bool setOperator(const BlockMatrixView& a, bool threaded) = 0;

  /// z = M^-1 r, one 3-vector per block row of the operator. `z` is resized and must not
  /// alias r.
  virtual void apply(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) = 0;

  /// For a preconditioner that acts row by row, z_i = B_i r_i: the 3x3 blocks B_i, one per
  /// row, which the conjugate gradients fuse into their vector updates (no pass of its own).
  /// Such blocks must be ready before a solve, which then neither sets the preconditioner up
  /// nor calls apply(). Null (the default) for a preconditioner that couples rows.
  [[nodiscard]] virtual const Eigen::Matrix3d* rowBlocks() const { return nullptr; }
};

}  // namespace voxcut
