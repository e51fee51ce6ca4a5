#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "../fem/FemBodies.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/linalg/BlockPreconditioner.h"
#include "voxcut/linalg/TwoLevelPreconditioner.h"

namespace voxcut {
namespace {

using test::flat;
using test::randomVector;

/// A reduced system of the small composite body (hanging and fixed nodes): A = P^T K P
/// scaled, plus a mass-like diagonal, in the model's block layout.
struct MeshCase {
  test::Body body = test::smallBody(0.0, 0.0);
  Eigen::MatrixXd a;
  std::vector<Eigen::Matrix3d> blocks, inverse;
};

MeshCase meshCase() {
  MeshCase c;
  std::vector<std::uint8_t> fixed(c.body.octree.nodeCount(), 0);
  fixed.at(0) = 1;
  c.body.model.setFixed(fixed);
  const BlockSparsity& sp = c.body.model.sparsity();
  const Eigen::SparseMatrix<double> p = prolongationMatrix(c.body.model);
  c.a = Eigen::MatrixXd(p.transpose() * restStiffnessMatrix(c.body.model) * p) * 1e-5;
  for (Eigen::Index i = 0; i < c.a.rows(); ++i) c.a(i, i) += 1e-3;
  c.blocks.resize(sp.blockCount());
  for (std::size_t i = 0; i < sp.diagonal.size(); ++i)
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s)
      c.blocks[s] = c.a.block<3, 3>(3 * static_cast<Eigen::Index>(i), 3 * sp.column[s]);
  for (std::size_t i = 0; i < sp.diagonal.size(); ++i)
    c.inverse.push_back(c.blocks[sp.diagonal[i]].inverse());
  return c;
}

TEST(TwoLevelPreconditioner, AggregatesPartitionTheRowsIntoConnectedSets) {
  const MeshCase c = meshCase();
  const BlockSparsity& sp = c.body.model.sparsity();
  const NodeAggregation& agg = c.body.model.aggregation();
  const std::size_t rows = sp.diagonal.size();
  ASSERT_EQ(agg.aggregate.size(), rows);
  ASSERT_EQ(agg.member.size(), rows);
  EXPECT_GT(agg.count(), 1u);
  EXPECT_LT(agg.count(), rows / 4);  // 1-rings of a 27-point stencil: several rows each
  std::vector<int> seen(rows, 0);
  for (std::size_t g = 0; g < agg.count(); ++g) {
    ASSERT_LT(agg.start[g], agg.start[g + 1]) << "empty aggregate " << g;
    for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m) {
      const std::uint32_t i = agg.member[m];
      EXPECT_EQ(agg.aggregate[i], g);
      if (m > agg.start[g]) {
        EXPECT_LT(agg.member[m - 1], i);
      }
      ++seen[i];
    }
    // Connected through the sparsity's blocks, restricted to the aggregate.
    std::vector<std::uint32_t> reached{agg.member[agg.start[g]]};
    for (std::size_t k = 0; k < reached.size(); ++k)
      for (std::uint32_t s = sp.rowStart[reached[k]]; s < sp.rowStart[reached[k] + 1]; ++s)
        if (agg.aggregate[sp.column[s]] == g &&
            std::find(reached.begin(), reached.end(), sp.column[s]) == reached.end())
          reached.push_back(sp.column[s]);
    EXPECT_EQ(reached.size(), agg.start[g + 1] - agg.start[g]) << "aggregate " << g;
  }
  for (std::size_t i = 0; i < rows; ++i) EXPECT_EQ(seen[i], 1) << "row " << i;
  // Each slot's link entry names its column's aggregate, within the row's ascending list.
  for (std::size_t i = 0; i < rows; ++i) {
    for (std::uint32_t k = agg.linkStart[i] + 1; k < agg.linkStart[i + 1]; ++k)
      EXPECT_LT(agg.linkAggregate[k - 1], agg.linkAggregate[k]);
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s) {
      const std::uint32_t k = agg.slotLink[s];
      ASSERT_GE(k, agg.linkStart[i]);
      ASSERT_LT(k, agg.linkStart[i + 1]);
      EXPECT_EQ(agg.linkAggregate[k], agg.aggregate[sp.column[s]]);
    }
  }
}

TEST(TwoLevelPreconditioner, AggregatesNeverSpanTwoPieces) {
  // Two blocks of rows with no block between them: no aggregate holds rows of both.
  BlockSparsity sp;
  const int rows = 40;
  for (int i = 0; i < rows; ++i) {
    const int lo = i < 20 ? 0 : 20, hi = i < 20 ? 20 : rows;
    for (int j = std::max(lo, i - 3); j < std::min(hi, i + 4); ++j) {
      if (j == i) sp.diagonal.push_back(static_cast<std::uint32_t>(sp.column.size()));
      sp.column.push_back(static_cast<std::uint32_t>(j));
    }
    sp.rowStart.push_back(static_cast<std::uint32_t>(sp.column.size()));
  }
  const NodeAggregation agg = aggregateNodes(sp);
  for (std::size_t g = 0; g < agg.count(); ++g) {
    const bool first = agg.member[agg.start[g]] < 20;
    for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m)
      EXPECT_EQ(agg.member[m] < 20, first) << "aggregate " << g;
  }
}

/// The positions of the free nodes of `body` (reduced order), bent so they are not a grid.
std::vector<Vec3d> freePositions(const test::Body& body) {
  std::vector<Vec3d> x;
  for (std::uint32_t n : body.model.freeNodes()) {
    const Vec3d p = body.octree.restPositions()[n];
    x.push_back(p + 0.1 * Vec3d(std::sin(20 * p.y()), 0.0, std::cos(20 * p.x())) * 0.01);
  }
  return x;
}

/// T (3 #rows x #coarse) of the file comment, built directly from its definition.
Eigen::MatrixXd densePrologation(const NodeAggregation& agg, const std::vector<Vec3d>* x) {
  std::vector<Eigen::Index> start{0};
  std::vector<Vec3d> offset(agg.aggregate.size(), Vec3d::Zero());
  for (std::size_t g = 0; g < agg.count(); ++g) {
    const auto size = static_cast<double>(agg.start[g + 1] - agg.start[g]);
    bool rotations = false;
    if (x != nullptr && size >= 3) {
      Vec3d c = Vec3d::Zero();
      for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m) c += (*x)[agg.member[m]];
      c /= size;
      Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();
      for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m)
        moment += ((*x)[agg.member[m]] - c) * ((*x)[agg.member[m]] - c).transpose();
      const Vec3d l = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(moment).eigenvalues();
      rotations = l(1) > 1e-3 * l(2);
      const double radius = std::sqrt(moment.trace() / size);
      if (rotations)
        for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m)
          offset[agg.member[m]] = ((*x)[agg.member[m]] - c) / radius;
    }
    start.push_back(start.back() + (rotations ? 6 : 3));
  }
  const auto rows = static_cast<Eigen::Index>(3 * agg.aggregate.size());
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(rows, start.back());
  for (std::size_t i = 0; i < agg.aggregate.size(); ++i) {
    const Eigen::Index r = 3 * static_cast<Eigen::Index>(i), c = start[agg.aggregate[i]];
    t.block<3, 3>(r, c).setIdentity();
    if (start[agg.aggregate[i] + 1] - c == 6)
      for (int k = 0; k < 3; ++k)  // column: rotation about axis k, e_k x d_i
        t.block<3, 1>(r, c + 3 + k) = Vec3d::Unit(k).cross(offset[i]);
  }
  return t;
}

TEST(TwoLevelPreconditioner, ApplyIsTheSymmetricVCycle) {
  // z = u + (D + U)^-1 (r - A u) with u = (D + L)^-1 r + T A_c^-1 T^T (r - A (D + L)^-1 r),
  // built densely, with and without rotations; M^-1 symmetric positive definite; same bits
  // with and without threads.
  MeshCase c = meshCase();
  const BlockSparsity& sp = c.body.model.sparsity();
  const NodeAggregation& agg = c.body.model.aggregation();
  const std::vector<Vec3d> x = freePositions(c.body);
  const auto n = c.a.rows();
  Eigen::MatrixXd lower = Eigen::MatrixXd::Zero(n, n), upper = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j) {
      if (i / 3 >= j / 3) lower(i, j) = c.a(i, j);
      if (i / 3 <= j / 3) upper(i, j) = c.a(i, j);
    }
  const std::vector<Vec3d> r1 = randomVector(sp.diagonal.size(), 1),
                           r2 = randomVector(sp.diagonal.size(), 2);
  for (const std::vector<Vec3d>* positions :
       {static_cast<const std::vector<Vec3d>*>(nullptr), &x}) {
    SCOPED_TRACE(positions ? "rigid modes" : "translations");
    const Eigen::MatrixXd t = densePrologation(agg, positions);
    if (positions) {
      EXPECT_GT(t.cols(), static_cast<Eigen::Index>(5 * agg.count()));  // rotations, mostly
    }
    const Eigen::MatrixXd coarse = t.transpose() * c.a * t;
    const Eigen::VectorXd r = flat(r1);
    // Block triangular (full 3x3 diagonal blocks): solved densely.
    Eigen::VectorXd u = lower.partialPivLu().solve(r);
    u += t * coarse.llt().solve(t.transpose() * (r - c.a * u));
    const Eigen::VectorXd expected = u + upper.partialPivLu().solve(r - c.a * u);

    TwoLevelPreconditioner pre;
    EXPECT_EQ(pre.coarseFactorEntries(), 0.0);
    ASSERT_TRUE(pre.setup(sp, agg, c.blocks, positions, true));
    EXPECT_EQ(pre.coarseSize(), t.cols());
    // The factor's lower triangle: its diagonal at least, the dense triangle at most.
    const auto m = static_cast<double>(t.cols());
    EXPECT_GE(pre.coarseFactorEntries(), m);
    EXPECT_LE(pre.coarseFactorEntries(), 0.5 * m * (m + 1.0));
    std::vector<Vec3d> z1, z2, serial;
    pre.apply(sp, agg, c.blocks, c.inverse, r1, z1, true);
    EXPECT_LE((flat(z1) - expected).norm(), 1e-9 * expected.norm());
    pre.apply(sp, agg, c.blocks, c.inverse, r2, z2, true);
    const double lhs = flat(r2).dot(flat(z1)), rhs = flat(r1).dot(flat(z2));
    EXPECT_NEAR(lhs, rhs, 1e-10 * std::abs(lhs));
    EXPECT_GT(flat(r1).dot(flat(z1)), 0.0);
    {
      const ThreadLimit one(1);
      TwoLevelPreconditioner alone;
      ASSERT_TRUE(alone.setup(sp, agg, c.blocks, positions, false));
      alone.apply(sp, agg, c.blocks, c.inverse, r1, serial, false);
    }
    for (std::size_t i = 0; i < serial.size(); ++i) EXPECT_EQ(serial[i], z1[i]) << "row " << i;
  }
}

TEST(TwoLevelPreconditioner, CollinearAggregatesKeepTranslationsOnly) {
  // Every position on one line: no aggregate can rotate, the coarse space is translations.
  MeshCase c = meshCase();
  const BlockSparsity& sp = c.body.model.sparsity();
  const NodeAggregation& agg = c.body.model.aggregation();
  std::vector<Vec3d> line(sp.diagonal.size());
  for (std::size_t i = 0; i < line.size(); ++i)
    line[i] = Vec3d(0.001 * static_cast<double>(i), 0, 0);
  TwoLevelPreconditioner pre;
  ASSERT_TRUE(pre.setup(sp, agg, c.blocks, &line, true));
  EXPECT_EQ(pre.coarseSize(), static_cast<Eigen::Index>(3 * agg.count()));
}

TEST(TwoLevelPreconditioner, WithoutACoarseFactorItIsSymmetricGaussSeidel) {
  // An indefinite coarse matrix (A not SPD) is refused; apply then smooths only.
  MeshCase c = meshCase();
  const BlockSparsity& sp = c.body.model.sparsity();
  const NodeAggregation& agg = c.body.model.aggregation();
  std::vector<Eigen::Matrix3d> negative = c.blocks;
  for (Eigen::Matrix3d& b : negative) b = -b;
  TwoLevelPreconditioner pre;
  EXPECT_FALSE(pre.setup(sp, agg, negative, nullptr, true));
  const std::vector<Vec3d> r = randomVector(sp.diagonal.size(), 4);
  std::vector<Vec3d> z, sgs;
  pre.apply(sp, agg, c.blocks, c.inverse, r, z, true);
  applySymmetricGaussSeidel(sp, c.blocks, c.inverse, r, sgs);
  for (std::size_t i = 0; i < z.size(); ++i)
    EXPECT_LE((z[i] - sgs[i]).norm(), 1e-12 * sgs[i].norm() + 1e-300);
}

}  // namespace
}  // namespace voxcut
