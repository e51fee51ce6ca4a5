#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <vector>

#include "../fem/FemBodies.h"
#include "voxcut/linalg/BlockPreconditioner.h"
#include "voxcut/linalg/BlockSparsity.h"

namespace voxcut {
namespace {

/// A dense pattern of `rows` block rows (every block present) and a random SPD matrix on it.
struct DenseCase {
  BlockSparsity sp;
  std::vector<Eigen::Matrix3d> blocks;
  Eigen::MatrixXd a;
};

DenseCase denseCase(int rows, unsigned seed) {
  DenseCase c;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const int n = 3 * rows;
  Eigen::MatrixXd g(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) g(i, j) = u(rng);
  c.a = g * g.transpose() + n * Eigen::MatrixXd::Identity(n, n);
  c.sp.diagonal.resize(static_cast<std::size_t>(rows));
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < rows; ++j) {
      if (i == j)
        c.sp.diagonal[static_cast<std::size_t>(i)] = static_cast<std::uint32_t>(c.sp.column.size());
      c.sp.column.push_back(static_cast<std::uint32_t>(j));
      c.blocks.push_back(c.a.block<3, 3>(3 * i, 3 * j));
    }
    c.sp.rowStart.push_back(static_cast<std::uint32_t>(c.sp.column.size()));
  }
  c.sp.mirror = blockMirrors(c.sp);
  return c;
}

using test::flat;
using test::randomVector;

TEST(BlockPreconditioner, IncompleteCholeskyOfAFullPatternIsExact) {
  // With every block in the pattern nothing is dropped: IC(0) is the exact block LDL^T.
  const DenseCase c = denseCase(5, 7);
  const IncompleteCholeskyPattern pattern = incompleteCholeskyPattern(c.sp);
  EXPECT_EQ(pattern.pairCount(), 10u);  // slot (i, k) has k pairs: 0 + 1 + 3 + 6
  IncompleteCholeskyFactor factor;
  factorIncompleteCholesky(c.sp, pattern, c.blocks, factor);
  EXPECT_EQ(factor.replacedPivots, 0u);
  const std::vector<Vec3d> r = randomVector(5, 3);
  std::vector<Vec3d> z;
  applyIncompleteCholesky(c.sp, factor, r, z);
  EXPECT_LE((c.a * flat(z) - flat(r)).norm(), 1e-12 * flat(r).norm());
  // Mirrors pair (i, k) with (k, i).
  for (std::size_t s = 0; s < c.sp.blockCount(); ++s) EXPECT_EQ(c.sp.mirror[c.sp.mirror[s]], s);
}

TEST(BlockPreconditioner, SymmetricGaussSeidelMatchesItsDefinition) {
  const DenseCase c = denseCase(4, 11);
  std::vector<Eigen::Matrix3d> inverse;
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(12, 12), l = Eigen::MatrixXd::Zero(12, 12);
  for (int i = 0; i < 4; ++i) {
    inverse.push_back(c.a.block<3, 3>(3 * i, 3 * i).inverse());
    d.block<3, 3>(3 * i, 3 * i) = c.a.block<3, 3>(3 * i, 3 * i);
    for (int k = 0; k < i; ++k) l.block<3, 3>(3 * i, 3 * k) = c.a.block<3, 3>(3 * i, 3 * k);
  }
  const Eigen::MatrixXd m = (d + l) * d.inverse() * (d + l.transpose());
  const std::vector<Vec3d> r = randomVector(4, 5);
  std::vector<Vec3d> z;
  applySymmetricGaussSeidel(c.sp, c.blocks, inverse, r, z);
  EXPECT_LE((m * flat(z) - flat(r)).norm(), 1e-12 * flat(r).norm());
}

TEST(BlockPreconditioner, IncompleteCholeskyOnAMeshMatchesThePatternAndIsSymmetric) {
  // On a real sparsity (hanging nodes, fixed nodes) with a rest stiffness plus mass: M agrees
  // with A on the pattern's diagonal blocks (IC(0)'s defining property) and M^-1 is symmetric.
  const test::Body b = test::smallBodyWithAFixedNode();
  const BlockSparsity& sp = b.model.sparsity();
  const test::BlockSystem system = test::restBlockSystem(b.model);
  const Eigen::MatrixXd& a = system.dense;
  const std::vector<Eigen::Matrix3d>& blocks = system.blocks;
  IncompleteCholeskyFactor factor;
  factorIncompleteCholesky(sp, incompleteCholeskyPattern(sp), blocks, factor);
  const std::size_t rows = sp.diagonal.size();
  const std::vector<Vec3d> r1 = randomVector(rows, 1), r2 = randomVector(rows, 2);
  std::vector<Vec3d> z1, z2;
  applyIncompleteCholesky(sp, factor, r1, z1);
  applyIncompleteCholesky(sp, factor, r2, z2);
  const double lhs = flat(r2).dot(flat(z1)), rhs = flat(r1).dot(flat(z2));
  EXPECT_NEAR(lhs, rhs, 1e-12 * std::abs(lhs));
  EXPECT_GT(flat(r1).dot(flat(z1)), 0.0);
  // Rebuild M = (I + L) D (I + L^T) densely and compare its diagonal blocks with A's.
  const auto n = static_cast<Eigen::Index>(3 * rows);
  Eigen::MatrixXd unitL = Eigen::MatrixXd::Identity(n, n), dd = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t i = 0; i < rows; ++i) {
    const auto ii = 3 * static_cast<Eigen::Index>(i);
    dd.block<3, 3>(ii, ii) = factor.pivotInverse[i].inverse();
    for (std::uint32_t s = sp.rowStart[i]; s < sp.diagonal[i]; ++s)
      unitL.block<3, 3>(ii, 3 * sp.column[s]) = factor.lower[s];
  }
  const Eigen::MatrixXd m = unitL * dd * unitL.transpose();
  double worst = 0.0;
  if (factor.replacedPivots == 0)
    for (std::size_t i = 0; i < rows; ++i)
      for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s) {
        const auto ii = 3 * static_cast<Eigen::Index>(i),
                   kk = 3 * static_cast<Eigen::Index>(sp.column[s]);
        worst =
            std::max(worst, (m.block<3, 3>(ii, kk) - a.block<3, 3>(ii, kk)).cwiseAbs().maxCoeff());
      }
  EXPECT_EQ(factor.replacedPivots, 0u);
  EXPECT_LE(worst, 1e-10 * a.cwiseAbs().maxCoeff());
}

}  // namespace
}  // namespace voxcut
