#pragma once
/// @file ConjugateGradients.h
/// Preconditioned conjugate gradients on a symmetric positive definite block matrix
/// (BlockMatrix.h), in the shape of mfem's CGSolver (linalg/solvers.hpp: SetOperator,
/// SetPreconditioner, Mult(b, x)) but returning its status by value.
///
/// From a start x with residual r = b - A x and z = M^-1 r, p = z, each iteration computes
///   q = A p,  alpha = (r, z) / (p, q),  x += alpha p,  r -= alpha q,
///   z = M^-1 r,  beta = (r, z)_new / (r, z),  p = z + beta p,
/// and stops when |r|^2 <= tolerance^2 |b|^2, after maxIterations, or at a non-finite value.
/// The preconditioner is set up lazily: its setOperator is called only once the start's
/// residual shows that an iteration is needed, so a warm start that has already converged
/// costs no factorisation. A preconditioner that acts row by row (LinearPreconditioner::
/// rowBlocks) is fused into the vector updates instead and never set up here.
///
/// Products and vector updates run in parallel over rows (parallelFor); dot products are
/// summed over fixed chunks in a fixed order (ChunkedSum.h), so results are bit-identical for
/// any thread count.
///
/// Thread-safety: one solve at a time per object (it owns its scratch vectors, sized once and
/// reused, so solves do not allocate once the size settles).

#include <optional>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/linalg/BlockMatrix.h"
#include "voxcut/linalg/LinearPreconditioner.h"
#include "voxcut/linalg/RowCoupling.h"

namespace voxcut {

/// When the conjugate gradients stop.
struct ConjugateGradientParams {
  double tolerance = 1e-3;  ///< stop when |r| <= tolerance |b| (2-norms)
  int maxIterations = 200;  ///< iteration cap (>= 0)
};

/// What one solve did.
struct ConjugateGradientStatus {
  int iterations = 0;      ///< iterations run
  double residual = 0.0;   ///< final |r| / |b| (0 when b = 0)
  bool converged = false;  ///< residual <= tolerance within maxIterations
  bool finite = true;      ///< false: a non-finite value appeared (x is then not to be used)
  /// false: the preconditioner could not be set up for A (setOperator failed) and no
  /// iteration ran
  bool preconditioned = true;
};

/// The solver: an operator, a preconditioner and the scratch of the iterations.
class ConjugateGradients {
 public:
  /// The matrix A, borrowed (it must stay valid during the solves); `threaded` runs the
  /// products, updates and sums in parallel.
  void setOperator(const BlockMatrixView& a, bool threaded) {
    a_ = a;
    threaded_ = threaded;
  }
  /// Couplings X added to A's product (RowCoupling.h), borrowed; null or empty: none. The
  /// operator is then A + X; the preconditioner is still set up with A alone.
  void setCoupling(const RowCoupling* coupling) { coupling_ = coupling; }
  /// The preconditioner M, borrowed (it must outlive the solves). Required.
  void setPreconditioner(LinearPreconditioner& m) { m_ = &m; }
  void setParams(const ConjugateGradientParams& params) { params_ = params; }
  [[nodiscard]] const ConjugateGradientParams& params() const { return params_; }

  /// Solves A x = b from the start x (both A.rows 3-vectors; x is the solution on return).
  /// b = 0 gives x = 0; a non-finite b gives finite == false and leaves x as it was.
  [[nodiscard]] ConjugateGradientStatus mult(const std::vector<Vec3d>& b, std::vector<Vec3d>& x);

  /// The status of a right-hand side with nothing to solve, from bb = |b|^2: a non-finite b
  /// (finite == false, x left as it was) or b = 0 (x = 0, converged); none otherwise.
  [[nodiscard]] static std::optional<ConjugateGradientStatus> trivialSolve(double bb,
                                                                           std::vector<Vec3d>& x);

  /// The iterations from a start x whose residual r = b - A x the caller made (it may have
  /// adjusted both, as the rigid-mode correction of ImplicitEuler does), with bb = |b|^2
  /// (finite, > 0). x and r are updated in place to the last iterate and its residual.
  [[nodiscard]] ConjugateGradientStatus iterate(double bb, std::vector<Vec3d>& x,
                                                std::vector<Vec3d>& r);

 private:
  /// z = M^-1 r through the preconditioner's apply; returns (r, z).
  double precondition(const std::vector<Vec3d>& r);

  BlockMatrixView a_;
  const RowCoupling* coupling_ = nullptr;
  bool threaded_ = true;
  LinearPreconditioner* m_ = nullptr;
  ConjugateGradientParams params_;
  std::vector<Vec3d> r_, z_, p_, q_;
  std::vector<double> partial_, partial2_;  ///< per chunk of rows, for dot products
};

}  // namespace voxcut
