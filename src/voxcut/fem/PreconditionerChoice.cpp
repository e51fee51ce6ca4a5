#include "voxcut/fem/PreconditionerChoice.h"

#include <cmath>
#include <limits>

#include "voxcut/core/Timer.h"

namespace voxcut {

/// The preconditioner of one solve, through linalg's interface. setOperator, which the
/// conjugate gradients call once an iteration is needed, decides what preconditions this step
/// (Cholesky's factor, made anew or kept; the earlier factor through the bridge; the two-level
/// V-cycle where neither is to be had; the multigrid's levels, remade or kept: see
/// ImplicitEulerParams), sets it up and writes the choice into the step's status; apply runs
/// it. Jacobi and block Jacobi act row by row with the assembly's inverse diagonal blocks.
class PreconditionerChoice::StepPreconditioner final : public LinearPreconditioner {
 public:
  /// `refresh`: set up from this step's matrix whatever the last steps did (a new Cholesky
  /// factor, analysed now for a new sparsity unless too costly; the multigrid's coarse levels
  /// remade): the second try of a solve the first preconditioner did not bring to converge.
  StepPreconditioner(PreconditionerChoice& choice, const Inputs& in, StepStatus& status,
                     bool refresh = false)
      : choice_(choice),
        in_(in),
        status_(status),
        kind_(choice.stepKind_),
        refresh_(refresh) {}

  [[nodiscard]] bool setOperator(const BlockMatrixView& a, bool threaded) override;
  void apply(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) override;
  [[nodiscard]] const Eigen::Matrix3d* rowBlocks() const override {
    const bool pointwise =
        kind_ == PreconditionerKind::Jacobi || kind_ == PreconditionerKind::BlockJacobi;
    return pointwise ? in_.diagonalInverse.data() : nullptr;
  }

 private:
  /// Cholesky: a new factor, the kept one, the bridge, or the two-level V-cycle instead.
  void chooseCholesky(std::size_t rows, bool threaded);
  /// Multigrid: a new hierarchy, new coarse levels or a new fine smoother; two-level if none.
  void chooseMultigrid(const BlockMatrixView& view, bool threaded);

  PreconditionerChoice& choice_;
  const Inputs& in_;
  StepStatus& status_;
  PreconditionerKind kind_;  ///< what apply runs (Cholesky may hand a step to TwoLevel)
  bool bridged_ = false;     ///< apply runs the earlier factor through the bridge
  bool threaded_ = true;
  bool refresh_ = false;
};

bool PreconditionerChoice::StepPreconditioner::setOperator(const BlockMatrixView& view,
                                                           bool threaded) {
  const Timer timer;
  PreconditionerChoice& s = choice_;
  const ElasticModel& model = in_.model;
  const BlockSparsity& sp = model.sparsity();
  threaded_ = threaded;
  if (kind_ == PreconditionerKind::IncompleteCholesky) {
    if (s.icRevision_ != model.sparsityRevision()) {
      s.icPattern_ = incompleteCholeskyPattern(sp);
      s.icRevision_ = model.sparsityRevision();
    }
    factorIncompleteCholesky(sp, s.icPattern_, in_.blocks, s.factor_);
  }
  if (kind_ == PreconditionerKind::Cholesky) chooseCholesky(view.rows, threaded);
  if (kind_ == PreconditionerKind::Multigrid) chooseMultigrid(view, threaded);
  if (kind_ == PreconditionerKind::TwoLevel) {
    (void)s.twoLevel_.setup(sp, model.aggregation(), in_.blocks, &in_.freePositions, threaded);
    s.size_.twoLevelCoarseEntries = s.twoLevel_.coarseFactorEntries();
  }
  status_.preconditioner = kind_;
  status_.bridged = bridged_;
  s.work_.bridged = s.work_.bridged || bridged_;
  status_.parts.setup += timer.ms();
  return true;  // every kind above applies, the two-level V-cycle as smoothing alone at worst
}

void PreconditionerChoice::StepPreconditioner::chooseCholesky(std::size_t rows, bool threaded) {
  PreconditionerChoice& s = choice_;
  const ElasticModel& model = in_.model;
  const ImplicitEulerParams& params = in_.params;
  const BlockSparsity& sp = model.sparsity();
  // A new structure is analysed and factorised once it has lasted factorAfterSteps steps;
  // until then, when its factor would cost too much, or when the matrix is not SPD, the
  // two-level V-cycle stands in. A structure at least 90 % the size of one whose factor
  // was too costly is not analysed again (the analysis alone takes tens of ms there).
  const std::uint64_t revision = model.sparsityRevision();
  if (s.choleskyRevision_ != revision && s.costlyRevision_ != revision &&
      (s.stepsOnStructure_ >= params.factorAfterSteps || refresh_)) {
    if (s.costlyRows_ != 0 && 10 * rows >= 9 * s.costlyRows_) {
      s.costlyRevision_ = revision;
    } else {
      s.analyse(sp);
      s.choleskyRevision_ = revision;
      const double updates = s.cholesky_.updateCount();
      s.costlyRows_ = 0;
      // The automatic choice weighs a factor's cost itself (AutomaticChoice.h).
      if (!s.automaticStep_ &&
          (updates > params.maxFactorUpdates ||
           updates > params.maxFactorUpdatesPerBlock * static_cast<double>(sp.blockCount()))) {
        s.costlyRows_ = rows;
        s.costlyRevision_ = revision;
        s.cholesky_ = BlockCholesky{};  // its pattern's memory back
      }
    }
  }
  if (s.choleskyRevision_ != revision || s.costlyRevision_ == revision) {
    // The earlier factor through the node map when beginStep could prepare it.
    bridged_ = s.bridgeRevision_ == revision && s.bridge_.valid() && s.cholesky_.factorised();
    if (!bridged_) kind_ = PreconditionerKind::TwoLevel;
  } else if (!s.cholesky_.factorised() || s.lastIterations_ > params.refactorIterations ||
             refresh_) {
    status_.factorised = s.cholesky_.factorise(sp, in_.blocks, threaded);
    s.work_.factorised = true;
    if (status_.factorised)
      s.bridge_.reset(model);
    else {
      s.bridge_.invalidate();
      kind_ = PreconditionerKind::TwoLevel;
    }
  }
}

void PreconditionerChoice::StepPreconditioner::chooseMultigrid(const BlockMatrixView& view,
                                                               bool threaded) {
  PreconditionerChoice& s = choice_;
  const ElasticModel& model = in_.model;
  const ImplicitEulerParams& params = in_.params;
  // The hierarchy follows the sparsity; its coarse levels are remade when the last step
  // showed them stale, else only the fine smoother follows the new matrix.
  if (s.multigridRefreshed_) s.multigridBaseIterations_ = s.lastIterations_;
  s.multigridRefreshed_ = false;
  bool ok = false;
  if (s.multigridRevision_ != model.sparsityRevision() || !s.multigrid_.built()) {
    s.multigrid_.build(view, s.freeCoords_, params.multigrid, threaded);
    s.multigridRevision_ = model.sparsityRevision();
    s.work_.built = true;
    ok = s.multigridRefreshed_ = s.multigrid_.setOperator(view, threaded);
  } else if (!s.multigrid_.valid() || refresh_ ||
             s.lastIterations_ > s.multigridBaseIterations_ + params.multigridRefreshIterations) {
    ok = s.multigridRefreshed_ = s.multigrid_.setOperator(view, threaded);
  } else {
    ok = s.multigrid_.updateFine(view, threaded);
    if (!ok) ok = s.multigridRefreshed_ = s.multigrid_.setOperator(view, threaded);
  }
  s.work_.refreshed = s.work_.refreshed || s.multigridRefreshed_;
  if (!ok) kind_ = PreconditionerKind::TwoLevel;
}

void PreconditionerChoice::StepPreconditioner::apply(const std::vector<Vec3d>& r,
                                                     std::vector<Vec3d>& z) {
  PreconditionerChoice& s = choice_;
  const BlockSparsity& sp = in_.model.sparsity();
  if (bridged_)
    s.bridge_.apply(sp, in_.blocks, s.cholesky_, in_.diagonalInverse, r, z);
  else if (kind_ == PreconditionerKind::Cholesky)
    s.cholesky_.solve(r, z);
  else if (kind_ == PreconditionerKind::IncompleteCholesky)
    applyIncompleteCholesky(sp, s.factor_, r, z);
  else if (kind_ == PreconditionerKind::Multigrid)
    s.multigrid_.apply(r, z);
  else if (kind_ == PreconditionerKind::TwoLevel)
    s.twoLevel_.apply(sp, in_.model.aggregation(), in_.blocks, in_.diagonalInverse, r, z,
                      threaded_);
  else
    applySymmetricGaussSeidel(sp, in_.blocks, in_.diagonalInverse, r, z);
  // Pair contacts couple rows the preconditioner does not see: it takes two sides pressed
  // together for stiff where they move together. The pieces' rigid motions, coupled through
  // the pairs (RigidModes), give that motion back as a coarse correction.
  if (in_.coarse != nullptr) in_.coarse->coarseCorrection(r, z);
}

void PreconditionerChoice::beginStep(const ElasticModel& model, const DeformationOctree& octree,
                                     const ImplicitEulerParams& params, bool contacts) {
  const std::uint64_t revision = model.sparsityRevision();
  if (revision != stepRevision_) {
    stepRevision_ = revision;
    stepsOnStructure_ = 0;
  } else if (stepsOnStructure_ < std::numeric_limits<int>::max()) {
    ++stepsOnStructure_;
  }
  const std::vector<std::uint32_t>& freeNodes = model.freeNodes();
  work_ = StepWork{};
  size_.newSparsity = stepped_ && stepsOnStructure_ == 0;
  size_.contacts = contacts;
  stepped_ = true;
  automaticStep_ = params.preconditioner == PreconditionerKind::Automatic;
  stepKind_ = automaticStep_ ? chooseAutomatic(model, params.tolerance) : params.preconditioner;
  work_.family = stepKind_;
  if (stepKind_ == PreconditionerKind::Multigrid && multigridRevision_ != revision) {
    freeCoords_.resize(freeNodes.size());
    for (std::size_t i = 0; i < freeNodes.size(); ++i)
      freeCoords_[i] = octree.nodeCoord(freeNodes[i]);
  }
  // A cut since the factor: map the factor onto the new rows (FactorBridge.h), once per
  // sparsity, unless the last step on the bridge showed it has worn out.
  if (lastBridged_ && lastIterations_ > params.bridgeIterations) bridge_.invalidate();
  if (stepKind_ == PreconditionerKind::Cholesky && bridge_.valid() &&
      cholesky_.factorised() && revision != choleskyRevision_ && bridgeRevision_ != revision) {
    if (bridge_.prepare(model, octree, cholesky_.rows())) bridgeRevision_ = revision;
  }
}

ConjugateGradientStatus PreconditionerChoice::iterate(ConjugateGradients& cg, const Inputs& in,
                                                      double bb, std::vector<Vec3d>& x,
                                                      std::vector<Vec3d>& r, StepStatus& status) {
  StepPreconditioner preconditioner(*this, in, status);
  cg.setPreconditioner(preconditioner);
  ConjugateGradientStatus result = cg.iterate(bb, x, r);
  // Not converged on a preconditioner made for earlier steps (the earlier factor through the
  // bridge after a cut, a factor or coarse levels of a matrix the contacts have changed since):
  // once more from where it stopped, on one made for this step's matrix.
  const bool betterFactor = stepKind_ == PreconditionerKind::Cholesky &&
                            !status.factorised &&
                            costlyRevision_ != in.model.sparsityRevision();
  const bool betterLevels =
      stepKind_ == PreconditionerKind::Multigrid && !multigridRefreshed_;
  if (!result.converged && result.finite && result.preconditioned &&
      (betterFactor || betterLevels)) {
    StepStatus again;
    StepPreconditioner fresh(*this, in, again, true);
    cg.setPreconditioner(fresh);
    const ConjugateGradientStatus more = cg.iterate(bb, x, r);
    status.factorised = status.factorised || again.factorised;
    status.preconditioner = again.preconditioner;
    status.bridged = again.bridged;
    status.retried = true;
    status.parts.setup += again.parts.setup;
    result = ConjugateGradientStatus{result.iterations + more.iterations, more.residual,
                                     more.converged, more.finite, more.preconditioned};
  }
  return result;
}

void PreconditionerChoice::analyse(const BlockSparsity& sparsity) {
  cholesky_.analyse(sparsity);
  bridge_.invalidate();
  work_.analysed = true;
  analysedRows_ = cholesky_.rows();
  analysedUpdates_ = cholesky_.updateCount();
  analysedBlocks_ = static_cast<double>(cholesky_.offDiagonalBlocks());
}

PreconditionerKind PreconditionerChoice::chooseAutomatic(const ElasticModel& model,
                                                        double tolerance) {
  const BlockSparsity& sp = model.sparsity();
  const std::size_t rows = model.freeNodeCount();
  // The first step weighs the factor of its own sparsity (an analysis, a fraction of a
  // factorisation) unless the body is too large for a factor to have a chance; later
  // sparsities scale the last analysis by their rows (fill grows as rows^(4/3), the work of
  // a factorisation as rows^2 for three-dimensional meshes under a nested ordering).
  if (analysedRows_ == 0 && rows > 0 && rows <= kAutomaticAnalysisRows) {
    analyse(sp);
    choleskyRevision_ = model.sparsityRevision();
  }
  const double scale = analysedRows_ == 0 ? 0.0
                                          : static_cast<double>(rows) /
                                                static_cast<double>(analysedRows_);
  size_.rows = rows;
  size_.blocks = sp.blockCount();
  size_.factorUpdates = analysedRows_ == 0 ? 1e30 : analysedUpdates_ * scale * scale;
  size_.factorBlocks = analysedRows_ == 0 ? 1e30 : analysedBlocks_ * std::pow(scale, 4.0 / 3.0);
  return automatic_.choose(size_, tolerance);
}

void PreconditionerChoice::endStep(const StepStatus& status) {
  lastIterations_ = status.iterations;
  lastBridged_ = status.bridged;
  if (!automaticStep_) return;
  work_.iterations = status.iterations;
  work_.used = status.preconditioner;
  if (work_.analysed || work_.factorised) {  // weigh the factor actually made
    size_.factorUpdates = analysedUpdates_;
    size_.factorBlocks = analysedBlocks_;
  }
  automatic_.record(work_, size_);
}

void PreconditionerChoice::updateTopology(const TopologyChange& change) {
  bridge_.update(change);
  bridgeRevision_ = 0;
}

}  // namespace voxcut
