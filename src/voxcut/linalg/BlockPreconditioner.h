#pragma once
/// @file BlockPreconditioner.h
/// Preconditioners for the conjugate gradients of the implicit step (fem/ImplicitEuler.h) that
/// couple nodes: symmetric block Gauss-Seidel and block incomplete Cholesky IC(0), both on the
/// reduced 3x3-block matrix A in the BlockSparsity layout (BlockSparsity.h; both triangles
/// stored, columns ascending per row). Rows are visited in their index order, one after the
/// other (triangular solves are sequential), so results do not depend on the thread count.
///
/// Notation: A = L_A + D_A + L_A^T with D_A the diagonal blocks and L_A the blocks below them.
///  - Symmetric block Gauss-Seidel: M = (D_A + L_A) D_A^-1 (D_A + L_A^T).
///  - IC(0): M = (I + L) D (I + L^T), L strictly lower with the pattern of L_A, D block
///    diagonal, chosen so that M agrees with A on the pattern (the update of a block keeps only
///    the products that land on the pattern). In the recurrences, F_ik = L_ik D_k:
///      F_ik = A_ik - sum_{j < k} L_ij F_kj^T   over j in both rows' patterns,
///      D_i  = A_ii - sum_{k < i} L_ik F_ik^T.
///    A pivot block D_i that is not positive definite (possible: A is not an M-matrix), or
///    that kept less than 5% of any diagonal entry of A_ii (cancellation: the rows after it
///    would get factors that grow without bound), is replaced by A_ii and the row's L blocks
///    by zero (the row falls back to block Jacobi). M stays symmetric positive definite.
///
/// Thread-safety: pure functions of their arguments; outputs must not be shared.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/linalg/BlockMatrix.h"
#include "voxcut/linalg/BlockSparsity.h"

namespace voxcut {

/// The symbolic part of IC(0) for one sparsity: for every block slot s = (i, k) below the
/// diagonal, the pairs (slot (i, j), slot (k, j)) with j < k present in both rows, in
/// ascending j. Built once per sparsity (fem/ElasticModel.h: per sparsityRevision).
struct IncompleteCholeskyPattern {
  std::vector<std::uint32_t> pairStart{
      0};                           ///< #blocks + 1 offsets (empty range off the lower part)
  std::vector<std::uint32_t> pair;  ///< 2 slots per pair: (i, j) then (k, j)

  [[nodiscard]] std::size_t pairCount() const { return pair.size() / 2; }
};

/// Builds the IC(0) pattern of `sparsity`. Cost: one merge of two rows per lower block.
[[nodiscard]] IncompleteCholeskyPattern incompleteCholeskyPattern(const BlockSparsity& sparsity);

/// The numeric IC(0) factor: L per slot (L_ik at a lower slot (i, k), its transpose at the
/// mirrored upper slot (k, i), so both triangular solves gather along rows) and the inverse
/// pivot blocks D_i^-1 per row.
struct IncompleteCholeskyFactor {
  std::vector<Eigen::Matrix3d> lower;         ///< L_ik at slot (i, k), L_ki^T at (i, k > i)
  std::vector<Eigen::Matrix3d> scaled;        ///< F_ik = L_ik D_k at slot (i, k), #blocks
  std::vector<Eigen::Matrix3d> pivotInverse;  ///< D_i^-1, #rows
  std::size_t replacedPivots = 0;             ///< pivots replaced by A_ii (see file comment)
};

/// Factorises A (`blocks`, one 3x3 per slot of `sparsity`) into `factor` (resized; reused
/// across calls so that steps do not allocate). Sequential over rows; deterministic.
void factorIncompleteCholesky(const BlockSparsity& sparsity,
                              const IncompleteCholeskyPattern& pattern,
                              const std::vector<Eigen::Matrix3d>& blocks,
                              IncompleteCholeskyFactor& factor);

/// z = M^-1 r for the IC(0) factor: forward (I + L) y = r, y = D^-1 y, backward (I + L^T) z = y.
/// `z` is resized; it must not alias r.
void applyIncompleteCholesky(const BlockSparsity& sparsity, const IncompleteCholeskyFactor& factor,
                             const std::vector<Vec3d>& r, std::vector<Vec3d>& z);

/// z = M^-1 r for symmetric block Gauss-Seidel: a forward sweep u_i = D_i^-1 (r_i - sum_{k<i}
/// A_ik u_k), then a backward sweep z_i = u_i - D_i^-1 sum_{k>i} A_ik z_k. `diagonalInverse`
/// holds D_i^-1 per row. `z` is resized; it must not alias r.
void applySymmetricGaussSeidel(const BlockSparsity& sparsity,
                               const std::vector<Eigen::Matrix3d>& blocks,
                               const std::vector<Eigen::Matrix3d>& diagonalInverse,
                               const std::vector<Vec3d>& r, std::vector<Vec3d>& z);

}  // namespace voxcut
