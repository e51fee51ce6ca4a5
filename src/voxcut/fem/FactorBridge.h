#pragma once
/// @file FactorBridge.h
/// Carries a sparse Cholesky factor across topology changes, so that the step of a cut is
/// preconditioned by the factor made before it instead of a weaker preconditioner.
///
/// Why: a cut changes the reduced system's rows (nodes are duplicated, elements refined), so
/// the factor no longer matches it, and a new one costs an analysis and a factorisation (many
/// times one iteration). Most of the body did not change, though: away from
/// the cut the old factor is still the inverse of (nearly) the same matrix.
///
/// How: every node of the current model is expressed as a weighted sum of the factor's rows,
/// starting from the prolongation P of the model the factor was made for (row n of P) and
/// remapped through each TopologyChange since (NodeSource weights, as for the velocities).
/// For the current free rows this gives an interpolation B (free rows x factor rows). A row is
/// "clean" when it is exactly one factor row with weight 1, claimed by no other row, and no
/// element created since the factor touches its node; the others, grown by one ring of
/// neighbours, are "local" (duplicated, created or re-shaped around the cut, and next to such).
/// The preconditioner is one symmetric V-cycle with the old factor C as its coarse solve and
/// block Gauss-Seidel on the local rows as its smoother:
///
///     u  = (D + L)_loc^-1 r                 forward sweep over the local rows
///     u += B C^-1 B^T (r - A u)             the earlier factor, through the node map
///     z  = u + (D + U)_loc^-1 (r - A u)     backward sweep over the local rows
///
/// It is symmetric positive definite: M^-1 = S + (I - S^T A) B C^-1 B^T (I - A S), where the
/// sweeps' part S is symmetric positive definite on the local rows (Gauss-Seidel on an SPD
/// matrix) and zero elsewhere, and a vector with no part on them is left unchanged by I - A S
/// and mapped by B^T injectively (each clean row to its own factor row), so the factor term
/// is positive. Conjugate gradients therefore stay correct; the bridge only decides how many
/// iterations they take (far fewer than with the two-level V-cycle on the shipped scenes' cut
/// steps: docs/performance.md, "Running scenes"). The sweeps and the products behind them
/// touch the local rows and their neighbours only. Deterministic (sequential, in row order).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/topology/TopologyChange.h"

namespace voxcut {

class BlockCholesky;
struct BlockSparsity;
class DeformationOctree;
class ElasticModel;

class FactorBridge {
 public:
  /// Starts over from the model a factor was just made for (B = identity on its free rows).
  void reset(const ElasticModel& model);
  /// Forgets the factor's model (the factor is gone or was never made).
  void invalidate() { valid_ = false; }
  /// Whether a factor's model is being tracked.
  [[nodiscard]] bool valid() const { return valid_; }

  /// Remaps the node expressions through a topology change (call with every change, as
  /// ImplicitEuler::updateTopology). No-op when invalid or nothing changed.
  void update(const TopologyChange& change);

  /// Builds B and the local rows for the current model (which must follow every change given
  /// to update) and octree. `factorRows` is the factor's row count. Returns false (and the
  /// bridge is then invalid) when an expression refers past it.
  bool prepare(const ElasticModel& model, const DeformationOctree& octree, std::size_t factorRows);

  /// z = M^-1 r (file comment) for the system A (`blocks` on `sparsity`), with the factor C
  /// and per free row its diagonal block's inverse. `z` is resized and must not alias r.
  /// prepare() must have succeeded.
  void apply(const BlockSparsity& sparsity, const std::vector<Eigen::Matrix3d>& blocks,
             BlockCholesky& factor, const std::vector<Eigen::Matrix3d>& diagonalInverse,
             const std::vector<Vec3d>& r, std::vector<Vec3d>& z);

  /// Free rows of the last prepare that are local (the D_L term).
  [[nodiscard]] std::size_t localRows() const { return localList_.size(); }

 private:
  bool valid_ = false;
  // Per node of the current model: its value as factor rows with weights (CSR), and whether a
  // change duplicated or created it.
  std::vector<std::uint32_t> start_{0}, row_;
  std::vector<double> weight_;
  std::vector<std::uint8_t> dirty_;
  std::vector<std::uint8_t> newElement_;  ///< per element: created since the factor
  // Prepared for the current free rows.
  std::vector<std::uint32_t> freeStart_{0}, freeRow_;
  std::vector<double> freeWeight_;
  std::vector<std::uint8_t> local_;
  std::vector<std::uint32_t> localList_;  ///< the local rows, ascending
  std::vector<std::uint32_t> haloList_;   ///< the local rows and their neighbours, ascending
  std::vector<Vec3d> coarse_, u_, t_;
};

}  // namespace voxcut
