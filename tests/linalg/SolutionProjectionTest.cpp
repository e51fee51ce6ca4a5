// The start projected onto earlier solutions (linalg/SolutionProjection.h): it reproduces a
// right-hand side's solution that lies in their span, its error is A-orthogonal to them
// otherwise, repeated solutions do no harm, the ring keeps the newest, and the result does not
// depend on the thread count.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/linalg/BlockMatrix.h"
#include "voxcut/linalg/SolutionProjection.h"

namespace voxcut {
namespace {

/// A symmetric positive definite block chain of n rows: diagonal blocks 4 I plus a small
/// symmetric part, neighbours coupled by -I (diagonally dominant).
BlockMatrix chain(std::size_t n) {
  BlockMatrix a;
  std::srand(3);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Matrix3d r = 0.2 * Eigen::Matrix3d::Random();
    const Eigen::Matrix3d sym = 0.5 * (r + r.transpose());
    if (i > 0) {
      a.column.push_back(static_cast<std::uint32_t>(i - 1));
      a.blocks.push_back(-Eigen::Matrix3d::Identity());
    }
    a.diagonal.push_back(static_cast<std::uint32_t>(a.column.size()));
    a.column.push_back(static_cast<std::uint32_t>(i));
    a.blocks.push_back(4.0 * Eigen::Matrix3d::Identity() + sym);
    if (i + 1 < n) {
      a.column.push_back(static_cast<std::uint32_t>(i + 1));
      a.blocks.push_back(-Eigen::Matrix3d::Identity());
    }
    a.rowStart.push_back(static_cast<std::uint32_t>(a.column.size()));
  }
  return a;
}

std::vector<Vec3d> randomVector(std::size_t n) {
  std::vector<Vec3d> v(n);
  for (Vec3d& x : v) x = Vec3d::Random();
  return v;
}

std::vector<Vec3d> times(const BlockMatrix& a, const std::vector<Vec3d>& x) {
  std::vector<Vec3d> y(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) y[i] = blockRowProduct(a.view(), x.data(), i);
  return y;
}

double distance(const std::vector<Vec3d>& x, const std::vector<Vec3d>& y) {
  double s = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) s += (x[i] - y[i]).squaredNorm();
  return std::sqrt(s);
}

TEST(SolutionProjection, ReproducesASolutionInTheSpan) {
  const std::size_t n = 300;  // more than one chunk of the sums
  const BlockMatrix a = chain(n);
  const auto x1 = randomVector(n), x2 = randomVector(n), x3 = randomVector(n);
  SolutionProjection p(4);
  std::vector<Vec3d> x;
  EXPECT_FALSE(p.project(a.view(), x1, x, false));  // nothing kept
  p.add(x1);
  p.add(x2);
  p.add(x3);
  std::vector<Vec3d> target(n);
  for (std::size_t i = 0; i < n; ++i) target[i] = 0.7 * x1[i] - 1.3 * x3[i];
  ASSERT_TRUE(p.project(a.view(), times(a, target), x, false));
  EXPECT_LE(distance(x, target), 1e-10 * distance(target, std::vector<Vec3d>(n, Vec3d::Zero())));
}

TEST(SolutionProjection, ErrorIsEnergyOrthogonalToTheKeptSolutions) {
  const std::size_t n = 300;
  const BlockMatrix a = chain(n);
  const auto x1 = randomVector(n), x2 = randomVector(n), b = randomVector(n);
  SolutionProjection p(3);
  p.add(x1);
  p.add(x2);
  std::vector<Vec3d> x;
  ASSERT_TRUE(p.project(a.view(), b, x, false));
  const std::vector<Vec3d> ax = times(a, x);
  for (const auto* w : {&x1, &x2}) {
    double residual = 0.0, scale = 0.0;  // w^T (b - A x) against w^T b
    for (std::size_t i = 0; i < n; ++i) {
      residual += (*w)[i].dot(b[i] - ax[i]);
      scale += std::abs((*w)[i].dot(b[i]));
    }
    EXPECT_LE(std::abs(residual), 1e-10 * scale);
  }
}

TEST(SolutionProjection, RepeatedSolutionsAndTheRing) {
  const std::size_t n = 40;
  const BlockMatrix a = chain(n);
  std::vector<std::vector<Vec3d>> xs;
  for (int k = 0; k < 5; ++k) xs.push_back(randomVector(n));
  SolutionProjection p(3);
  p.add(xs[0]);
  p.add(xs[0]);  // a repeated direction: the pseudo-inverse leaves it out
  std::vector<Vec3d> x;
  ASSERT_TRUE(p.project(a.view(), times(a, xs[0]), x, false));
  EXPECT_LE(distance(x, xs[0]), 1e-9);
  for (int k = 1; k < 5; ++k) p.add(xs[static_cast<std::size_t>(k)]);
  EXPECT_EQ(p.size(), 3u);
  // The newest three are kept: x4 is reproduced, x0 (forgotten) is not.
  ASSERT_TRUE(p.project(a.view(), times(a, xs[4]), x, false));
  EXPECT_LE(distance(x, xs[4]), 1e-9);
  ASSERT_TRUE(p.project(a.view(), times(a, xs[0]), x, false));
  EXPECT_GT(distance(x, xs[0]), 1e-3);
  // A smaller capacity keeps the newest.
  p.setCapacity(1);
  EXPECT_EQ(p.size(), 1u);
  ASSERT_TRUE(p.project(a.view(), times(a, xs[4]), x, false));
  EXPECT_LE(distance(x, xs[4]), 1e-9);
  // Another row count starts afresh.
  p.setCapacity(3);
  p.add(randomVector(n + 1));
  EXPECT_EQ(p.size(), 1u);
}

TEST(SolutionProjection, SameForAnyThreadCount) {
  const std::size_t n = 2000;
  const BlockMatrix a = chain(n);
  SolutionProjection p(6);
  for (int k = 0; k < 6; ++k) p.add(randomVector(n));
  const auto b = randomVector(n);
  std::vector<Vec3d> serial, threaded;
  SolutionProjection q = p;
  ASSERT_TRUE(p.project(a.view(), b, serial, false));
  {
    const ThreadLimit limit(2);
    ASSERT_TRUE(q.project(a.view(), b, threaded, true));
  }
  EXPECT_EQ(serial, threaded);
}

}  // namespace
}  // namespace voxcut
