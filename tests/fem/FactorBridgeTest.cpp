#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <string>
#include <vector>

#include "FemBodies.h"
#include "voxcut/fem/FactorBridge.h"
#include "voxcut/fem/ImplicitEuler.h"
#include "voxcut/linalg/BlockCholesky.h"
#include "voxcut/topology/CutTopology.h"

namespace voxcut {
namespace {

using namespace test;

// A bar of 8 x 40 x 8 voxels in level-2 elements, fixed at y = 0, and the links of the
// plane y = 30 crossed over x < 3: a small cut near the free end, refined down to level 1.
struct CutBlock {
  VoxelGrid grid;
  DeformationOctree octree;
  ElasticModel model;
  std::vector<std::uint64_t> cut;
};

CutBlock cutBlock() {
  CutBlock c;
  c.grid = makeGrid({9, 41, 9}, 0.003,
                    [](int x, int y, int z) { return x < 8 && y < 40 && z < 8 ? 1 : 0; });
  c.octree = makeOctree(c.grid, 2, 2);
  std::vector<ElasticMaterial> mats(2);
  mats[1] = {1e5, 0.35, 1000.0, 0.5, 0.01};
  c.model = ElasticModel(c.octree, c.grid, mats);
  std::vector<std::uint8_t> fixed(c.octree.nodeCount(), 0);
  for (std::size_t n = 0; n < fixed.size(); ++n)
    fixed[n] = c.octree.nodeCoord(static_cast<std::uint32_t>(n)).y == 0 ? 1 : 0;
  c.model.setFixed(fixed);
  for (int z = 0; z < 8; ++z)
    for (int x = 0; x < 3; ++x) c.cut.push_back(VoxelGrid::linkId(c.grid.index(x, 30, z), 1));
  return c;
}

// Applies the cut to the grid, the octree and the model; returns the change.
TopologyChange applyCut(CutBlock& c) {
  for (std::uint64_t l : c.cut)
    c.grid.setConnected(static_cast<std::size_t>(l / 3), static_cast<int>(l % 3), false);
  CutTopologyParams p;
  p.finestLevel = 1;
  TopologyChange tc = updateCutTopology(c.octree, c.grid, c.cut, p);
  c.model.updateTopology(c.octree, c.grid, tc);
  return tc;
}

std::vector<Eigen::Matrix3d> diagonalInverses(const ElasticModel& model, const BlockSystem& sys) {
  const BlockSparsity& sp = model.sparsity();
  std::vector<Eigen::Matrix3d> out(model.freeNodeCount());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = sys.blocks[sp.diagonal[i]].inverse();
  return out;
}

// M^-1 as a dense matrix: the bridge applied to every unit vector.
Eigen::MatrixXd denseBridge(FactorBridge& bridge, const ElasticModel& model, const BlockSystem& sys,
                            BlockCholesky& factor) {
  const std::size_t rows = model.freeNodeCount();
  const std::vector<Eigen::Matrix3d> dinv = diagonalInverses(model, sys);
  Eigen::MatrixXd m(3 * static_cast<Eigen::Index>(rows), 3 * static_cast<Eigen::Index>(rows));
  std::vector<Vec3d> e(rows, Vec3d::Zero()), z;
  for (std::size_t i = 0; i < rows; ++i)
    for (int a = 0; a < 3; ++a) {
      e[i][a] = 1.0;
      bridge.apply(model.sparsity(), sys.blocks, factor, dinv, e, z);
      m.col(3 * static_cast<Eigen::Index>(i) + a) = flat(z);
      e[i][a] = 0.0;
    }
  return m;
}

TEST(FactorBridge, WithoutAChangeItIsTheFactor) {
  CutBlock c = cutBlock();
  const BlockSystem sys = restBlockSystem(c.model);
  BlockCholesky factor;
  factor.analyse(c.model.sparsity());
  ASSERT_TRUE(factor.factorise(c.model.sparsity(), sys.blocks, false));
  FactorBridge bridge;
  bridge.reset(c.model);
  ASSERT_TRUE(bridge.prepare(c.model, c.octree, factor.rows()));
  EXPECT_EQ(bridge.localRows(), 0u);
  const std::vector<Vec3d> r = randomVector(c.model.freeNodeCount(), 3);
  std::vector<Vec3d> z, exact;
  bridge.apply(c.model.sparsity(), sys.blocks, factor, diagonalInverses(c.model, sys), r, z);
  factor.solve(r, exact);
  ASSERT_EQ(z.size(), exact.size());
  for (std::size_t i = 0; i < z.size(); ++i) EXPECT_EQ(z[i], exact[i]) << "row " << i;
}

TEST(FactorBridge, AfterACutItIsSymmetricPositiveDefinite) {
  CutBlock c = cutBlock();
  BlockSystem sys = restBlockSystem(c.model);
  BlockCholesky factor;
  factor.analyse(c.model.sparsity());
  ASSERT_TRUE(factor.factorise(c.model.sparsity(), sys.blocks, false));
  FactorBridge bridge;
  bridge.reset(c.model);
  const std::size_t before = c.model.freeNodeCount();
  const TopologyChange tc = applyCut(c);
  ASSERT_TRUE(tc.changed);
  bridge.update(tc);
  ASSERT_TRUE(bridge.prepare(c.model, c.octree, factor.rows()));
  const std::size_t rows = c.model.freeNodeCount();
  ASSERT_GT(rows, before);  // refined and duplicated nodes
  EXPECT_GT(bridge.localRows(), 0u);
  EXPECT_LT(bridge.localRows(), rows);  // most rows still use the old factor alone
  sys = restBlockSystem(c.model);
  const Eigen::MatrixXd m = denseBridge(bridge, c.model, sys, factor);
  const double scale = m.cwiseAbs().maxCoeff();
  EXPECT_LE((m - m.transpose()).cwiseAbs().maxCoeff(), 1e-12 * scale);
  const Eigen::MatrixXd sym = 0.5 * (m + m.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(sym, Eigen::EigenvaluesOnly);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 1e-9 * eig.eigenvalues().maxCoeff());
  // As a preconditioner of the new system: the condition number of M^-1 A (the eigenvalues
  // of C^T A C with M^-1 = C C^T) is a tenth of block Jacobi's D^-1 A or less.
  const auto condition = [&](const Eigen::MatrixXd& inverse) {
    const Eigen::MatrixXd l =
        Eigen::LLT<Eigen::MatrixXd>(0.5 * (inverse + inverse.transpose())).matrixL();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e(l.transpose() * sys.dense * l,
                                                           Eigen::EigenvaluesOnly);
    return e.eigenvalues().maxCoeff() / e.eigenvalues().minCoeff();
  };
  Eigen::MatrixXd jacobi = Eigen::MatrixXd::Zero(m.rows(), m.cols());
  const std::vector<Eigen::Matrix3d> dinv = diagonalInverses(c.model, sys);
  for (std::size_t i = 0; i < rows; ++i)
    jacobi.block<3, 3>(3 * static_cast<Eigen::Index>(i), 3 * static_cast<Eigen::Index>(i)) =
        dinv[i];
  const double bridged = condition(m), blockJacobi = condition(jacobi);
  RecordProperty("condition_bridged", std::to_string(bridged));
  RecordProperty("condition_block_jacobi", std::to_string(blockJacobi));
  EXPECT_LT(bridged, 0.1 * blockJacobi);  // measured: 2.0 against 33.4
}

TEST(FactorBridge, ARowPastTheFactorInvalidatesIt) {
  CutBlock c = cutBlock();
  FactorBridge bridge;
  bridge.reset(c.model);
  EXPECT_FALSE(bridge.prepare(c.model, c.octree, 1));  // a factor of one row cannot serve
  EXPECT_FALSE(bridge.valid());
  bridge.update(applyCut(c));  // ignored: invalid
  EXPECT_FALSE(bridge.prepare(c.model, c.octree, c.model.freeNodeCount()));
}

TEST(ImplicitEulerDynamics, CutStepIsBridgedAndAgreesWithTwoLevel) {
  // The same cut body stepped with the default (Cholesky) and the two-level preconditioner to
  // a tight tolerance: the cut step runs on the earlier factor through the bridge, in fewer
  // iterations, and lands where the two-level one does.
  CutBlock a = cutBlock(), b = cutBlock();
  ImplicitEulerParams p;
  p.gravity = Vec3d(0.5, -9.81, 1.0);
  p.tolerance = 1e-10;
  p.maxIterations = 2000;
  ImplicitEuler chol(p);
  p.preconditioner = PreconditionerKind::TwoLevel;
  ImplicitEuler two(p);
  bool factored = false;
  for (int s = 0; s < 4; ++s) {
    const StepStatus sa = chol.step(a.model, a.octree);
    ASSERT_TRUE(sa.converged && two.step(b.model, b.octree).converged);
    factored = factored || sa.factorised;
  }
  ASSERT_TRUE(factored);
  chol.updateTopology(applyCut(a));
  two.updateTopology(applyCut(b));
  const StepStatus sa = chol.step(a.model, a.octree), sb = two.step(b.model, b.octree);
  ASSERT_TRUE(sa.converged && sb.converged);
  EXPECT_TRUE(sa.bridged);
  EXPECT_FALSE(sa.factorised);
  EXPECT_EQ(sa.preconditioner, PreconditionerKind::Cholesky);
  EXPECT_FALSE(sb.bridged);
  EXPECT_LT(2 * sa.iterations, sb.iterations);  // measured: 13 against 27
  double moved = 0, difference = 0;
  for (std::size_t n = 0; n < a.octree.nodeCount(); ++n) {
    moved = std::max(moved, (a.octree.positions()[n] - a.octree.restPositions()[n]).norm());
    difference = std::max(difference, (a.octree.positions()[n] - b.octree.positions()[n]).norm());
  }
  EXPECT_GT(moved, 0.0);
  EXPECT_LE(difference, 1e-8 * moved);
  // The next step factorises the new structure.
  const StepStatus next = chol.step(a.model, a.octree);
  EXPECT_TRUE(next.factorised);
  EXPECT_FALSE(next.bridged);
}

TEST(ImplicitEulerDynamics, AWornBridgeHandsCutStepsToTwoLevel) {
  // Two cuts with a step between and no factorisation: the second cut step is bridged again
  // unless the first took more than bridgeIterations iterations.
  for (const int limit : {1000, 0}) {
    CutBlock c = cutBlock();
    ImplicitEulerParams p;
    p.gravity = Vec3d(0.5, -9.81, 1.0);
    p.bridgeIterations = limit;
    ImplicitEuler solver(p);
    for (int s = 0; s < 3; ++s) ASSERT_TRUE(solver.step(c.model, c.octree).converged);
    solver.updateTopology(applyCut(c));
    const StepStatus first = solver.step(c.model, c.octree);
    ASSERT_TRUE(first.converged);
    ASSERT_TRUE(first.bridged);
    ASSERT_GT(first.iterations, 0);
    c.cut.clear();
    for (int z = 0; z < 8; ++z)
      for (int x = 5; x < 8; ++x) c.cut.push_back(VoxelGrid::linkId(c.grid.index(x, 14, z), 1));
    solver.updateTopology(applyCut(c));
    const StepStatus second = solver.step(c.model, c.octree);
    EXPECT_TRUE(second.converged);
    EXPECT_FALSE(second.factorised);
    EXPECT_EQ(second.bridged, limit > 0) << limit;
    EXPECT_EQ(second.preconditioner,
              limit > 0 ? PreconditionerKind::Cholesky : PreconditionerKind::TwoLevel);
  }
}

}  // namespace
}  // namespace voxcut
