#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <random>
#include <vector>

#include "../fem/FemBodies.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/linalg/BlockCholesky.h"
#include "voxcut/linalg/BlockPreconditioner.h"
#include "voxcut/linalg/BlockSparsity.h"

namespace voxcut {
namespace {

using test::flat;
using test::randomVector;

/// A symmetric block matrix on the node graph of `pieces` nx x ny x nz lattices (27-point
/// stencil) with no block between them, random blocks, made SPD by a dominant diagonal.
struct LatticeCase {
  BlockSparsity sp;
  std::vector<Eigen::Matrix3d> blocks;
  Eigen::MatrixXd a;  ///< dense copy
};

LatticeCase latticeCase(int nx, int ny, int nz, int pieces, unsigned seed) {
  LatticeCase c;
  const int perPiece = nx * ny * nz, rows = pieces * perPiece;
  auto id = [&](int p, int x, int y, int z) { return p * perPiece + x + nx * (y + ny * z); };
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * rows, 3 * rows);
  for (int p = 0; p < pieces; ++p)
    for (int z = 0; z < nz; ++z)
      for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x)
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) {
                const int X = x + dx, Y = y + dy, Z = z + dz;
                if (X < 0 || Y < 0 || Z < 0 || X >= nx || Y >= ny || Z >= nz) continue;
                const int i = id(p, x, y, z), k = id(p, X, Y, Z);
                if (k >= i) continue;
                Eigen::Matrix3d b;
                for (int r = 0; r < 3; ++r)
                  for (int s = 0; s < 3; ++s) b(r, s) = u(rng);
                a.block<3, 3>(3 * i, 3 * k) = b;
                a.block<3, 3>(3 * k, 3 * i) = b.transpose();
              }
  for (int i = 0; i < 3 * rows; ++i) a(i, i) = 30.0 + u(rng);
  c.a = a;
  c.sp.diagonal.resize(static_cast<std::size_t>(rows));
  for (int i = 0; i < rows; ++i) {
    for (int k = 0; k < rows; ++k) {
      if (i != k && a.block<3, 3>(3 * i, 3 * k).isZero(0.0)) continue;
      if (i == k)
        c.sp.diagonal[static_cast<std::size_t>(i)] = static_cast<std::uint32_t>(c.sp.column.size());
      c.sp.column.push_back(static_cast<std::uint32_t>(k));
      c.blocks.push_back(a.block<3, 3>(3 * i, 3 * k));
    }
    c.sp.rowStart.push_back(static_cast<std::uint32_t>(c.sp.column.size()));
  }
  c.sp.mirror = blockMirrors(c.sp);
  return c;
}

double relativeResidual(const Eigen::MatrixXd& a, const std::vector<Vec3d>& z,
                        const std::vector<Vec3d>& r) {
  return (a * flat(z) - flat(r)).norm() / flat(r).norm();
}

TEST(BlockCholesky, SolvesALatticeSystemExactly) {
  const LatticeCase c = latticeCase(5, 4, 3, 1, 3);
  BlockCholesky chol;
  chol.analyse(c.sp);
  ASSERT_TRUE(chol.factorise(c.sp, c.blocks));
  EXPECT_TRUE(chol.factorised());
  // The ordering is a permutation of the rows.
  std::vector<std::uint32_t> order = chol.ordering();
  std::sort(order.begin(), order.end());
  for (std::size_t i = 0; i < order.size(); ++i) EXPECT_EQ(order[i], i);
  // L holds at least the lower blocks of A (fill adds more).
  EXPECT_GE(chol.offDiagonalBlocks(), (c.sp.blockCount() - c.sp.diagonal.size()) / 2);
  const std::vector<Vec3d> r = randomVector(c.sp.diagonal.size(), 4);
  std::vector<Vec3d> z;
  chol.solve(r, z);
  EXPECT_LE(relativeResidual(c.a, z, r), 1e-13);
  // In place.
  std::vector<Vec3d> w = r;
  chol.solve(w, w);
  EXPECT_EQ(w, z);
}

TEST(BlockCholesky, ParallelFactorIsBitIdenticalAndExactOnTwoPieces) {
  // Big enough for the parallel plan (several subtrees, then the columns above them), two
  // disconnected pieces (two roots of the elimination tree).
  const LatticeCase c = latticeCase(9, 8, 7, 2, 5);
  BlockCholesky one, two;
  one.analyse(c.sp);
  two.analyse(c.sp);
  EXPECT_GT(one.updateCount(), 2e4);
  EXPECT_GT(one.taskCount(), 2u);
  {
    const ThreadLimit limit(1);
    ASSERT_TRUE(one.factorise(c.sp, c.blocks, false));
  }
  {
    const ThreadLimit limit(2);
    ASSERT_TRUE(two.factorise(c.sp, c.blocks, true));
  }
  const std::vector<Vec3d> r = randomVector(c.sp.diagonal.size(), 6);
  std::vector<Vec3d> z1, z2;
  one.solve(r, z1);
  two.solve(r, z2);
  EXPECT_EQ(z1, z2);
  EXPECT_LE(relativeResidual(c.a, z1, r), 1e-12);
  // Refactorising the same matrix gives the same factor (the workspaces were left clean).
  ASSERT_TRUE(two.factorise(c.sp, c.blocks, true));
  two.solve(r, z2);
  EXPECT_EQ(z1, z2);
}

TEST(BlockCholesky, ManyPiecesShareAFewTasks) {
  // 40 separate lattices (a body cut into many pieces): 40 roots, at most 16 tasks (one
  // workspace each), still bit-identical at 1 and 2 threads and exact.
  const LatticeCase c = latticeCase(3, 3, 3, 40, 12);
  BlockCholesky chol;
  chol.analyse(c.sp);
  EXPECT_GT(chol.updateCount(), 2e4);
  EXPECT_GT(chol.taskCount(), 1u);
  EXPECT_LE(chol.taskCount(), 16u);
  const std::vector<Vec3d> r = randomVector(c.sp.diagonal.size(), 13);
  std::vector<Vec3d> z1, z2;
  {
    const ThreadLimit limit(1);
    ASSERT_TRUE(chol.factorise(c.sp, c.blocks, false));
    chol.solve(r, z1);
  }
  {
    const ThreadLimit limit(2);
    ASSERT_TRUE(chol.factorise(c.sp, c.blocks, true));
    chol.solve(r, z2);
  }
  EXPECT_EQ(z1, z2);
  EXPECT_LE(relativeResidual(c.a, z1, r), 1e-12);
}

TEST(BlockCholesky, ANonPositivePivotIsReportedAndTheNextFactorIsClean) {
  LatticeCase c = latticeCase(9, 8, 7, 1, 8);
  std::vector<Eigen::Matrix3d> bad = c.blocks;
  bad[c.sp.diagonal[100]](1, 1) = -50.0;  // not SPD
  BlockCholesky chol;
  chol.analyse(c.sp);
  EXPECT_FALSE(chol.factorise(c.sp, bad));
  EXPECT_FALSE(chol.factorised());
  ASSERT_TRUE(chol.factorise(c.sp, c.blocks));
  const std::vector<Vec3d> r = randomVector(c.sp.diagonal.size(), 9);
  std::vector<Vec3d> z;
  chol.solve(r, z);
  EXPECT_LE(relativeResidual(c.a, z, r), 1e-12);
  // A NaN is not positive either.
  bad = c.blocks;
  bad[c.sp.diagonal[0]](0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(chol.factorise(c.sp, bad));
}

TEST(BlockCholesky, SolvesTheReducedSystemOfACompositeBody) {
  // The sparsity of a real body (hanging nodes, a fixed node): rest stiffness plus mass.
  const test::Body b = test::smallBodyWithAFixedNode();
  const BlockSparsity& sp = b.model.sparsity();
  const test::BlockSystem a = test::restBlockSystem(b.model);
  BlockCholesky chol;
  chol.analyse(sp);
  ASSERT_TRUE(chol.factorise(sp, a.blocks));
  const std::vector<Vec3d> r = randomVector(sp.diagonal.size(), 1);
  std::vector<Vec3d> z;
  chol.solve(r, z);
  EXPECT_LE(relativeResidual(a.dense, z, r), 1e-9);
}

}  // namespace
}  // namespace voxcut
