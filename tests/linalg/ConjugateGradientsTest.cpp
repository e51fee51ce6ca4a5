// The preconditioned conjugate gradients (linalg/ConjugateGradients.h): solutions against a
// dense solve with a row-wise and a coupled preconditioner, the preconditioner set up only
// when an iteration is needed, a failed set-up and a singular system as statuses, and the
// same bits at any thread count.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <limits>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/linalg/BlockPreconditioner.h"
#include "voxcut/linalg/BlockSparsity.h"
#include "voxcut/linalg/ConjugateGradients.h"
#include "voxcut/linalg/Multigrid.h"

namespace voxcut {
namespace {

/// A symmetric positive definite block matrix on a chain of `rows` nodes (each coupled to
/// the next two), its dense copy, and the inverses of its diagonal blocks.
struct ChainSystem {
  BlockSparsity sp;
  std::vector<Eigen::Matrix3d> blocks;
  std::vector<Eigen::Matrix3d> diagonalInverse;
  Eigen::MatrixXd dense;
};

ChainSystem chainSystem(int rows) {
  ChainSystem c;
  const int n = 3 * rows;
  c.dense = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < rows; ++i) {
    Eigen::Matrix3d d = Eigen::Matrix3d::Identity() * (8.0 + (i % 5));
    d(0, 1) = d(1, 0) = 0.5;
    c.dense.block<3, 3>(3 * i, 3 * i) = d;
    for (int k = 1; k <= 2 && i + k < rows; ++k) {
      Eigen::Matrix3d b = -Eigen::Matrix3d::Identity() / k;
      b(2, 0) = 0.25 * ((i + k) % 3);
      c.dense.block<3, 3>(3 * i, 3 * (i + k)) = b;
      c.dense.block<3, 3>(3 * (i + k), 3 * i) = b.transpose();
    }
  }
  for (int i = 0; i < rows; ++i) {
    for (int k = std::max(0, i - 2); k <= std::min(rows - 1, i + 2); ++k) {
      if (i == k) c.sp.diagonal.push_back(static_cast<std::uint32_t>(c.sp.column.size()));
      c.sp.column.push_back(static_cast<std::uint32_t>(k));
      c.blocks.push_back(c.dense.block<3, 3>(3 * i, 3 * k));
    }
    c.sp.rowStart.push_back(static_cast<std::uint32_t>(c.sp.column.size()));
    c.diagonalInverse.push_back(c.dense.block<3, 3>(3 * i, 3 * i).inverse());
  }
  c.sp.mirror = blockMirrors(c.sp);
  return c;
}

std::vector<Vec3d> rightHandSide(std::size_t rows) {
  std::vector<Vec3d> b(rows);
  for (std::size_t i = 0; i < rows; ++i)
    b[i] = Vec3d(1.0 + static_cast<double>(i % 4), -0.5 * static_cast<double>(i % 3), 0.25);
  return b;
}

Eigen::VectorXd flat(const std::vector<Vec3d>& v) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(3 * v.size()));
  for (std::size_t i = 0; i < v.size(); ++i)
    out.segment<3>(3 * static_cast<Eigen::Index>(i)) = v[i];
  return out;
}

/// Block Jacobi: row by row, fused into the iterations.
class RowWise final : public LinearPreconditioner {
 public:
  explicit RowWise(const std::vector<Eigen::Matrix3d>& inverse) : inverse_(inverse) {}
  bool setOperator(const BlockMatrixView&, bool) override { return ++setups, true; }
  void apply(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) override {
    ++applications;
    z.resize(r.size());
    for (std::size_t i = 0; i < r.size(); ++i) z[i] = inverse_[i] * r[i];
  }
  const Eigen::Matrix3d* rowBlocks() const override { return inverse_.data(); }
  int setups = 0, applications = 0;

 private:
  const std::vector<Eigen::Matrix3d>& inverse_;
};

/// Symmetric block Gauss-Seidel (BlockPreconditioner.h): couples rows.
class Coupled final : public LinearPreconditioner {
 public:
  Coupled(const ChainSystem& c, bool succeeds) : c_(c), succeeds_(succeeds) {}
  bool setOperator(const BlockMatrixView& a, bool) override {
    ++setups;
    EXPECT_EQ(a.blocks, c_.blocks.data());
    return succeeds_;
  }
  void apply(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) override {
    ++applications;
    applySymmetricGaussSeidel(c_.sp, c_.blocks, c_.diagonalInverse, r, z);
  }
  int setups = 0, applications = 0;

 private:
  const ChainSystem& c_;
  bool succeeds_;
};

TEST(ConjugateGradients, SolvesAsADenseSolveDoesWithEitherKindOfPreconditioner) {
  const ChainSystem c = chainSystem(300);
  const std::vector<Vec3d> b = rightHandSide(300);
  const Eigen::VectorXd exact = c.dense.ldlt().solve(flat(b));
  RowWise rowWise(c.diagonalInverse);
  Coupled coupled(c, true);
  for (LinearPreconditioner* m : {static_cast<LinearPreconditioner*>(&rowWise),
                                  static_cast<LinearPreconditioner*>(&coupled)}) {
    ConjugateGradients cg;
    cg.setOperator(c.sp.view(c.blocks), true);
    cg.setPreconditioner(*m);
    cg.setParams({1e-10, 500});
    std::vector<Vec3d> x(300, Vec3d::Zero());
    const ConjugateGradientStatus s = cg.mult(b, x);
    EXPECT_TRUE(s.converged && s.finite && s.preconditioned);
    EXPECT_GT(s.iterations, 0);
    EXPECT_LE(s.residual, 1e-10);
    EXPECT_LT((flat(x) - exact).norm(), 1e-8 * exact.norm());
  }
  // The row-wise blocks are fused into the updates: never set up nor applied on their own.
  EXPECT_EQ(rowWise.setups, 0);
  EXPECT_EQ(rowWise.applications, 0);
  EXPECT_EQ(coupled.setups, 1);
  EXPECT_GT(coupled.applications, 1);
}

TEST(ConjugateGradients, AConvergedStartSetsNothingUp) {
  const ChainSystem c = chainSystem(50);
  const std::vector<Vec3d> b = rightHandSide(50);
  const Eigen::VectorXd exact = c.dense.ldlt().solve(flat(b));
  std::vector<Vec3d> x(50);
  for (std::size_t i = 0; i < x.size(); ++i)
    x[i] = exact.segment<3>(3 * static_cast<Eigen::Index>(i));
  Coupled coupled(c, true);
  ConjugateGradients cg;
  cg.setOperator(c.sp.view(c.blocks), false);
  cg.setPreconditioner(coupled);
  const ConjugateGradientStatus s = cg.mult(b, x);
  EXPECT_TRUE(s.converged);
  EXPECT_EQ(s.iterations, 0);
  EXPECT_EQ(coupled.setups, 0);
  EXPECT_EQ(coupled.applications, 0);
}

TEST(ConjugateGradients, FailuresAreStatuses) {
  const ChainSystem c = chainSystem(50);
  const std::vector<Vec3d> b = rightHandSide(50);
  ConjugateGradients cg;
  cg.setOperator(c.sp.view(c.blocks), false);
  // A preconditioner that cannot be made: no iteration, the start kept.
  Coupled failing(c, false);
  cg.setPreconditioner(failing);
  std::vector<Vec3d> x(50, Vec3d::Zero());
  ConjugateGradientStatus s = cg.mult(b, x);
  EXPECT_FALSE(s.preconditioned);
  EXPECT_FALSE(s.converged);
  EXPECT_EQ(s.iterations, 0);
  EXPECT_EQ(failing.applications, 0);
  for (const Vec3d& v : x) EXPECT_EQ(v, Vec3d::Zero());
  // A non-finite right-hand side.
  Coupled coupled(c, true);
  cg.setPreconditioner(coupled);
  std::vector<Vec3d> bad = b;
  bad[7].x() = std::numeric_limits<double>::quiet_NaN();
  s = cg.mult(bad, x);
  EXPECT_FALSE(s.finite);
  EXPECT_FALSE(s.converged);
  // b = 0: x = 0 at once.
  x.assign(50, Vec3d::Ones());
  s = cg.mult(std::vector<Vec3d>(50, Vec3d::Zero()), x);
  EXPECT_TRUE(s.converged);
  for (const Vec3d& v : x) EXPECT_EQ(v, Vec3d::Zero());
}

TEST(ConjugateGradients, MultigridThroughTheInterfaceIsBitIdenticalAtOneAndTwoThreads) {
  // A chain of 2000 rows along x, and a coarsest level of at most 200 rows, so that the
  // multigrid has coarse levels (a chain's factor has no fill: it could be the coarsest).
  const std::size_t rows = 2000;
  const ChainSystem c = chainSystem(static_cast<int>(rows));
  std::vector<Index3> coords(rows);
  for (std::size_t i = 0; i < rows; ++i) coords[i] = Index3{static_cast<int>(i), 0, 0};
  const std::vector<Vec3d> b = rightHandSide(rows);
  std::vector<std::vector<Vec3d>> solutions;
  for (int threads : {1, 2}) {
    const ThreadLimit limit(threads);
    const BlockMatrixView a = c.sp.view(c.blocks);
    Multigrid multigrid;
    MultigridParams params;
    params.coarsestRows = 200;
    multigrid.build(a, coords, params, true);
    ConjugateGradients cg;
    cg.setOperator(a, true);
    cg.setPreconditioner(multigrid);
    cg.setParams({1e-8, 200});
    std::vector<Vec3d> x(rows, Vec3d::Zero());
    const ConjugateGradientStatus s = cg.mult(b, x);
    EXPECT_TRUE(s.converged);
    EXPECT_GT(multigrid.levelCount(), 1u);
    solutions.push_back(x);
  }
  for (std::size_t i = 0; i < rows; ++i) ASSERT_EQ(solutions[0][i], solutions[1][i]) << i;
}

}  // namespace
}  // namespace voxcut
