#pragma once
/// @file BlockCholesky.h
/// Sparse Cholesky factorisation A = L L^T of the reduced 3x3-block system of the implicit step
/// (fem/ImplicitEuler.h), node by node: every entry of L is a 3x3 block, so the factorisation and
/// the triangular solves run on fixed-size block products instead of scalar index chasing.
/// ImplicitEuler uses it as the preconditioner of its conjugate gradients, refactorised only
/// when the structure changes or the factor has gone stale (the matrix changes slowly from one
/// step to the next, so the factor of an earlier step still brings the solve down to a few
/// iterations).
///
/// Method (docs/algorithms.md, "Preconditioners"):
///  1. Ordering: approximate minimum degree (Eigen's AMDOrdering) on the node graph, so a
///     node's three unknowns stay together.
///  2. Symbolic: elimination tree (Liu's algorithm with path compression), then the pattern of
///     each block column of L from the row subtrees of the tree, rows ascending.
///  3. Numeric: left-looking; column j gathers A's column into a dense block workspace,
///     subtracts L(j:n, k) L(j, k)^T for every earlier column k with a block in row j (row j's
///     blocks listed by the symbolic phase, k ascending), factorises the 3x3 pivot and scales.
///  4. Solve: forward L y = b, backward L^T x = y, block by block.
/// Subtrees of the elimination tree (each at most an eighth of the work) are factorised in
/// parallel, then the columns above them in order; every column is computed by the same
/// operations in the same order whichever thread runs it, so the factor does not depend on the
/// thread count. The solves are sequential (parallel solves do not pay at these sizes).
///
/// Thread-safety: none; one call at a time per object (all three use its scratch).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

struct BlockSparsity;

/// Block sparse Cholesky factor of one BlockSparsity (BlockSparsity.h).
class BlockCholesky {
 public:
  /// Orders the nodes of `sparsity` and computes the pattern of L. Call again whenever the
  /// sparsity changes; the numeric factor is dropped.
  void analyse(const BlockSparsity& sparsity);

  /// Factorises A (`blocks`, one 3x3 per slot of the analysed sparsity, both triangles). Returns
  /// false, and leaves no usable factor, when a pivot block is not numerically positive
  /// definite (A is not SPD).
  [[nodiscard]] bool factorise(const BlockSparsity& sparsity,
                               const std::vector<Eigen::Matrix3d>& blocks, bool threaded = true);

  /// z = A^-1 r with the last factor (which must exist). `z` is resized; it may alias r.
  void solve(const std::vector<Vec3d>& r, std::vector<Vec3d>& z);

  /// True after a successful factorise (until the next analyse).
  [[nodiscard]] bool factorised() const { return factorised_; }
  /// Rows (nodes) of the analysed sparsity.
  [[nodiscard]] std::size_t rows() const { return perm_.size(); }
  /// Blocks of L below the diagonal.
  [[nodiscard]] std::size_t offDiagonalBlocks() const { return row_.size(); }
  /// 3x3 block products one factorisation costs (each column's updates and scalings): what
  /// the numeric phase's time grows with.
  [[nodiscard]] double updateCount() const { return updates_; }
  /// Subtrees of the elimination tree factorised in parallel (1 for a small system).
  [[nodiscard]] std::size_t taskCount() const { return taskStart_.size() - 1; }
  /// Elimination order: the sparsity row factorised as the j-th.
  [[nodiscard]] const std::vector<std::uint32_t>& ordering() const { return perm_; }

 private:
  std::vector<std::uint32_t> perm_;      ///< new index -> sparsity row
  std::vector<std::uint32_t> inverse_;   ///< sparsity row -> new index
  std::vector<std::uint32_t> colStart_;  ///< per new column, its blocks below the diagonal
  std::vector<std::uint32_t> row_;       ///< new row index of each such block, ascending
  double updates_ = 0.0;
  bool factorised_ = false;

  std::vector<Eigen::Matrix3d> lower_;         ///< L(row_[q], j) per q
  std::vector<Eigen::Matrix3d> pivotInverse_;  ///< L(j, j)^-1 per column (lower triangular)

  /// Per row j, the blocks (j, k) left of the diagonal: column k and position in lower_.
  std::vector<std::uint32_t> rowListStart_, rowListColumn_, rowListBlock_;
  /// Parallel plan: disjoint subtrees of the elimination tree (columns ascending per task),
  /// then the columns above them in order.
  std::vector<std::uint32_t> taskStart_{0}, taskColumns_, topColumns_;

  // Scratch of factorise (one zeroed block workspace per task) and solve.
  std::vector<std::vector<Eigen::Matrix3d>> work_;
  std::vector<Vec3d> y_;

  void planTasks(const std::vector<std::uint32_t>& parent, const std::vector<double>& subtree);
  bool factorColumn(const BlockSparsity& sp, const std::vector<Eigen::Matrix3d>& blocks,
                    std::uint32_t j, Eigen::Matrix3d* work);
};

}  // namespace voxcut
