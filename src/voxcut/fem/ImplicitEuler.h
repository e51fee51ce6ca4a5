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
/// Thread-safety: one step at a time per ImplicitEuler; it owns its scratch buffers (sized
/// once, reused, so steps do not allocate once the sizes settle).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/FactorBridge.h"
#include "voxcut/fem/RigidModes.h"
#include "voxcut/linalg/BlockCholesky.h"
#include "voxcut/linalg/BlockPreconditioner.h"
#include "voxcut/linalg/ConjugateGradients.h"
#include "voxcut/linalg/Multigrid.h"
#include "voxcut/linalg/RowCoupling.h"
#include "voxcut/linalg/SolutionProjection.h"
#include "voxcut/linalg/TwoLevelPreconditioner.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/topology/TopologyChange.h"

namespace voxcut {

/// The kinds of preconditioner of the conjugate gradients (docs/algorithms.md,
/// "Preconditioners"; the iterations each takes per step, from bench/bench_fem:
/// docs/performance.md, "Deformation solver"). ImplicitEuler sets up and applies the kind
/// chosen through linalg's interface (linalg/LinearPreconditioner.h).
///
/// IC(0) costs a factorisation per step (about 4 matrix-vector products' worth of work) and a
/// sequential solve per iteration (about one product). Where a pivot breaks down it falls back
/// to block Jacobi for that row; it has gone unstable on a piece cut off (docs/performance.md,
/// "Deformation solver"). Symmetric Gauss-Seidel is positive definite for any
/// SPD matrix and stable there, but its iterations grow with the body's size, with the
/// contrast between element sizes and on a cut-off piece that hangs on its mass alone. The
/// two-level V-cycle adds a coarse correction by the rigid motions of node aggregates: an
/// iteration costs about 2.5 products and the coarse matrix (6 unknowns per aggregate) is
/// factorised (sparse Cholesky) every step, but its iterations stay low in every case.
///
/// Cholesky (the default) preconditions with the exact sparse Cholesky factor of an earlier
/// step's matrix (linalg/BlockCholesky.h). The matrix changes little from one step to the
/// next (the element rotations move slowly), so a factor stays good for many steps: it is
/// recomputed only when the previous step needed more than `refactorIterations` iterations, and for
/// a new sparsity once it has lasted `factorAfterSteps` steps. The steps before, a cut's, run on
/// the earlier factor mapped onto the new rows (FactorBridge.h: a V-cycle with that factor as its
/// coarse solve and Gauss-Seidel on the rows the change touched); without an earlier factor,
/// or for a system whose factor would cost too much (`maxFactorUpdates`), the two-level
/// V-cycle stands in. A factorisation costs more than a step's iterations and an iteration a
/// few products (its forward and backward solves are sequential), but a factor brings a step
/// down to a few iterations, so over the steps it serves it is the cheapest. Being an exact
/// factor of an SPD matrix, a stale one is still SPD: the conjugate gradients stay correct,
/// only slower.
/// Multigrid (linalg/Multigrid.h; docs/algorithms.md, "Multigrid") runs a V-cycle through
/// coarse levels made from the node grid, cut parts kept apart: its iterations grow least with
/// the body's size (docs/performance.md, "Deformation solver at scale"). Its hierarchy is built
/// once per sparsity; its coarse levels are remade only when a step's iterations rise
/// (multigridRefreshIterations), else only the fine smoother follows the matrix. Where a
/// factor fails (not positive definite) the step falls back to the two-level V-cycle.
/// All are deterministic for any thread count.
enum class PreconditionerKind {
  Jacobi,                ///< inverse of the diagonal entries
  BlockJacobi,           ///< inverse of each node's 3x3 diagonal block
  SymmetricGaussSeidel,  ///< one forward and one backward block Gauss-Seidel sweep
  IncompleteCholesky,    ///< block IC(0), refactorised every step (linalg/BlockPreconditioner.h)
  TwoLevel,   ///< Gauss-Seidel and aggregates' rigid motions (linalg/TwoLevelPreconditioner.h)
  Cholesky,   ///< sparse Cholesky factor of an earlier step's matrix (linalg/BlockCholesky.h)
  Multigrid,  ///< geometric multigrid V-cycle on the node grid (linalg/Multigrid.h)
};

/// Every kind of preconditioner, in declaration order.
inline constexpr PreconditionerKind kPreconditionerKinds[] = {
    PreconditionerKind::Jacobi,
    PreconditionerKind::BlockJacobi,
    PreconditionerKind::SymmetricGaussSeidel,
    PreconditionerKind::IncompleteCholesky,
    PreconditionerKind::TwoLevel,
    PreconditionerKind::Cholesky,
    PreconditionerKind::Multigrid};

/// Name of a preconditioner ("jacobi", "block_jacobi", "symmetric_gauss_seidel",
/// "incomplete_cholesky", "two_level", "cholesky", "multigrid"), for reports and scene files.
[[nodiscard]] const char* preconditionerName(PreconditionerKind p);

/// Settings of a time step.
struct ImplicitEulerParams {
  double timeStep = 0.004;        ///< dt (s), > 0
  Vec3d gravity = Vec3d::Zero();  ///< g (m/s^2), as external force M g
  double tolerance = 1e-3;        ///< stop when |r| <= tolerance |b| (reduced 2-norms)
  int maxIterations = 200;        ///< conjugate-gradient iteration cap (>= 0)
  PreconditionerKind preconditioner = PreconditionerKind::Cholesky;
  bool warmStart = true;  ///< start from the previous step's dv
  /// With warmStart: keep the last this many solutions (carried through topology changes
  /// as the velocities are) and start a solve from their best combination in the energy norm
  /// (linalg/SolutionProjection.h) instead of the previous dv alone. It costs one matrix
  /// product per kept solution, so it starts after a solve that took more iterations than
  /// solutions kept, and stops after a projected solve that took fewer than half as many.
  /// 0 turns it off.
  int projectionHistory = 8;
  /// Correct each solve by the rigid motions of every piece (RigidModes.h), so that the
  /// net force and torque of a step are exact whatever the tolerance.
  bool rigidCorrection = true;
  /// Cholesky only: refactorise when the previous step's solve took more iterations than
  /// this (the factor has gone stale).
  int refactorIterations = 3;
  /// Cholesky only: a new sparsity (a cut, other fixed nodes) is analysed and factorised once
  /// it has lasted this many steps; the steps before use the earlier factor through the node
  /// map (FactorBridge.h), or the two-level preconditioner when there is none. While
  /// a blade cuts every frame, a factor would be thrown away as soon as it was made.
  int factorAfterSteps = 1;
  /// Cholesky only: steps on a new sparsity run on the earlier factor through the node map
  /// (FactorBridge.h) while the previous such step took at most this many iterations; after
  /// one that took more (the changes since the factor have piled up: a blade cutting frame
  /// after frame, with no step in between to factorise), the two-level V-cycle until the next
  /// factorisation (the iterations of a scene that cuts frame after frame: docs/performance.md,
  /// "Running scenes").
  int bridgeIterations = 12;
  /// Cholesky only: when one factorisation would cost more 3x3 block updates than this
  /// (BlockCholesky::updateCount) or more than maxFactorUpdatesPerBlock
  /// per block of the matrix, the two-level preconditioner is used instead: a factor whose
  /// fill outgrows the body costs more to make, and each of its sequential solves more, than
  /// the iterations it saves (the shipped scenes' organs stay well below the limit per block,
  /// a thin beam does not: docs/performance.md, "Deformation solver").
  double maxFactorUpdates = 1e7;
  double maxFactorUpdatesPerBlock = 50.0;
  /// Multigrid only: the coarse levels (Galerkin products of the fine matrix) are made anew
  /// on a new sparsity and when the previous step took more than this many iterations
  /// beyond the first step on them; in between they stay those of an earlier step's matrix,
  /// which the rotations change little (the V-cycle stays symmetric positive definite:
  /// linalg/Multigrid.h), and only the fine level's smoother follows the matrix.
  int multigridRefreshIterations = 3;
  MultigridParams multigrid;  ///< Multigrid only: the hierarchy's settings
};

/// What one step did. The counts and the residual are the conjugate gradients'; the rigid-mode
/// correction after them (ImplicitEulerParams::rigidCorrection) is a Galerkin projection, so
/// it can only lower the error in the energy norm.
struct StepStatus {
  int iterations = 0;       ///< conjugate-gradient iterations run
  double residual = 0.0;    ///< final |r| / |b| (0 when b = 0)
  bool converged = false;   ///< residual <= tolerance within maxIterations
  bool finite = true;       ///< false: a non-finite value appeared; nothing was moved
  double assemblyMs = 0.0;  ///< wall time of the assembly (rotations, forces, blocks), ms
  double solveMs = 0.0;     ///< wall time of the preconditioner set-up and the solve, ms
  bool factorised = false;  ///< Cholesky: this step computed a new factor
  /// Cholesky: the sparsity had changed since the factor (a cut) and the step was
  /// preconditioned by the earlier factor through the node map (FactorBridge.h)
  bool bridged = false;
  /// The solve did not converge on the first preconditioner and went on with one made for
  /// this step's matrix (a new factor, new coarse levels).
  bool retried = false;
  /// The preconditioner the solve used (Cholesky may hand a step to TwoLevel); the setting's
  /// own when the warm start already converged.
  PreconditionerKind preconditioner = PreconditionerKind::Cholesky;
};

/// A point of the body pressed against something by a penalty spring along a fixed normal
/// for one step (docs/algorithms.md, "Contact"): the force on the point is
/// f = -stiffness (gap + n . (u - u0)) n, u - u0 its displacement during the step, taken into
/// the implicit step with its stiffness (so contact is as stable as the elastic forces), and
/// spread to the element's corners with the point's trilinear weights. Friction, where given,
/// is a tangential damper toward the velocity of what is pressed on, also implicit:
/// f_t = -friction (I - n n^T) (v_p - surfaceVelocity) at the step's end velocity (the caller
/// sets friction = mu f_n / max(|v_t|, eps), a regularised Coulomb law; docs/algorithms.md,
/// "Friction").
struct PointContact {
  std::uint32_t element = 0;              ///< element (copy) holding the point
  std::array<double, 8> weight{};         ///< the point's trilinear weights in it, summing to 1
  Vec3d normal = Vec3d::UnitY();          ///< unit, pointing out of what is pressed on
  double gap = 0.0;                       ///< signed distance along normal at the step's start (m)
  double stiffness = 0.0;                 ///< penalty stiffness (N/m), >= 0
  double friction = 0.0;                  ///< tangential damping (N s/m), >= 0
  Vec3d surfaceVelocity = Vec3d::Zero();  ///< of what is pressed on (m/s; its tangential part)
};

/// A spring between two points of the body (self contact: a surface vertex pressed into
/// another part of the same body, docs/algorithms.md, "Self contact in one solve"), taken
/// into the implicit step whole: the force on point a is
/// f = -stiffness (gap + dt n . (v_a - v_b)) n at the step's end velocities, and -f on point
/// b, with friction -friction (I - n n^T)(v_a - v_b) on a and its opposite on b. Equal and
/// opposite by construction, so the pair moves no momentum into the body.
struct PairContact {
  std::uint32_t element = 0;          ///< element (copy) holding point a
  std::array<double, 8> weight{};     ///< a's trilinear weights in it
  std::uint32_t other = 0;            ///< element (copy) holding point b
  std::array<double, 8> otherWeight{};  ///< b's trilinear weights in it
  Vec3d normal = Vec3d::UnitY();      ///< unit, the direction a is pushed (out of b's material)
  double gap = 0.0;                   ///< signed distance along normal at the step's start (m)
  double stiffness = 0.0;             ///< penalty stiffness (N/m), >= 0
  double friction = 0.0;              ///< tangential damping (N s/m), >= 0
};

/// Backward Euler integrator: the node velocities and the solver's state between steps.
class ImplicitEuler {
 public:
  explicit ImplicitEuler(const ImplicitEulerParams& params = {}) : params_(params) {}

  [[nodiscard]] const ImplicitEulerParams& params() const { return params_; }
  void setParams(const ImplicitEulerParams& params) {
    params_ = params;
    costlyRows_ = 0;  // the cost limits may have changed
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
  [[nodiscard]] const std::vector<double>& contactForces() const { return contactForce_; }
  /// Per contact of the last step, in the order given: its friction force on the body (N).
  [[nodiscard]] const std::vector<Vec3d>& contactFrictionForces() const { return contactFriction_; }
  /// The pair contacts of the next step, used for that one step and then cleared.
  void setPairContacts(std::vector<PairContact> pairs);
  /// Per pair contact of the last step, in the order given: the normal force on point a at
  /// the step's end, -stiffness (gap + dt n . (v_a - v_b)) (N; negative when it pulled).
  [[nodiscard]] const std::vector<double>& pairForces() const { return pairForce_; }
  /// Per pair contact of the last step, in the order given: its friction force on point a (N).
  [[nodiscard]] const std::vector<Vec3d>& pairFrictionForces() const { return pairFriction_; }

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
  void resize(const ElasticModel& model);
  void assemble(const ElasticModel& model, const DeformationOctree& octree);
  StepStatus solve(const ElasticModel& model);
  /// The kept solutions from the free rows of the last solve to nodes.
  void projectionToNodes();
  class StepPreconditioner;  ///< the preconditioner of one solve (ImplicitEuler.cpp)

  ImplicitEulerParams params_;
  std::vector<Vec3d> velocity_;  ///< per node
  std::vector<Vec3d> lastDv_;    ///< per node, the warm start

  // Scratch, sized by resize(), reused across steps.
  /// 36 per element: c_e R K_ab R^T for corners a <= b (kUpperBlock order); the blocks
  /// below the diagonal are these blocks' transposes (K is symmetric).
  std::vector<Eigen::Matrix3d> elementBlocks_;
  std::vector<std::array<Vec3d, 8>> elementForce_;
  std::vector<double> nodeDiagonal_;  ///< m_n + dt alpha-mass_n
  std::vector<Vec3d> nodeRhs_;
  std::vector<Eigen::Matrix3d> blocks_;          ///< reduced matrix, one per sparsity block
  std::vector<Eigen::Matrix3d> preconditioner_;  ///< per free node: (block) diagonal inverse
  IncompleteCholeskyPattern icPattern_;          ///< of the sparsity with revision icRevision_
  std::uint64_t icRevision_ = 0;
  IncompleteCholeskyFactor factor_;
  TwoLevelPreconditioner twoLevel_;
  Multigrid multigrid_;
  /// Earlier solutions less their free pieces' means: by free row of the sparsity of the last
  /// solve, or by node after a topology change (until the next solve takes them to its rows).
  SolutionProjection projection_;
  bool projectionByNode_ = false;
  std::uint64_t projectionRevision_ = 0;      ///< sparsity of the kept solutions' rows
  bool projecting_ = false;                   ///< whether the next solve starts projected
  std::vector<std::uint32_t> lastFreeNodes_;  ///< the rows of the kept solutions
  std::size_t lastNodeCount_ = 0;
  std::vector<Vec3d> projectionRhs_;
  std::uint64_t multigridRevision_ = 0;  ///< sparsity the hierarchy was built for
  bool multigridRefreshed_ = false;      ///< the last step made the coarse levels anew
  int multigridBaseIterations_ = 0;      ///< iterations of the first step on them
  std::vector<Index3> freeCoords_;       ///< node-grid coordinates of the free nodes
  BlockCholesky cholesky_;               ///< analysed for the sparsity with choleskyRevision_
  FactorBridge bridge_;                  ///< from cholesky_'s model to the current one
  std::uint64_t bridgeRevision_ = 0;     ///< sparsity the bridge was last prepared for
  std::uint64_t choleskyRevision_ = 0;
  std::uint64_t costlyRevision_ = 0;  ///< a sparsity whose factor would cost too much
  std::size_t costlyRows_ = 0;        ///< its rows (0: none so far)
  int lastIterations_ = 0;          ///< of the previous step (Cholesky: decides a refactorisation)
  bool lastBridged_ = false;        ///< the previous step ran on the bridge
  std::uint64_t stepRevision_ = 0;  ///< sparsity revision of the last step
  int stepsOnStructure_ = 0;        ///< steps before this one on the same sparsity
  std::vector<PointContact> contacts_;       ///< of the next step, sorted by element (stable)
  std::vector<std::uint32_t> contactStart_;  ///< per element + 1: its contacts' range (when any)
  std::vector<std::size_t> contactOrder_;    ///< contacts_[k] was given at contactOrder_[k]
  std::vector<double> contactForce_;         ///< of the last step, in the order given
  std::vector<Vec3d> contactFriction_;       ///< of the last step, in the order given
  std::vector<PairContact> pairs_;           ///< of the next step, in the order given
  std::vector<double> pairForce_;            ///< of the last step, in the order given
  std::vector<Vec3d> pairFriction_;          ///< of the last step, in the order given
  RowCoupling coupling_;                     ///< the pairs' cross terms, by free row
  std::vector<Vec3d> freePositions_;         ///< current positions of the free nodes
  std::vector<double> freeMasses_;           ///< lumped masses of the free nodes (kg)
  /// Per free row, the mass part of the reduced matrix summed over the row, sum_k w_k
  /// (m + dt alpha-mass)_n: A times a translation c of a free piece is massRow_i c exactly.
  std::vector<double> massRow_;
  /// Per free row: coupled through an element to a node that is not the full prolongation
  /// of free nodes (fixed, or hanging on a fixed master); its piece's translations stiffen.
  std::vector<std::uint8_t> anchoredRow_;
  std::uint64_t anchoredRevision_ = 0;   ///< sparsity revision anchoredRow_ is for
  std::vector<std::uint8_t> freePiece_;  ///< per rigid_ piece: no anchored row
  std::vector<Vec3d> shift_;             ///< per free row, its free piece's common warm start
  RigidModes rigid_;
  std::array<std::vector<Vec3d>, 6> rigidProducts_;  ///< scratch: A times each rigid mode
  /// The conjugate gradients and their scratch; the preconditioner is each solve's own.
  ConjugateGradients cg_;
  std::vector<Vec3d> b_, x_, r_, q_, vr_;
  std::vector<double> partial_;  ///< per chunk of rows, for |b|^2
};

}  // namespace voxcut
