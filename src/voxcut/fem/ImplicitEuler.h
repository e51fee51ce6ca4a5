#pragma once
/// @file ImplicitEuler.h
/// One implicit (backward) Euler step of the corotational composite FEM (docs/algorithms.md,
/// "Implicit Euler"), one linearised solve per step:
///
///   (M + dt C + dt^2 K) dv = dt (f_el + f_ext - C v - dt K v),  v += dv,  x += dt v,
///
/// with K = sum_e R_e K_e R_e^T (R_e from the polar decomposition of the deformation gradient
/// averaged over the element's material, Corotation.h, dR ignored), f_el = -sum_e R_e K_e y_e (y_e
/// the corotated displacement), C = alpha M (exact per voxel, lumped) + sum_e beta_e R_e K_e R_e^T
/// (beta_e the element's E-weighted mean), f_ext = M g. Everything is reduced by the hanging-node
/// and fixed-node prolongation P (ElasticModel.h): the solve is on P^T A P with P^T b, so hanging
/// nodes stay at the mean of their masters and fixed nodes keep their position and zero
/// velocity.
///
/// The system is solved by preconditioned conjugate gradients (linalg/ConjugateGradients.h)
/// on a 3x3-block sparse matrix assembled each step (each block on or above the diagonal
/// gathered from its sources in a fixed order, the ones below mirrored), preconditioned by
/// default by the sparse Cholesky factor of an earlier step's matrix (linalg/BlockCholesky.h;
/// the two-level V-cycle of linalg/TwoLevelPreconditioner.h stands in where no factor is
/// ready), warm-started from the previous step's dv. Parallel over elements and rows; dot products
/// are summed over fixed chunks in a fixed order and triangular solves are sequential, so results
/// are bit-identical for any thread count.
///
/// ImplicitEuler runs the step and holds the velocities; its parts, each in its own file:
/// the contact law (ContactLaw.h) and a step's contact set (StepContacts.h), the assembly of
/// the reduced system (StepAssembly.h), the choice and set-up of the preconditioner with the
/// second try within a step (PreconditionerChoice.h), the warm start and the projection onto
/// earlier solutions (WarmStart.h), and the rigid-mode correction with the free pieces
/// (RigidCorrection.h).
///
/// Thread-safety: one step at a time per ImplicitEuler; it owns its scratch buffers (sized
/// once, reused, so steps do not allocate once the sizes settle).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/fem/ContactLaw.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEulerParams.h"
#include "voxcut/fem/PreconditionerChoice.h"
#include "voxcut/fem/RigidCorrection.h"
#include "voxcut/fem/StepAssembly.h"
#include "voxcut/fem/StepContacts.h"
#include "voxcut/fem/WarmStart.h"
#include "voxcut/linalg/BlockMatrix.h"
#include "voxcut/linalg/ConjugateGradients.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/topology/TopologyChange.h"

namespace voxcut {

/// Backward Euler integrator: the node velocities and the solver's state between steps.
class ImplicitEuler {
 public:
  explicit ImplicitEuler(const ImplicitEulerParams& params = {}) : params_(params) {}

  [[nodiscard]] const ImplicitEulerParams& params() const { return params_; }
  void setParams(const ImplicitEulerParams& params) {
    params_ = params;
    preconditioners_.forgetCostlySparsity();  // the cost limits may have changed
  }

  /// Advances `octree` by one time step with `model` (which must match it): writes the new
  /// current positions of the free nodes, then sets the hanging nodes from their masters;
  /// keeps the new velocities. A solve that does not converge still moves the nodes (with the
  /// last iterate) and says so in the status; a non-finite right-hand side or solution moves
  /// nothing, resets the warm start and returns finite == false. Never throws for either.
  StepStatus step(const ElasticModel& model, DeformationOctree& octree);

  /// The point contacts of the next step (elements of the model that step gets); they are
  /// used for that one step and then cleared. Not sorted in any particular way.
  void setContacts(std::vector<PointContact> contacts);
  /// Per contact of the last step, in the order given: the normal force at the step's end,
  /// -stiffness (gap + n . dt v_point) (N; negative when the step pulled the point).
  [[nodiscard]] const std::vector<double>& contactForces() const {
    return contacts_.normalForces();
  }
  /// Per contact of the last step, in the order given: its friction force on the body (N).
  [[nodiscard]] const std::vector<Vec3d>& contactFrictionForces() const {
    return contacts_.frictionForces();
  }
  /// The pair contacts of the next step, used for that one step and then cleared.
  void setPairContacts(std::vector<PairContact> pairs);
  /// Per pair contact of the last step, in the order given: the normal force on point a at
  /// the step's end, -stiffness (gap + dt n . (v_a - v_b)) (N; negative when it pulled).
  [[nodiscard]] const std::vector<double>& pairForces() const { return contacts_.pairForces(); }
  /// Per pair contact of the last step, in the order given: its friction force on point a (N).
  [[nodiscard]] const std::vector<Vec3d>& pairFrictionForces() const {
    return contacts_.pairFrictionForces();
  }

  /// The preconditioner the last step chose (Cholesky, Multigrid or TwoLevel under Automatic; the
  /// setting before the first step). A step's StepStatus says what its solve ran on, which
  /// may be a stand-in (the two-level V-cycle).
  [[nodiscard]] PreconditionerKind chosenPreconditioner() const {
    return preconditioners_.stepped() ? preconditioners_.stepKind() : params_.preconditioner;
  }
  /// Automatic: the work a step on `kind` (Cholesky, Multigrid or TwoLevel) is expected to cost, in fine
  /// matrix products, as the last step weighed it (fem/AutomaticChoice.h).
  [[nodiscard]] double expectedWork(PreconditionerKind kind) const {
    return preconditioners_.expectedWork(kind);
  }

  /// Node velocities (m/s), one per node of the model last stepped (or set); empty before.
  [[nodiscard]] const std::vector<Vec3d>& velocities() const { return velocity_; }
  /// Sets the node velocities (one per node; the next step projects them through P, so
  /// fixed nodes get zero and hanging nodes their masters' mean).
  void setVelocities(std::vector<Vec3d> velocity) { velocity_ = std::move(velocity); }
  /// Forgets velocities and warm start (the next step starts at rest).
  void reset();

  /// Remaps velocities and the warm start through a topology change: node n takes the
  /// weighted sum of its sources' values (zero without sources). Call with the same change as
  /// ElasticModel::updateTopology. No-op when !change.changed.
  void updateTopology(const TopologyChange& change);

  /// Kinetic energy 1/2 sum_n m_n |v_n|^2 (J) with the model's lumped masses, as consistent
  /// with P (equals 1/2 v_r^T P^T M P v_r).
  [[nodiscard]] double kineticEnergy(const ElasticModel& model) const;

  /// The reduced system matrix P^T (M + dt C + dt^2 K) P of the last step, 3 #free square
  /// (DOF 3 i + axis of free node i), both triangles; empty before the first step.
  [[nodiscard]] Eigen::SparseMatrix<double> reducedMatrix(const ElasticModel& model) const;

 private:
  /// Sizes the velocities, the warm start and the buffers for `model`.
  void resize(const ElasticModel& model);
  /// The solve of the assembled system: the velocity change dv into x_ (free rows).
  StepStatus solve(const ElasticModel& model);
  /// The start of the solve from x_ (the warm start): the rigid-mode set-up, the start split
  /// into its free pieces' means (shift_) and the rest (q_), projected onto earlier solutions
  /// where due, and its residual r_; their times go to `parts`. Returns whether it was
  /// projected.
  bool startSolve(const ElasticModel& model, const BlockMatrixView& view, StepParts& parts);
  /// The end of a solve that ran `cg`: the rigid-mode correction of the result, the status,
  /// and the solution kept for later projections.
  void finishSolve(const ConjugateGradientStatus& cg, bool projected, StepStatus& status);
  /// After a finite solve: new velocities, the contacts' forces, new positions.
  void advance(const ElasticModel& model, DeformationOctree& octree);

  ImplicitEulerParams params_;
  std::vector<Vec3d> velocity_;  ///< per node
  StepContacts contacts_;
  StepAssembly assembly_;
  PreconditionerChoice preconditioners_;
  WarmStart warmStart_;
  RigidCorrection rigid_;
  std::vector<Vec3d> freePositions_;  ///< current positions of the free nodes
  std::vector<double> freeMasses_;    ///< lumped masses of the free nodes (kg)
  /// The conjugate gradients and their scratch; the preconditioner is each solve's own.
  ConjugateGradients cg_;
  std::vector<Vec3d> x_, r_, q_, vr_;
  std::vector<Vec3d> shift_;     ///< per free row, its free piece's common warm start
  std::vector<double> partial_;  ///< per chunk of rows, for |b|^2
};

}  // namespace voxcut
