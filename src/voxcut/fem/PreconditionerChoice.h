#pragma once
/// @file PreconditionerChoice.h
/// The preconditioners an implicit Euler step's conjugate gradients run on (ImplicitEuler.h;
/// docs/algorithms.md, "Preconditioners", "Multigrid", "Factor bridge" and "A second try
/// within the step"), kept from step to step, and the choice, each step, of the one that
/// preconditions its solve (PreconditionerKind, ImplicitEulerParams):
///
/// - Cholesky: the factor of an earlier step's matrix, refactorised when the previous step
///   took more than refactorIterations iterations; a new sparsity is analysed and factorised
///   once it has lasted factorAfterSteps steps, the steps before run on the earlier factor
///   mapped onto the new rows (FactorBridge.h) while that bridge has not worn out
///   (bridgeIterations), else on the two-level V-cycle, which also stands in for a factor that
///   would cost too much (maxFactorUpdates, maxFactorUpdatesPerBlock) or fails;
/// - Multigrid: the hierarchy built once per sparsity, its coarse levels remade when the
///   previous step's iterations rose (multigridRefreshIterations), else only the fine smoother
///   following the matrix; the two-level V-cycle where a level fails;
/// - IC(0) refactorised every step; the others from the assembly's diagonal inverses.
///
/// A solve that does not converge on a preconditioner made for earlier steps (the bridge, a
/// kept factor or kept coarse levels) goes on once, from where it stopped, on one made for
/// this step's matrix. With pair contacts, every application ends with the coarse correction
/// by the pieces' rigid motions (RigidModes::coarseCorrection). All are deterministic for any
/// thread count.
///
/// Thread-safety: one step at a time per object.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/fem/AutomaticChoice.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/FactorBridge.h"
#include "voxcut/fem/ImplicitEulerParams.h"
#include "voxcut/fem/RigidModes.h"
#include "voxcut/linalg/BlockCholesky.h"
#include "voxcut/linalg/BlockPreconditioner.h"
#include "voxcut/linalg/ConjugateGradients.h"
#include "voxcut/linalg/Multigrid.h"
#include "voxcut/linalg/TwoLevelPreconditioner.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/topology/TopologyChange.h"

namespace voxcut {

/// The preconditioners kept between steps and what the choice among them remembers.
class PreconditionerChoice {
 public:
  /// What a solve's preconditioner is made from, borrowed for that solve.
  struct Inputs {
    const ElasticModel& model;
    const ImplicitEulerParams& params;
    const std::vector<Eigen::Matrix3d>& blocks;           ///< A, per slot of the sparsity
    const std::vector<Eigen::Matrix3d>& diagonalInverse;  ///< per free row
    const std::vector<Vec3d>& freePositions;  ///< current, for the two-level V-cycle's rotations
    const RigidModes* coarse = nullptr;       ///< set: a coarse correction after each apply
  };

  /// The cost limits may have changed: a sparsity found too costly to factorise is tried
  /// again.
  void forgetCostlySparsity() { costlyRows_ = 0; }

  /// Before a step of `model` on `octree` (with `contacts` or without): counts the steps on
  /// its sparsity, takes the free nodes' grid coordinates for a new multigrid hierarchy, and
  /// maps the factor onto a new sparsity (FactorBridge::prepare) unless the last step on the
  /// bridge wore it out.
  void beginStep(const ElasticModel& model, const DeformationOctree& octree,
                 const ImplicitEulerParams& params, bool contacts = false);

  /// Runs the conjugate gradients `cg` (operator, coupling and settings set) from x and its
  /// residual r on this step's preconditioner, and once more on one made for this step's
  /// matrix when that did not converge (the file comment); writes the preconditioners used
  /// into `status` (factorised, bridged, retried, preconditioner). The iterations of both
  /// runs are summed.
  ConjugateGradientStatus iterate(ConjugateGradients& cg, const Inputs& in, double bb,
                                  std::vector<Vec3d>& x, std::vector<Vec3d>& r,
                                  StepStatus& status);

  /// After a step: its iterations and whether it ran on the bridge, which the next step's
  /// choice depends on.
  void endStep(const StepStatus& status);

  /// Whether a step has begun, and the kind the last one chose (the setting's, or the
  /// automatic choice's Cholesky, Multigrid or TwoLevel).
  [[nodiscard]] bool stepped() const { return stepped_; }
  [[nodiscard]] PreconditionerKind stepKind() const { return stepKind_; }

  /// Automatic: the expected work of a step on `kind` (Cholesky, Multigrid, TwoLevel), in fine
  /// products, as the last step's choice weighed it (AutomaticChoice.h).
  [[nodiscard]] double expectedWork(PreconditionerKind kind) const {
    return automatic_.expected(kind);
  }

  /// Remaps the bridge through a topology change (as ImplicitEuler::updateTopology).
  void updateTopology(const TopologyChange& change);

 private:
  class StepPreconditioner;  ///< the preconditioner of one solve (PreconditionerChoice.cpp)

  /// Automatic: the kind this step of `model` runs on (AutomaticChoice.h).
  PreconditionerKind chooseAutomatic(const ElasticModel& model, double tolerance);
  /// Orders and analyses `sparsity` for cholesky_, and keeps the factor's size.
  void analyse(const BlockSparsity& sparsity);

  /// Automatic: bodies with more free rows than this are not analysed for a first estimate
  /// of their factor (its analysis alone would cost several steps); they start on the
  /// multigrid.
  static constexpr std::size_t kAutomaticAnalysisRows = 40000;

  PreconditionerKind stepKind_ = PreconditionerKind::Cholesky;  ///< of the current step
  AutomaticChoice automatic_;
  bool stepped_ = false;
  bool automaticStep_ = false;  ///< the current step's kind is the automatic choice's
  StepWork work_;               ///< what the current step's preconditioners did
  SystemSize size_;             ///< what the automatic choice weighs the work on
  std::size_t analysedRows_ = 0;  ///< rows of the sparsity cholesky_ analysed last
  double analysedUpdates_ = 0.0;  ///< its factor's updates and blocks below the diagonal
  double analysedBlocks_ = 0.0;

  IncompleteCholeskyPattern icPattern_;  ///< of the sparsity with revision icRevision_
  std::uint64_t icRevision_ = 0;
  IncompleteCholeskyFactor factor_;
  TwoLevelPreconditioner twoLevel_;
  Multigrid multigrid_;
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
};

}  // namespace voxcut
