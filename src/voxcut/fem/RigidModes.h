#pragma once
/// @file RigidModes.h
/// Momentum-exact linear solves: a Galerkin correction of an implicit step's solution by the
/// rigid motions of each connected piece of the mesh (docs/algorithms.md, "Rigid-mode
/// correction").
///
/// The conjugate gradients stop at a relative residual; what they leave is an error in every
/// mode, the rigid ones included. An error in a piece's rigid modes is a net force or torque
/// that nothing resists (a free piece's rigid motions cost no elastic energy), so a body in
/// free fall drifts sideways and turns, a little every step. After the solve, with Z the six
/// rigid motions of each piece (translations, and rotations about its centroid through the
/// current node positions) and A the step's matrix, the correction
///
///   x += Z c,  c = (Z^T A Z)^+ Z^T r,  r -= A Z c
///
/// makes the residual orthogonal to every piece's rigid motions: the step's net force and
/// torque on each piece are exact (to round-off), whatever the tolerance. When the exact
/// solution is a rigid motion of a piece (free fall, no damping), the correction finds it.
/// Pieces are the connected components of the matrix graph; A couples no two pieces, so one
/// product with the six global mode vectors gives every piece's A Z.
///
/// Thread-safety: one call at a time per object; results do not depend on the thread count
/// (per-piece sums run in row order).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/linalg/BlockSparsity.h"
#include "voxcut/linalg/RowCoupling.h"

namespace voxcut {

/// The rigid motions of the pieces of a reduced system and the correction above.
class RigidModes {
 public:
  /// Labels the pieces of `sparsity` (rebuilt only when `revision` differs from the last
  /// call's) and sets the modes for the current free-node positions `positions` (#free,
  /// metres) and weights `weights` (#free, the nodes' masses): the six columns are
  /// translations along x, y, z and rotations about x, y, z through each piece's weighted
  /// centroid (about the centre of mass the mass matrix couples no translation to a rotation,
  /// which keeps a large translation's round-off out of the rotations), scaled by the piece's
  /// radius so that all six have the same size.
  void setup(const BlockSparsity& sparsity, std::uint64_t revision,
             const std::vector<Vec3d>& positions, const std::vector<double>& weights);

  /// Mode k (0..5) over all rows, #free (each row takes its own piece's mode).
  [[nodiscard]] const std::vector<Vec3d>& mode(int k) const {
    return modes_[static_cast<std::size_t>(k)];
  }

  /// Row i of A mode(k) for the six modes, A's blocks `blocks` with columns `column` over slots
  /// [begin, end) (row i of a BlockSparsity's pattern). One pass over the row's blocks, and
  /// no multiplication by the modes' known zeros: a translation is a unit vector, and the
  /// rotation about axis a, e_a x d, has component a zero. Each sum is blockRowProduct's (its
  /// terms in the same order) less those terms, which are exactly zero, so the products are
  /// the same as blockRowProduct's. After setup().
  [[nodiscard]] std::array<Vec3d, 6> rowProducts(const Eigen::Matrix3d* blocks,
                                                 const std::uint32_t* column, std::uint32_t begin,
                                                 std::uint32_t end) const;

  /// Takes az[k] = A mode(k) (#free each; swapped in, so `az` gets the previous buffers
  /// back for reuse) and inverts each piece's 6x6 Z^T A Z
  /// (a pseudo-inverse: the modes of a piece with too few free nodes to span them all are
  /// left out).
  /// With `coupling` (may be null or empty; borrowed until the next setOperator), the step's
  /// matrix is A + X (linalg/RowCoupling.h) and `az` still A's products alone: pieces that X
  /// couples are corrected together, by one Galerkin problem over all their modes.
  void setOperator(std::array<std::vector<Vec3d>, 6>& az, const RowCoupling* coupling = nullptr);

  /// Applies the correction to an iterate x and its residual r = b - A x (#free each):
  /// x += Z c, r -= A Z c per piece, with c = (Z^T A Z)^+ Z^T r (coupled pieces: over their
  /// group, with A + X). Afterwards Z^T r = 0 (to round-off). Needs setOperator for the
  /// current A.
  void correct(std::vector<Vec3d>& x, std::vector<Vec3d>& r) const;

  /// z += Z c with c = (Z^T A Z)^+ Z^T r, as correct() (a coarse correction for a
  /// preconditioner: symmetric positive semi-definite in r).
  void coarseCorrection(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) const;

  /// Number of pieces found by the last setup.
  [[nodiscard]] std::size_t pieceCount() const { return pieceCount_; }
  /// Piece of each free node, #free.
  [[nodiscard]] const std::vector<std::uint32_t>& piece() const { return piece_; }

 private:
  /// Per piece, c = (Z^T A Z)^+ Z^T r (coupled pieces over their group).
  [[nodiscard]] std::vector<Eigen::Matrix<double, 6, 1>> coefficients(
      const std::vector<Vec3d>& r) const;

  std::uint64_t revision_ = 0;
  bool labelled_ = false;
  std::size_t pieceCount_ = 0;
  std::vector<std::uint32_t> piece_;
  std::array<std::vector<Vec3d>, 6> modes_;
  std::array<std::vector<Vec3d>, 6> products_;        ///< A times each mode
  std::vector<Eigen::Matrix<double, 6, 6>> inverse_;  ///< per piece, (Z^T A Z)^+
  /// Pieces that a coupling joins: the groups of more than one piece, each its pieces
  /// (ascending) and the pseudo-inverse of Z^T (A + X) Z over all their modes.
  std::vector<std::vector<std::uint32_t>> groups_;
  std::vector<Eigen::MatrixXd> groupInverse_;
  const RowCoupling* coupling_ = nullptr;
};

}  // namespace voxcut
