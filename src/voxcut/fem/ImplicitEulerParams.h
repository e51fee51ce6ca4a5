#pragma once
/// @file ImplicitEulerParams.h
/// The settings of an implicit Euler step (ImplicitEuler.h), the kinds of preconditioner it
/// chooses among (PreconditionerChoice.h) and the status a step returns.
///
/// Thread-safety: plain values; preconditionerName is pure.

#include <cstdint>

#include "voxcut/core/Types.h"
#include "voxcut/linalg/Multigrid.h"

namespace voxcut {

/// The kinds of preconditioner of the conjugate gradients (docs/algorithms.md,
/// "Preconditioners"; the iterations each takes per step, from bench/bench_fem:
/// docs/performance.md, "Deformation solver"). PreconditionerChoice.h chooses the kind for each
/// step, sets it up and applies it through linalg's interface (linalg/LinearPreconditioner.h).
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
  /// Cholesky, Multigrid or TwoLevel, chosen per body and step from its structure and its
  /// last steps (fem/AutomaticChoice.h); a step's status names the one it used.
  Automatic,
};

/// Every kind of preconditioner, in declaration order.
inline constexpr PreconditionerKind kPreconditionerKinds[] = {
    PreconditionerKind::Jacobi,
    PreconditionerKind::BlockJacobi,
    PreconditionerKind::SymmetricGaussSeidel,
    PreconditionerKind::IncompleteCholesky,
    PreconditionerKind::TwoLevel,
    PreconditionerKind::Cholesky,
    PreconditionerKind::Multigrid,
    PreconditionerKind::Automatic};

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

/// Wall time of a step's parts, ms (docs/performance.md, "The step by its parts"); they add
/// up to the step's time but for the few vector copies between them.
struct StepParts {
  double prepare = 0.0;     ///< velocities projected, the solver choice, contacts prepared
  double assembly = 0.0;    ///< rotations, forces, element blocks, the reduced rows
  /// The rigid-mode correction: the modes and their products with A, the start's and the
  /// result's corrections.
  double rigid = 0.0;
  /// The start projected onto the earlier solutions, and its residual b - A x0.
  double projection = 0.0;
  double setup = 0.0;       ///< the preconditioner's set-up (a factor, coarse levels, smoother)
  double iterations = 0.0;  ///< the conjugate-gradient iterations, preconditioning included
  double advance = 0.0;     ///< the solution kept for later starts, prolonged, nodes moved
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
  StepParts parts;          ///< the step's wall time by its parts
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

}  // namespace voxcut
