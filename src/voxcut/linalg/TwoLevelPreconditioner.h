#pragma once
/// @file TwoLevelPreconditioner.h
/// Two-level preconditioner for the conjugate gradients of the implicit step (fem/ImplicitEuler.h):
/// symmetric block Gauss-Seidel smoothing around a coarse correction on node aggregates.
///
/// Why: one-level preconditioners (Jacobi, Gauss-Seidel, IC(0); BlockPreconditioner.h) damp
/// the error only locally, so their iteration counts grow with the number of nodes across a
/// body and with the contrast between element sizes (1-voxel elements beside 8-voxel ones
/// after a cut), and they barely touch the near-rigid motion of a piece that was cut off and
/// hangs on its mass alone. A coarse space of the rigid motions (translations and rotations)
/// of aggregates of neighbouring nodes carries exactly those smooth motions (smoothed
/// aggregation's "near null space" of elasticity, here unsmoothed).
///
/// Aggregation (Vanek, Mandel and Brezina's plain aggregation, on the graph of the block
/// sparsity): rows in index order; a row whose neighbours are all unaggregated starts an
/// aggregate with them (its 1-ring); every row left over joins the aggregate of its first
/// aggregated neighbour from the first pass. Then, `pairings` times, aggregates merge in pairs
/// with the neighbour they share the most blocks with. Aggregates never cross pieces (pieces
/// share no block). Deterministic.
///
/// Coarse space, per step from the current node positions x_i: aggregate I has a centre c_I
/// (mean of its rows' positions) and a radius r_I (RMS distance to it); row i of I gets the
/// offset d_i = (x_i - c_I) / r_I, and T_i = [I, -[d_i]x] maps I's coarse unknowns (t, w) to
/// t + w x d_i. An aggregate of fewer than 3 rows, or whose rows lie on one line (second
/// moment eigenvalues l1 <= 1e-3 l2), has translations only (3 unknowns, d_i = 0).
///
/// Per step, each row's blocks are first summed per aggregate they reach, B_iJ = sum of A_ij T_j
/// over j in J (a few 3x6 blocks per row): A_c(I, J) = sum over i in I of T_i^T B_iJ, and
/// A T c = sum_J B_iJ c_J costs a fraction of a product with A. A_c = T^T A T is symmetric
/// positive definite whenever A is and T has full rank, and is factorised every step by a
/// sparse Cholesky (Eigen's simplicial LLT, AMD ordering; the ordering and symbolic factor are
/// kept while the pattern stays); if that fails the preconditioner is symmetric Gauss-Seidel
/// alone. A dense factor would grow with the cube of the aggregates, which cuts multiply
/// (docs/performance.md, "Deformation solver").
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

#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <cstdint>
#include <memory>
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

/// Rounds of pairing after the 1-ring aggregation that fem/ElasticModel.h uses. One round: larger
/// aggregates cost a few more iterations and save more in the coarse system; no round, or a
/// second one, is no faster per step (docs/performance.md, "Deformation solver").
inline constexpr int kAggregatePairings = 1;

/// Plain aggregation of the rows of `sparsity` (file comment), then `pairings` rounds of
/// merging neighbouring aggregates in pairs.
[[nodiscard]] NodeAggregation aggregateNodes(const BlockSparsity& sparsity, int pairings = 0);

/// The coarse factor and the scratch of the V-cycle.
class TwoLevelPreconditioner {
 public:
  TwoLevelPreconditioner() = default;
  /// A copy refactorises the copied coarse matrix (the same factor, bit for bit).
  TwoLevelPreconditioner(const TwoLevelPreconditioner& other);
  TwoLevelPreconditioner& operator=(const TwoLevelPreconditioner& other);
  TwoLevelPreconditioner(TwoLevelPreconditioner&&) noexcept = default;
  TwoLevelPreconditioner& operator=(TwoLevelPreconditioner&&) noexcept = default;
  ~TwoLevelPreconditioner();

  /// Sums the coarse matrix from `blocks` (one 3x3 per slot of `sparsity`) and factorises it.
  /// Returns false (and apply() then smooths only, a symmetric Gauss-Seidel) if the coarse
  /// matrix is not numerically positive definite.
  /// `positions` (one per row, current; may be null) add the rotations of each aggregate
  /// whose rows are not all on one line.
  bool setup(const BlockSparsity& sparsity, const NodeAggregation& aggregation,
             const std::vector<Eigen::Matrix3d>& blocks, const std::vector<Vec3d>* positions,
             bool threaded);

  /// z = M^-1 r (file comment); `diagonalInverse` holds D_i^-1 per row. `z` is resized and
  /// must not alias r.
  void apply(const BlockSparsity& sparsity, const NodeAggregation& aggregation,
             const std::vector<Eigen::Matrix3d>& blocks,
             const std::vector<Eigen::Matrix3d>& diagonalInverse, const std::vector<Vec3d>& r,
             std::vector<Vec3d>& z, bool threaded);

  /// Unknowns of the coarse system (3 or 6 per aggregate) at the last setup.
  [[nodiscard]] Eigen::Index coarseSize() const { return coarse_.rows(); }
  /// Entries of the coarse factor L (its diagonal included; 0 before the first setup): a
  /// V-cycle's two triangular solves read each once.
  [[nodiscard]] double coarseFactorEntries() const;

 private:
  using LinkBlock = Eigen::Matrix<double, 3, 6>;
  using Mode = Eigen::Matrix<double, 6, 1>;  ///< translation, rotation
  std::vector<LinkBlock> link_;              ///< B_iJ per entry of NodeAggregation::linkAggregate
  std::vector<Vec3d> offset_;  ///< per row: (x_i - centre_I) / radius_I, 0 without rotations
  std::vector<std::uint32_t> columnStart_;        ///< per aggregate, its first coarse unknown
  Eigen::SparseMatrix<double> coarse_;            ///< lower triangle of A_c
  std::vector<int> patternOuter_, patternInner_;  ///< coarse_'s pattern at the last analysis
  std::vector<Eigen::Triplet<double>> coarseTriplets_;
  /// Empty until the first setup (on the heap: Eigen's sparse factors cannot be moved).
  using Factor = Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower>;
  std::unique_ptr<Factor> factor_;
  bool valid_ = false;
  std::vector<Vec3d> u_, t_;
  Eigen::VectorXd coarseRhs_;
  std::vector<Mode> coarseSolution_;  ///< per aggregate
};

}  // namespace voxcut
