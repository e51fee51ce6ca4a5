#pragma once
/// @file StepAssembly.h
/// The reduced system of one implicit Euler step (ImplicitEuler.h; docs/algorithms.md,
/// "Implicit Euler"), assembled from the elements, the lumped masses and the point contacts:
///
///   A = P^T (M + dt C + dt^2 K) P,   b = P^T dt (f_el + f_ext - C v - dt K v + f_contact),
///
/// with the point contacts' springs and dampers in A and b (ContactLaw.h, contactStepTerms; a
/// pair contact's cross terms are not here but beside A, StepContacts::coupling()).
///
/// Elements first, in parallel: each one's rotation, its force and its 36 rotated, scaled
/// stiffness blocks on and above the diagonal. Then each node's mass diagonal and right-hand
/// side, gathered from its incident corners in a fixed order; then each free row's P^T b and
/// the blocks of A on and above the diagonal, each summed over its sources in the order of the
/// sparsity's plan (linalg/BlockSparsity.h); the blocks below are their mirrors' transposes (A
/// is symmetric, and so exactly symmetric in floating point too). Results are bit-identical
/// for any thread count.
///
/// Thread-safety: one assembly at a time per object; it owns its buffers (sized once, reused,
/// so steps do not allocate once the sizes settle).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEulerParams.h"
#include "voxcut/fem/StepContacts.h"
#include "voxcut/topology/DeformationOctree.h"

namespace voxcut {

/// The assembled system of a step and the per-element and per-node buffers behind it.
class StepAssembly {
 public:
  /// Sizes the buffers for `model`.
  void resize(const ElasticModel& model);

  /// Assembles A and b for a step of `params` (timeStep, gravity; the diagonal inverse is
  /// by 3x3 block unless the preconditioner is Jacobi) from the node velocities at the step's
  /// start `velocity` (per node of `model`, which must match `octree`) and the step's
  /// prepared point contacts. After resize(model).
  void assemble(const ElasticModel& model, const DeformationOctree& octree,
                const std::vector<Vec3d>& velocity, const StepContacts& contacts,
                const ImplicitEulerParams& params);

  /// A's blocks, one per slot of the model's sparsity.
  [[nodiscard]] const std::vector<Eigen::Matrix3d>& blocks() const { return blocks_; }
  /// Per free row: the inverse of its 3x3 diagonal block (the inverse of its diagonal
  /// entries, as a diagonal matrix, for Jacobi).
  [[nodiscard]] const std::vector<Eigen::Matrix3d>& diagonalInverse() const {
    return diagonalInverse_;
  }
  /// Per free row, P^T b.
  [[nodiscard]] const std::vector<Vec3d>& rhs() const { return rhs_; }
  /// Per free row, the mass part of A summed over the row, sum_k w_k (m + dt alpha-mass)_n:
  /// A times a translation c of a free piece is massRow_i c exactly.
  [[nodiscard]] const std::vector<double>& massRow() const { return massRow_; }

  /// A as a sparse matrix, 3 #free square (DOF 3 i + axis of free row i), both triangles;
  /// empty when nothing was assembled for `model`'s sparsity.
  [[nodiscard]] Eigen::SparseMatrix<double> reducedMatrix(const ElasticModel& model) const;

 private:
  /// Per element: rotation, force and the blocks on and above the diagonal, contacts included.
  void assembleElements(const ElasticModel& model, const DeformationOctree& octree,
                        const std::vector<Vec3d>& velocity, const StepContacts& contacts,
                        double dt);
  /// Per node: the mass diagonal and dt (M g - alpha M v + f).
  void gatherNodes(const ElasticModel& model, const std::vector<Vec3d>& velocity, double dt,
                   const Vec3d& gravity);
  /// Per free row: P^T b, the mass row, A's blocks on and above the diagonal, the diagonal
  /// inverse; then the blocks below the diagonal.
  void gatherRows(const ElasticModel& model, bool blockDiagonal);
  void mirrorLowerBlocks(const ElasticModel& model);

  /// 36 per element: c_e R K_ab R^T for corners a <= b (kUpperBlock order); the blocks
  /// below the diagonal are these blocks' transposes (K is symmetric).
  std::vector<Eigen::Matrix3d> elementBlocks_;
  std::vector<std::array<Vec3d, 8>> elementForce_;
  std::vector<double> nodeDiagonal_;  ///< m_n + dt alpha-mass_n
  std::vector<Vec3d> nodeRhs_;
  std::vector<Eigen::Matrix3d> blocks_;           ///< reduced matrix, one per sparsity block
  std::vector<Eigen::Matrix3d> diagonalInverse_;  ///< per free row
  std::vector<Vec3d> rhs_;                        ///< per free row
  std::vector<double> massRow_;                   ///< per free row
};

}  // namespace voxcut
