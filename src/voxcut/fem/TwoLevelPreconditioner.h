#pragma once
/// @file TwoLevelPreconditioner.h
/// Two-level preconditioner for the conjugate gradients of the implicit step (ImplicitEuler.h):
/// symmetric block Gauss-Seidel smoothing around a coarse correction on node aggregates.
///
/// Why: one-level preconditioners (Jacobi, Gauss-Seidel, IC(0); BlockPreconditioner.h) damp
/// the error only locally, so their iteration counts grow with the number of nodes across a
/// body and with the contrast between element sizes (1-voxel elements beside 8-voxel ones
/// after a cut), and they barely touch the near-rigid motion of a piece that was cut off and
/// hangs on its mass alone. A coarse space of piecewise-constant translations on aggregates of
/// neighbouring nodes carries exactly those smooth motions.
///
/// Aggregation (Vanek, Mandel and Brezina's plain aggregation, on the graph of the block
/// sparsity): rows in index order; a row whose neighbours are all unaggregated starts an
/// aggregate with them (its 1-ring); every row left over joins the aggregate of its first
/// aggregated neighbour from the first pass. Aggregates never cross pieces (pieces share no
/// block). Deterministic.
///
/// Per step, each row's blocks are first summed per aggregate they reach (B_iJ = sum of A_ij
/// over j in J, a few per row): A_c sums them over i in I, and A T c = sum_J B_iJ c_J costs a
/// fraction of a product with A.
///
/// Coarse matrix: A_c = T^T A T with T the 3 #rows x 3 #aggregates prolongation that copies an
/// aggregate's translation to its rows, i.e. block (I, J) is the sum of the blocks A_ij with
/// i in I and j in J. It is symmetric positive definite whenever A is (T has full rank), and
/// is factorised densely (Cholesky) every step.
///
/// Application (one symmetric V-cycle, so M is symmetric positive definite and CG applies):
///   u  = (D + L)^-1 r                      forward block Gauss-Seidel sweep
///   u += T A_c^-1 T^T (r - A u)             coarse correction
///   z  = u + (D + U)^-1 (r - A u)           backward sweep
/// with A = L + D + U. Sweeps run rows in order (sequential); the products, restriction and
/// prolongation are parallel with fixed per-row sums, so results do not depend on the thread
/// count.
///
/// Thread-safety: one apply at a time per object (it owns scratch vectors).

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

struct BlockSparsity;

/// A partition of the rows of a block sparsity into aggregates.
struct NodeAggregation {
  std::vector<std::uint32_t> aggregate;  ///< aggregate of each row
  std::vector<std::uint32_t> start{0};   ///< #aggregates + 1 offsets into member
  std::vector<std::uint32_t> member;     ///< rows of each aggregate, ascending
  /// Per row i, the aggregates J its blocks reach, ascending: entries
  /// [linkStart[i], linkStart[i + 1]) of linkAggregate; per block slot, its entry.
  std::vector<std::uint32_t> linkStart{0};
  std::vector<std::uint32_t> linkAggregate;
  std::vector<std::uint32_t> slotLink;

  [[nodiscard]] std::size_t count() const { return start.size() - 1; }
};

/// Plain aggregation of the rows of `sparsity` (file comment).
[[nodiscard]] NodeAggregation aggregateNodes(const BlockSparsity& sparsity);

/// The coarse factor and the scratch of the V-cycle.
class TwoLevelPreconditioner {
 public:
  /// Sums the coarse matrix from `blocks` (one 3x3 per slot of `sparsity`) and factorises it.
  /// Returns false (and apply() then smooths only, a symmetric Gauss-Seidel) if the coarse
  /// matrix is not numerically positive definite.
  bool setup(const BlockSparsity& sparsity, const NodeAggregation& aggregation,
             const std::vector<Eigen::Matrix3d>& blocks, bool threaded);

  /// z = M^-1 r (file comment); `diagonalInverse` holds D_i^-1 per row. `z` is resized and
  /// must not alias r.
  void apply(const BlockSparsity& sparsity, const NodeAggregation& aggregation,
             const std::vector<Eigen::Matrix3d>& blocks,
             const std::vector<Eigen::Matrix3d>& diagonalInverse, const std::vector<Vec3d>& r,
             std::vector<Vec3d>& z, bool threaded);

  /// Unknowns of the coarse system (3 per aggregate) at the last setup.
  [[nodiscard]] Eigen::Index coarseSize() const { return coarse_.rows(); }

 private:
  std::vector<Eigen::Matrix3d> link_;  ///< B_iJ per entry of NodeAggregation::linkAggregate
  Eigen::MatrixXd coarse_;
  Eigen::LLT<Eigen::MatrixXd> factor_;
  bool valid_ = false;
  std::vector<Vec3d> u_, t_;
  Eigen::VectorXd coarseRhs_;
  std::vector<Vec3d> coarseSolution_;  ///< one translation per aggregate
};

}  // namespace voxcut
