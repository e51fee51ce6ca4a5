#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "FemBodies.h"
#include "voxcut/fem/AutomaticChoice.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEuler.h"

namespace voxcut {
namespace {

using namespace test;

constexpr PreconditionerKind kCholesky = PreconditionerKind::Cholesky;
constexpr PreconditionerKind kMultigrid = PreconditionerKind::Multigrid;
constexpr PreconditionerKind kTwoLevel = PreconditionerKind::TwoLevel;

/// A system of `rows` rows with 20 blocks a row whose factor has `updatesPerBlock` updates
/// and 2.5 blocks below the diagonal per block of the matrix.
SystemSize systemOf(std::size_t rows, double updatesPerBlock) {
  SystemSize s;
  s.rows = rows;
  s.blocks = 20 * rows;
  s.factorUpdates = updatesPerBlock * static_cast<double>(s.blocks);
  s.factorBlocks = 2.5 * static_cast<double>(s.blocks);
  return s;
}

StepWork cholesky(int iterations, bool factorised) {
  StepWork w;
  w.family = w.used = kCholesky;
  w.iterations = iterations;
  w.factorised = factorised;
  return w;
}

StepWork multigrid(int iterations) {
  StepWork w;
  w.family = w.used = kMultigrid;
  w.iterations = iterations;
  return w;
}

TEST(AutomaticChoice, ACheapFactorStartsOnCholeskyAnExpensiveOneOnMultigrid) {
  AutomaticChoice cheap, costly;
  EXPECT_EQ(cheap.choose(systemOf(500, 5.0), 1e-3), kCholesky);
  EXPECT_EQ(costly.choose(systemOf(20000, 500.0), 1e-6), kMultigrid);
  // A looser tolerance lets a factor last longer: the same factor is worth more.
  const SystemSize mid = systemOf(3000, 100.0);
  AutomaticChoice a;
  EXPECT_LT(a.prior(kCholesky, mid, 1e-3, 0.0), a.prior(kCholesky, mid, 1e-6, 0.0));
  EXPECT_LT(a.prior(kMultigrid, mid, 1e-3, 0.0), a.prior(kMultigrid, mid, 1e-6, 0.0));
  // Cuts every step cost the multigrid a hierarchy a step, the two-level V-cycle nothing.
  EXPECT_GT(a.prior(kMultigrid, mid, 1e-6, 1.0),
            a.prior(kMultigrid, mid, 1e-6, 0.0) + a.costs().hierarchyBuild);
  EXPECT_EQ(a.prior(kTwoLevel, mid, 1e-6, 1.0), a.prior(kTwoLevel, mid, 1e-6, 0.0));
}

TEST(AutomaticChoice, WorkCountsWhatTheStepDid) {
  AutomaticChoice a;
  const SystemSize s = systemOf(1000, 50.0);
  const AutomaticCosts& c = a.costs();
  const double plain = a.stepWork(cholesky(3, false), s);
  EXPECT_DOUBLE_EQ(plain, 3.0 * (1.0 + c.iterationOverhead + 2.0 * c.solveBlock * 2.5));
  EXPECT_DOUBLE_EQ(a.stepWork(cholesky(3, true), s) - plain, c.factorUpdate * 50.0);
  StepWork built = multigrid(4);
  built.built = built.refreshed = true;
  EXPECT_DOUBLE_EQ(a.stepWork(built, s) - a.stepWork(multigrid(4), s),
                   c.hierarchyBuild + c.coarseRefresh);
  StepWork standIn = cholesky(10, false);
  standIn.used = PreconditionerKind::TwoLevel;
  // The two-level V-cycle's coarse solves count by its factor's entries per fine block.
  SystemSize factored = s;
  factored.twoLevelCoarseEntries = 0.5 * static_cast<double>(s.blocks);
  EXPECT_DOUBLE_EQ(a.stepWork(standIn, factored),
                   10.0 * (1.0 + c.iterationOverhead + c.twoLevelIteration +
                           2.0 * c.twoLevelCoarseEntry * 0.5) +
                       c.twoLevelSetup);
  // Before its first set-up they are estimated from the rows: growing with the body, so
  // that a two-level iteration costs more products on a larger one.
  const double perProductSmall = a.stepWork(standIn, systemOf(1000, 50.0));
  const double perProductLarge = a.stepWork(standIn, systemOf(20000, 50.0));
  EXPECT_GT(perProductLarge, perProductSmall);
}

TEST(AutomaticChoice, SwitchesWhenTheRunningKindCostsMoreAndComesBackWhenThePriorSaysSo) {
  AutomaticChoice a;
  const SystemSize s = systemOf(2000, 10.0);
  const double tolerance = 1e-6;
  ASSERT_EQ(a.choose(s, tolerance), kCholesky);
  // A factor that goes stale every step (a fast motion): Cholesky's mean climbs until the
  // multigrid's prior is cheaper by the switch ratio.
  int steps = 0;
  PreconditionerKind k = kCholesky;
  while (k == kCholesky && steps < 200) {
    a.record(cholesky(3, true), s);
    k = a.choose(s, tolerance);
    ++steps;
  }
  ASSERT_EQ(k, kMultigrid) << "never left a factor remade every step";
  EXPECT_GT(steps, 1);  // one expensive step is not enough to switch
  EXPECT_LT(a.expected(kMultigrid), a.costs().switchRatio * a.expected(kCholesky) + 1e-9);
  // On the multigrid at a little over its prior's cost (7.6 V-cycles at 1e-6), Cholesky's
  // estimate drifts back to its own prior, which is cheaper by more than the switch ratio, so
  // Cholesky is tried again.
  steps = 0;
  while (k == kMultigrid && steps < 1000) {
    a.record(multigrid(9), s);
    k = a.choose(s, tolerance);
    ++steps;
  }
  EXPECT_EQ(k, kCholesky);
  EXPECT_GT(steps, 10);  // not at once: the observation is kept for a while
}

TEST(AutomaticChoice, ABladeCuttingEveryStepTakesTheBodyOffTheMultigridWithinAFewSteps) {
  AutomaticChoice a;
  SystemSize s = systemOf(20000, 500.0);  // a large body: its factor would cost too much
  ASSERT_EQ(a.choose(s, 1e-6), kMultigrid);
  for (int step = 0; step < 40; ++step) {  // at rest on the multigrid
    a.record(multigrid(8), s);
    ASSERT_EQ(a.choose(s, 1e-6), kMultigrid);
  }
  // Now every step has a new sparsity, hence a new hierarchy.
  s.newSparsity = true;
  int steps = 0;
  PreconditionerKind k = kMultigrid;
  while (k == kMultigrid && steps < 50) {
    StepWork w = multigrid(8);
    w.built = w.refreshed = true;
    a.record(w, s);
    k = a.choose(s, 1e-6);
    ++steps;
  }
  EXPECT_EQ(k, kTwoLevel);
  // Within a few steps: each new hierarchy raises the cut rate by 1/8, and with it the
  // multigrid's expected cost by 1/8 of a hierarchy and coarse levels; at 20,000 rows the
  // two-level V-cycle's 34 iterations are cheaper once the cut rate passes about a half.
  EXPECT_LE(steps, 6);
  EXPECT_GT(a.cutRate(), 0.0);
}

// Contacts change the matrix where they press every step: the multigrid needs more V-cycles
// and remakes its coarse levels, the two-level V-cycle (with nothing to remake) needs a few more
// iterations; the priors say so, in proportion to the share of recent steps with contacts.
TEST(AutomaticChoice, ContactsMakeTheMultigridDearerThanTheTwoLevelVCycle) {
  AutomaticChoice a;
  const SystemSize s = systemOf(3000, 500.0);
  const double mgRest = a.prior(kMultigrid, s, 1e-6, 0.0, 0.0);
  const double mgContact = a.prior(kMultigrid, s, 1e-6, 0.0, 1.0);
  const double tlRest = a.prior(kTwoLevel, s, 1e-6, 0.0, 0.0);
  const double tlContact = a.prior(kTwoLevel, s, 1e-6, 0.0, 1.0);
  EXPECT_GT(tlContact, tlRest);
  EXPECT_GT(mgContact / mgRest, tlContact / tlRest);
  EXPECT_GT(mgContact, a.prior(kMultigrid, s, 1e-6, 0.0, 0.5));
  // The running rate: a body in contact from its first step starts at 1; steps without
  // contacts bring it down.
  SystemSize touching = s;
  touching.contacts = true;
  (void)a.choose(touching, 1e-6);
  EXPECT_EQ(a.contactRate(), 1.0);
  for (int k = 0; k < 40; ++k) (void)a.choose(s, 1e-6);
  EXPECT_LT(a.contactRate(), 0.01);
}

TEST(AutomaticChoice, StaysPutBetweenTwoKindsOfAboutTheSameCost) {
  AutomaticChoice a;
  const SystemSize s = systemOf(2000, 20.0);
  PreconditionerKind k = a.choose(s, 1e-3);
  int switches = 0;
  for (int step = 0; step < 300; ++step) {
    double other = 1e30;
    for (PreconditionerKind o : AutomaticChoice::kKinds)
      if (o != k) other = std::min(other, a.expected(o));
    // Each step costs what the other kind is expected to cost, within 10 %.
    StepWork w = k == kCholesky ? cholesky(1, false) : multigrid(1);
    const double unit = a.stepWork(w, s);
    w.iterations = static_cast<int>(0.95 * other / unit) + 1;
    a.record(w, s);
    const PreconditionerKind next = a.choose(s, 1e-3);
    switches += next != k ? 1 : 0;
    k = next;
  }
  EXPECT_LE(switches, 2);
}

TEST(AutomaticChoice, TheStepReportsTheKindItChoseAndConverges) {
  Body b = smallBody(0.2, 1e-4);
  std::vector<std::uint8_t> fixed(b.octree.nodeCount(), 0);
  for (std::size_t n = 0; n < fixed.size(); ++n)
    fixed[n] = b.octree.nodeCoord(static_cast<std::uint32_t>(n))[0] == 0 ? 1 : 0;
  b.model.setFixed(std::move(fixed));
  ImplicitEulerParams p;
  p.gravity = Vec3d(0.3, -2.0, -9.81);
  p.tolerance = 1e-6;
  p.maxIterations = 500;
  p.preconditioner = PreconditionerKind::Automatic;
  ImplicitEuler solver(p);
  EXPECT_EQ(solver.chosenPreconditioner(), PreconditionerKind::Automatic);
  for (int s = 0; s < 20; ++s) {
    const StepStatus st = solver.step(b.model, b.octree);
    EXPECT_TRUE(st.converged) << "step " << s;
    const PreconditionerKind chosen = solver.chosenPreconditioner();
    EXPECT_TRUE(chosen == kCholesky || chosen == kMultigrid || chosen == kTwoLevel);
    EXPECT_NE(st.preconditioner, PreconditionerKind::Automatic);
    EXPECT_GT(solver.expectedWork(kCholesky), 0.0);
    EXPECT_GT(solver.expectedWork(kMultigrid), 0.0);
    EXPECT_GT(solver.expectedWork(kTwoLevel), 0.0);
  }
  // A body of a few hundred rows: a factor is cheap and lasts, the choice is Cholesky.
  EXPECT_EQ(solver.chosenPreconditioner(), kCholesky);
}

}  // namespace
}  // namespace voxcut
