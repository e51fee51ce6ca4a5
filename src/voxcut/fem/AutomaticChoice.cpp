#include "voxcut/fem/AutomaticChoice.h"

#include <algorithm>
#include <cmath>

namespace voxcut {

namespace {

/// Digits of accuracy the solve asks for: 3 at a relative tolerance of 1e-3.
double digits(double tolerance) { return std::clamp(-std::log10(tolerance), 1.0, 12.0); }

/// One two-level V-cycle in fine products: its sweeps, and its coarse factor's two solves,
/// which grow faster with the body than the fine matrix does. Before its first set-up the
/// factor's entries per fine block are estimated from the rows (measured on the bunny: 0.24 at
/// 430 rows, 0.48 at 4,700, 0.89 at 21,000).
double twoLevelCycle(const AutomaticCosts& costs, const SystemSize& size) {
  const double blocks = std::max<double>(1.0, static_cast<double>(size.blocks));
  const double perBlock = size.twoLevelCoarseEntries > 0.0
                              ? size.twoLevelCoarseEntries / blocks
                              : 0.1 * std::pow(static_cast<double>(size.rows) / 100.0, 0.4);
  return costs.twoLevelIteration + 2.0 * costs.twoLevelCoarseEntry * perBlock;
}

}  // namespace

int AutomaticChoice::slot(PreconditionerKind kind) {
  for (int k = 0; k < kKindCount; ++k)
    if (kKinds[k] == kind) return k;
  return 0;
}

double AutomaticChoice::stepWork(const StepWork& w, const SystemSize& size) const {
  const double blocks = std::max<double>(1.0, static_cast<double>(size.blocks));
  const double solve = 2.0 * costs_.solveBlock * size.factorBlocks / blocks;
  const double iterations = w.iterations;
  const double iteration = 1.0 + costs_.iterationOverhead;  // product and vector work
  double work = 0.0;
  if (w.used == PreconditionerKind::Multigrid) {
    work = iterations * (iteration + costs_.vcycle) + costs_.fineRefresh;
  } else if (w.used == PreconditionerKind::Cholesky) {
    work = iterations * (iteration + solve + (w.bridged ? costs_.bridgeIteration : 0.0));
  } else {  // the two-level V-cycle, chosen or standing in
    work = iterations * (iteration + twoLevelCycle(costs_, size)) + costs_.twoLevelSetup;
  }
  if (w.analysed) work += costs_.analysisBlock * size.factorBlocks / blocks;
  if (w.factorised) work += costs_.factorUpdate * size.factorUpdates / blocks;
  if (w.built) work += costs_.hierarchyBuild;
  if (w.refreshed) work += costs_.coarseRefresh;
  return work;
}

double AutomaticChoice::observedWork(const StepWork& w, const SystemSize& size) const {
  // What a new sparsity costs (an analysis; a hierarchy and its first coarse levels) is
  // weighed by the cut rate in structural(), not by the steps that happened to pay it.
  StepWork kept = w;
  if (w.built) kept.refreshed = false;
  kept.built = kept.analysed = false;
  return stepWork(kept, size);
}

double AutomaticChoice::prior(PreconditionerKind kind, const SystemSize& size, double tolerance,
                              double cutRate, double contactRate) const {
  const double blocks = std::max<double>(1.0, static_cast<double>(size.blocks));
  const double iteration = 1.0 + costs_.iterationOverhead;
  const double c = std::clamp(cutRate, 0.0, 1.0);
  const double touching = std::clamp(contactRate, 0.0, 1.0);
  // Measured on the bunny at 1e-3 and 1e-6 (docs/performance.md, "The automatic solver
  // choice"): 6 V-cycles a step at 1e-3, 7-8 at 1e-6, at every size; the two-level V-cycle
  // as many on small bodies, growing with the rows beyond a few thousand (11-12 iterations at
  // 400 and 2,300 rows, 17-21 at 950, 4,500 and 8,300: the square root of the rows in
  // thousands, at least 1.5, is the middle of that spread).
  const double vcycles = 4.0 + 0.6 * digits(tolerance);
  const double rows = static_cast<double>(size.rows);
  // Contacts change the matrix where they press, every step: more iterations, and coarse
  // levels that go stale.
  const double twoLevelIterations = vcycles * std::max(1.5, std::sqrt(rows / 1000.0)) *
                                    (1.0 + costs_.contactTwoLevel * touching);
  const double twoLevel =
      twoLevelIterations * (iteration + twoLevelCycle(costs_, size)) + costs_.twoLevelSetup;
  if (kind == PreconditionerKind::TwoLevel) return twoLevel;
  if (kind == PreconditionerKind::Multigrid)
    return vcycles * (1.0 + costs_.contactVcycles * touching) * (iteration + costs_.vcycle) +
           costs_.fineRefresh + touching * costs_.contactRefreshShare * costs_.coarseRefresh +
           structural(kind, size, cutRate);
  // Cholesky: a fresh factor of a slowly rotating body brings a step down to a couple of
  // iterations; how many steps it lasts falls with the digits asked for (measured: about 30
  // at 1e-3, 3 at 1e-6, the bunny swinging under gravity). A step with a new sparsity runs
  // on a stand-in (the bridge, the two-level V-cycle), and the next without one analyses and
  // factorises anew.
  const double lifetime =
      std::clamp(3.0 * std::pow(10.0, (6.0 - digits(tolerance)) / 3.0), 1.0, 100.0);
  const double factor = costs_.factorUpdate * size.factorUpdates / blocks;
  const double solve = 2.0 * costs_.solveBlock * size.factorBlocks / blocks;
  const double steady = factor / lifetime + 2.5 * (iteration + solve);
  return (1.0 - c) * steady + c * twoLevel + c * (1.0 - c) * factor +
         structural(kind, size, cutRate);
}

double AutomaticChoice::structural(PreconditionerKind kind, const SystemSize& size,
                                   double cutRate) const {
  const double c = std::clamp(cutRate, 0.0, 1.0);
  if (kind == PreconditionerKind::Multigrid)
    return c * (costs_.hierarchyBuild + costs_.coarseRefresh);
  if (kind == PreconditionerKind::Cholesky) {
    const double blocks = std::max<double>(1.0, static_cast<double>(size.blocks));
    return c * (1.0 - c) * costs_.analysisBlock * size.factorBlocks / blocks;
  }
  return 0.0;
}

PreconditionerKind AutomaticChoice::choose(const SystemSize& size, double tolerance) {
  if (started_) {
    cutRate_ += costs_.cutRateWeight * ((size.newSparsity ? 1.0 : 0.0) - cutRate_);
    contactRate_ += costs_.cutRateWeight * ((size.contacts ? 1.0 : 0.0) - contactRate_);
  } else {
    contactRate_ = size.contacts ? 1.0 : 0.0;  // a body that starts in contact
  }
  for (int k = 0; k < kKindCount; ++k) {
    const double structure = structural(kKinds[k], size, cutRate_);
    prior_[k] = prior(kKinds[k], size, tolerance, cutRate_, contactRate_) - structure;
    if (!seen_[k]) {
      expected_[k] = prior_[k] + structure;
      continue;
    }
    // A resting kind's observation fades into what its prior said then, so that its
    // expectation drifts to today's prior.
    if (k != current_) mean_[k] += costs_.drift * (meanPrior_[k] - mean_[k]);
    // The observed mean, moved by how far the prior has moved since (a cut rate rising),
    // and the new sparsities' cost at today's cut rate.
    expected_[k] = std::max(0.0, mean_[k] + prior_[k] - meanPrior_[k]) + structure;
  }
  int best = 0;
  for (int k = 1; k < kKindCount; ++k)
    if (expected_[k] < expected_[best]) best = k;
  if (!started_ || expected_[best] < costs_.switchRatio * expected_[current_]) current_ = best;
  started_ = true;
  return kKinds[current_];
}

void AutomaticChoice::record(const StepWork& w, const SystemSize& size) {
  const int k = slot(w.family);
  const double work = observedWork(w, size);
  // The means start from the prior, so that the set-up of a kind's first step (a factor, a
  // hierarchy) counts as one step among many rather than as the kind's cost.
  if (!seen_[k]) mean_[k] = meanPrior_[k] = prior_[k];
  mean_[k] += costs_.meanWeight * (work - mean_[k]);
  meanPrior_[k] += costs_.meanWeight * (prior_[k] - meanPrior_[k]);
  seen_[k] = true;
}

}  // namespace voxcut
