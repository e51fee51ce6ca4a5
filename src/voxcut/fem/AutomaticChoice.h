#pragma once
/// @file AutomaticChoice.h
/// The automatic preconditioner (PreconditionerKind::Automatic; docs/algorithms.md, "The
/// automatic solver choice"): each step runs on the sparse Cholesky factor, the multigrid or
/// the two-level V-cycle, whichever is expected to cost least per step on this body now.
///
/// Why: none wins everywhere. A factor pays where it is cheap and lasts many steps (small
/// bodies, a loose tolerance, slow motion); the multigrid's V-cycles hardly grow in number
/// with the body but its hierarchy is rebuilt for every new sparsity, which a blade cutting
/// frame after frame makes every step; the two-level V-cycle costs little to set up but its
/// iterations grow with the body (docs/performance.md, "The automatic solver choice").
///
/// How: the work of a step is counted, not timed, so the choice is the same for any thread
/// count and machine load. A step's work is expressed in fine-matrix products (one product A x
/// costs `blocks` 3x3 block products) from what the step did: its iterations (each a product,
/// the conjugate gradients' vector work and a preconditioner application), a factorisation
/// (BlockCholesky::updateCount updates), an analysis, a new multigrid hierarchy or coarse
/// levels (AutomaticCosts gives the weights, measured on this code). Each kind keeps a running
/// mean of its own steps' work, and beside it the mean of what its prior (an estimate from the
/// structure, the tolerance, how often the sparsity changes and how often contacts press) said
/// at those steps: its expected work is the observed mean moved by how far the prior has moved
/// since, so that a blade starting to cut, or a tool starting to press, moves the kinds'
/// costs at once. The kind not running drifts
/// back towards its prior by 1/32 a step, so that a kind given up on long ago is tried again
/// once the prior says it would pay. A step switches kind only when another is expected to
/// cost less than `switchRatio` of the current one.
///
/// Thread-safety: one step at a time per object.

#include <cstddef>

#include "voxcut/fem/ImplicitEulerParams.h"

namespace voxcut {

/// Weights of the work counts: in products (one whole fine product A x) unless said, per block
/// of the fine matrix where said. Measured on the bunny at 500 to 30,000 nodes, each operation
/// timed alone against the fine product (docs/performance.md, "The automatic solver choice");
/// only their ratios matter.
struct AutomaticCosts {
  double factorUpdate = 8.0;        ///< one 3x3 block update of a factorisation
  double solveBlock = 2.0;          ///< one block of L in a triangular solve (two per solve)
  double analysisBlock = 25.0;      ///< ordering and symbolic analysis, per block of L
  /// An iteration's own work beside its product and preconditioner (the conjugate
  /// gradients' vector updates, the rigid-mode and contact corrections), in products.
  double iterationOverhead = 2.0;
  double vcycle = 5.0;              ///< one V-cycle, in products (measured 2.9-6.4)
  /// A new multigrid hierarchy, in products (measured 100-320 alone; a cut's refined elements
  /// make it dearer, and a blade cutting every step must keep the body off the multigrid)
  double hierarchyBuild = 700.0;
  double coarseRefresh = 100.0;     ///< new coarse levels, in products (measured 40-136)
  double fineRefresh = 5.0;         ///< the fine smoother following the matrix (2.4-9.7)
  /// One two-level V-cycle, in products, beside its coarse factor's solves (twoLevelCoarseEntry)
  double twoLevelIteration = 1.0;
  /// One entry of the two-level V-cycle's coarse factor, read in each of its two triangular
  /// solves, in fine block products: with twoLevelIteration the V-cycle measured 2.2-8.2
  /// products from 500 to 30,000 nodes, its coarse factor 0.24-0.89 entries per fine block.
  double twoLevelCoarseEntry = 4.0;
  double twoLevelSetup = 20.0;      ///< its coarse system, in products
  double bridgeIteration = 2.0;     ///< the bridge's sweeps beyond the factor's solve, products
  double switchRatio = 0.85;        ///< another kind must be expected below this fraction
  double drift = 1.0 / 32.0;        ///< per step, of a resting kind's mean towards its prior
  double cutRateWeight = 1.0 / 8.0;  ///< of a step in the running cut and contact rates
  /// In contact (the matrix changes every step where the contacts press), the multigrid's
  /// V-cycles per step grow by this factor times the contact rate (measured: 2.0-2.7 times
  /// those at rest from 500 to 12k nodes; 2.3 is the middle), and it remakes its coarse levels
  /// in this share of the steps ...
  double contactVcycles = 1.3;
  double contactRefreshShare = 0.5;
  /// ... and the two-level V-cycle's iterations grow by this factor times the contact rate
  /// (measured: 1.3-2.1 times those at rest).
  double contactTwoLevel = 0.5;
  /// Of a new step in a kind's running mean: a mean over about 1/meanWeight steps, so that a
  /// factorisation every few steps or a cut's new hierarchy is spread over its neighbours.
  double meanWeight = 1.0 / 16.0;
};

/// What one step's preconditioner did (PreconditionerChoice fills it in).
struct StepWork {
  PreconditionerKind family = PreconditionerKind::Cholesky;  ///< the kind chosen
  PreconditionerKind used = PreconditionerKind::Cholesky;    ///< what the solve ran on
  int iterations = 0;
  bool analysed = false;    ///< Cholesky: a new sparsity was ordered and analysed
  bool factorised = false;  ///< Cholesky: a factorisation
  bool bridged = false;     ///< Cholesky: the earlier factor through the node map
  bool built = false;       ///< Multigrid: a new hierarchy
  bool refreshed = false;   ///< Multigrid: new coarse levels
};

/// The structure the work is weighed on: the fine matrix and the last factor analysed.
struct SystemSize {
  std::size_t rows = 0;
  std::size_t blocks = 0;             ///< of the fine matrix (both triangles)
  bool newSparsity = false;           ///< the sparsity changed since the last step (a cut)
  bool contacts = false;              ///< the step has contacts (points or pairs)
  double factorUpdates = 0.0;         ///< of a factorisation (BlockCholesky::updateCount)
  double factorBlocks = 0.0;          ///< of L below the diagonal
  /// Entries of the two-level V-cycle's coarse factor at its last set-up (0: none yet).
  double twoLevelCoarseEntries = 0.0;
};

/// The running choice among Cholesky, Multigrid and TwoLevel for one body (file comment).
class AutomaticChoice {
 public:
  /// The kinds it chooses among, in the order of its tables.
  static constexpr PreconditionerKind kKinds[] = {PreconditionerKind::Cholesky,
                                                  PreconditionerKind::Multigrid,
                                                  PreconditionerKind::TwoLevel};
  static constexpr int kKindCount = 3;

  /// The kind the next step runs on, given the body's size and the solve's tolerance.
  [[nodiscard]] PreconditionerKind choose(const SystemSize& size, double tolerance);

  /// Counts a finished step's work into its kind's mean.
  void record(const StepWork& work, const SystemSize& size);

  /// The expected work of a step of `kind` (products), as the last choose() weighed it.
  [[nodiscard]] double expected(PreconditionerKind kind) const { return expected_[slot(kind)]; }

  /// The work of `work` in fine products (the weights of AutomaticCosts).
  [[nodiscard]] double stepWork(const StepWork& work, const SystemSize& size) const;

  /// The structure-only estimate of a step of `kind`, in products, when the sparsity changes
  /// in a fraction `cutRate` of the steps and contacts press in a fraction `contactRate`.
  [[nodiscard]] double prior(PreconditionerKind kind, const SystemSize& size, double tolerance,
                             double cutRate, double contactRate = 0.0) const;

  /// The part of prior() that new sparsities cost (a new hierarchy, an analysis), which the
  /// observed means leave out.
  [[nodiscard]] double structural(PreconditionerKind kind, const SystemSize& size,
                                  double cutRate) const;
  /// stepWork less what the step paid for a new sparsity (structural()'s part).
  [[nodiscard]] double observedWork(const StepWork& work, const SystemSize& size) const;

  /// The fraction of recent steps whose sparsity had changed (a running mean).
  [[nodiscard]] double cutRate() const { return cutRate_; }
  /// The fraction of recent steps with contacts (a running mean).
  [[nodiscard]] double contactRate() const { return contactRate_; }

  [[nodiscard]] const AutomaticCosts& costs() const { return costs_; }

 private:
  static int slot(PreconditionerKind kind);

  AutomaticCosts costs_;
  int current_ = 0;  ///< slot of the kind running
  bool started_ = false;
  double cutRate_ = 0.0;
  double contactRate_ = 0.0;
  double mean_[kKindCount] = {};       ///< running mean of the kind's steps' work
  double meanPrior_[kKindCount] = {};  ///< the same mean of its prior at those steps
  bool seen_[kKindCount] = {};
  double expected_[kKindCount] = {};
  double prior_[kKindCount] = {};  ///< of the last choose(), its structural() part left out
};

}  // namespace voxcut
