// Couplings between pairs of sparse row combinations (linalg/RowCoupling.h): the product
// against the dense X = -sum_p (S_a C_p S_b^T + S_b C_p S_a^T), its symmetry, the terms as
// added, and the solvers that take X beside a block matrix A: the conjugate gradients on
// A + X (ConjugateGradients::setCoupling) and the projection onto earlier solutions
// (SolutionProjection::project with a coupling), each against a dense computation.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/linalg/BlockSparsity.h"
#include "voxcut/linalg/ConjugateGradients.h"
#include "voxcut/linalg/RowCoupling.h"
#include "voxcut/linalg/SolutionProjection.h"

#include "CouplingReference.h"

namespace voxcut {
namespace {

using test::flat;
using test::randomVector;
using test::selector;
using test::Term;
using test::unflat;

/// X = -sum_p (S_a C S_b^T + S_b C S_a^T), dense.
Eigen::MatrixXd denseCoupling(const std::vector<Term>& terms, std::size_t rows) {
  const auto n = static_cast<Eigen::Index>(3 * rows);
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, n);
  for (const Term& t : terms) {
    const Eigen::MatrixXd sa = selector(t.a, rows), sb = selector(t.b, rows);
    x -= sa * t.c * sb.transpose() + sb * t.c * sa.transpose();
  }
  return x;
}

RowCoupling couplingOf(const std::vector<Term>& terms) {
  RowCoupling coupling;
  for (const Term& t : terms) coupling.add(t.a, t.b, t.c);
  return coupling;
}

/// A random symmetric 3x3 (positive semi-definite when `definite`), entries of size `scale`.
Eigen::Matrix3d randomSymmetric(std::mt19937& rng, double scale, bool definite) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3d m;
  for (int k = 0; k < 9; ++k) m(k / 3, k % 3) = u(rng);
  return definite ? Eigen::Matrix3d(scale * m * m.transpose())
                  : Eigen::Matrix3d(0.5 * scale * (m + m.transpose()));
}

/// Random terms over `rows` rows: one to four entries a side, rows drawn freely (a row may
/// repeat within a side and appear on both sides), weights in [-1, 1].
std::vector<Term> randomTerms(std::size_t rows, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::uint32_t> row(0, static_cast<std::uint32_t>(rows - 1));
  std::uniform_int_distribution<int> entries(1, 4);
  std::uniform_real_distribution<double> weight(-1.0, 1.0);
  std::vector<Term> terms;
  for (int p = 0; p < count; ++p) {
    Term t;
    for (RowWeights* s : {&t.a, &t.b}) {
      const int m = entries(rng);
      for (int k = 0; k < m; ++k) s->push_back({row(rng), weight(rng)});
    }
    t.c = randomSymmetric(rng, 2.0, false);
    terms.push_back(t);
  }
  return terms;
}

/// Two disconnected block chains (rows [0, n1) and [n1, n1 + n2), each row coupled to the
/// next two in its chain) and the diagonal parts S_a C S_a^T + S_b C S_b^T of the terms added
/// into them: A, with A + X = A0 + sum_p (S_a - S_b) C_p (S_a - S_b)^T symmetric positive
/// definite for positive semi-definite C_p. The terms' sides must lie within two rows of one
/// chain, so that their diagonal parts fit the pattern.
struct CoupledSystem {
  BlockSparsity sp;
  std::vector<Eigen::Matrix3d> blocks;
  std::vector<Eigen::Matrix3d> diagonalInverse;  ///< of A's diagonal blocks
  std::vector<Term> terms;
  RowCoupling coupling;
  Eigen::MatrixXd a;  ///< A, dense
  Eigen::MatrixXd x;  ///< X, dense

  [[nodiscard]] std::size_t rows() const { return diagonalInverse.size(); }
  [[nodiscard]] BlockMatrixView view() const { return sp.view(blocks); }
};

CoupledSystem coupledSystem(int n1, int n2, const std::vector<Term>& terms) {
  CoupledSystem c;
  const int rows = n1 + n2;
  const auto chainOf = [&](int i) { return i < n1 ? 0 : 1; };
  c.a = Eigen::MatrixXd::Zero(3 * rows, 3 * rows);
  for (int i = 0; i < rows; ++i) {
    Eigen::Matrix3d d = Eigen::Matrix3d::Identity() * (8.0 + (i % 5));
    d(0, 1) = d(1, 0) = 0.5;
    c.a.block<3, 3>(3 * i, 3 * i) = d;
    for (int k = 1; k <= 2 && i + k < rows && chainOf(i + k) == chainOf(i); ++k) {
      Eigen::Matrix3d b = -Eigen::Matrix3d::Identity() / k;
      b(2, 0) = 0.25 * ((i + k) % 3);
      c.a.block<3, 3>(3 * i, 3 * (i + k)) = b;
      c.a.block<3, 3>(3 * (i + k), 3 * i) = b.transpose();
    }
  }
  const auto n = static_cast<std::size_t>(rows);
  for (const Term& t : terms) {
    const Eigen::MatrixXd sa = selector(t.a, n), sb = selector(t.b, n);
    c.a += sa * t.c * sa.transpose() + sb * t.c * sb.transpose();
  }
  // The blocks of A on the pattern; nothing may lie outside it.
  Eigen::MatrixXd rest = c.a;
  for (int i = 0; i < rows; ++i) {
    for (int k = std::max(0, i - 2); k <= std::min(rows - 1, i + 2); ++k) {
      if (chainOf(k) != chainOf(i)) continue;
      if (i == k) c.sp.diagonal.push_back(static_cast<std::uint32_t>(c.sp.column.size()));
      c.sp.column.push_back(static_cast<std::uint32_t>(k));
      c.blocks.push_back(c.a.block<3, 3>(3 * i, 3 * k));
      rest.block<3, 3>(3 * i, 3 * k).setZero();
    }
    c.sp.rowStart.push_back(static_cast<std::uint32_t>(c.sp.column.size()));
    c.diagonalInverse.push_back(c.a.block<3, 3>(3 * i, 3 * i).inverse());
  }
  c.sp.mirror = blockMirrors(c.sp);
  EXPECT_EQ(rest.norm(), 0.0) << "a term's diagonal part does not fit the pattern";
  c.terms = terms;
  c.coupling = couplingOf(terms);
  c.x = denseCoupling(terms, n);
  return c;
}

/// Terms over two chains of n1 and n2 rows (n1, n2 >= 40): interpolated points of one chain
/// against the other's (both ways), and two distant rows of the first chain, whose coupling
/// block lies far outside the pattern. C = k (n n^T) + small shear: positive definite and
/// stronger than A's diagonal, so that the coupling changes the solution well beyond the
/// tolerances.
std::vector<Term> chainTerms(int n1, unsigned seed) {
  std::mt19937 rng(seed);
  const auto u = static_cast<std::uint32_t>(n1);
  std::vector<Term> terms;
  terms.push_back({{{3, 0.2}, {4, 0.5}, {5, 0.3}},
                   {{u + 7, 0.6}, {u + 8, 0.4}},
                   randomSymmetric(rng, 30.0, true) + 2.0 * Eigen::Matrix3d::Identity()});
  terms.push_back({{{u + 30, 1.0}}, {{10, 0.5}, {11, 0.5}}, randomSymmetric(rng, 20.0, true)});
  terms.push_back({{{20, 1.0}}, {{36, 1.0}}, randomSymmetric(rng, 25.0, true)});
  return terms;
}

/// Block Jacobi on A's diagonal blocks, fused into the iterations (rowBlocks).
class RowWise final : public LinearPreconditioner {
 public:
  explicit RowWise(const std::vector<Eigen::Matrix3d>& inverse) : inverse_(inverse) {}
  bool setOperator(const BlockMatrixView&, bool) override { return true; }
  void apply(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) override {
    z.resize(r.size());
    for (std::size_t i = 0; i < r.size(); ++i) z[i] = inverse_[i] * r[i];
  }
  const Eigen::Matrix3d* rowBlocks() const override { return inverse_.data(); }

 private:
  const std::vector<Eigen::Matrix3d>& inverse_;
};

/// The same block Jacobi through setOperator and apply (no rowBlocks): the path of a
/// preconditioner that couples rows, which must be set up with A alone.
class Applied final : public LinearPreconditioner {
 public:
  Applied(const std::vector<Eigen::Matrix3d>& inverse, const Eigen::Matrix3d* blocks)
      : inverse_(inverse), blocks_(blocks) {}
  bool setOperator(const BlockMatrixView& a, bool) override {
    ++setups;
    EXPECT_EQ(a.blocks, blocks_);
    return true;
  }
  void apply(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) override {
    z.resize(r.size());
    for (std::size_t i = 0; i < r.size(); ++i) z[i] = inverse_[i] * r[i];
  }
  int setups = 0;

 private:
  const std::vector<Eigen::Matrix3d>& inverse_;
  const Eigen::Matrix3d* blocks_;
};

// y += X x against the dense X, from a nonzero y, for terms whose rows repeat within a side
// and across the two sides (the product must add every entry's share, not the last one's).
TEST(RowCoupling, MultiplyAddMatchesTheDenseMatrix) {
  const std::size_t rows = 17;
  const std::vector<Term> terms = randomTerms(rows, 25, 11);
  const RowCoupling coupling = couplingOf(terms);
  EXPECT_EQ(coupling.size(), terms.size());
  EXPECT_FALSE(coupling.empty());
  const Eigen::MatrixXd x = denseCoupling(terms, rows);
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const std::vector<Vec3d> in = randomVector(rows, seed), y0 = randomVector(rows, 100 + seed);
    std::vector<Vec3d> y = y0;
    coupling.multiplyAdd(in, y);
    const Eigen::VectorXd expected = flat(y0) + x * flat(in);
    const double scale = flat(y0).norm() + x.norm() * flat(in).norm();
    EXPECT_LE((flat(y) - expected).norm(), 1e-12 * scale) << "seed " << seed;
    // Sanity: the coupling is not negligible against y0.
    EXPECT_GT((x * flat(in)).norm(), 0.1 * flat(y0).norm());
  }
}

// X is symmetric: x^T X y = y^T X x for any x, y, and the dense X equals its transpose (the
// two halves of each term mirror each other).
TEST(RowCoupling, ProductIsSymmetric) {
  const std::size_t rows = 23;
  const std::vector<Term> terms = randomTerms(rows, 30, 12);
  const RowCoupling coupling = couplingOf(terms);
  const std::vector<Vec3d> u = randomVector(rows, 5), v = randomVector(rows, 6);
  std::vector<Vec3d> xu(rows, Vec3d::Zero()), xv(rows, Vec3d::Zero());
  coupling.multiplyAdd(u, xu);
  coupling.multiplyAdd(v, xv);
  const double vxu = flat(v).dot(flat(xu)), uxv = flat(u).dot(flat(xv));
  const double scale = flat(u).norm() * flat(xv).norm() + flat(v).norm() * flat(xu).norm();
  EXPECT_GT(std::abs(vxu), 1e-3 * scale);  // not trivially zero
  EXPECT_LE(std::abs(vxu - uxv), 1e-12 * scale);
  // Column by column: X e_j through the product is the dense X's column j, and X = X^T.
  const Eigen::MatrixXd dense = denseCoupling(terms, rows);
  Eigen::MatrixXd fromProducts(dense.rows(), dense.cols());
  for (Eigen::Index j = 0; j < dense.cols(); ++j) {
    Eigen::VectorXd e = Eigen::VectorXd::Zero(dense.rows());
    e[j] = 1.0;
    std::vector<Vec3d> y(rows, Vec3d::Zero());
    coupling.multiplyAdd(unflat(e), y);
    fromProducts.col(j) = flat(y);
  }
  EXPECT_LE((fromProducts - dense).norm(), 1e-12 * dense.norm());
  EXPECT_LE((fromProducts - fromProducts.transpose()).norm(), 1e-12 * dense.norm());
}

// forEachTerm hands back every term's two sides and matrix as added, in order; clear()
// forgets them and the coupling takes new terms afterwards.
TEST(RowCoupling, TermsAsAddedAndClear) {
  const std::vector<Term> terms = randomTerms(9, 4, 13);
  RowCoupling coupling = couplingOf(terms);
  std::size_t p = 0;
  coupling.forEachTerm([&](const auto* a0, const auto* a1, const auto* b0, const auto* b1,
                           const Eigen::Matrix3d& c) {
    ASSERT_LT(p, terms.size());
    EXPECT_EQ(RowWeights(a0, a1), terms[p].a) << "term " << p;
    EXPECT_EQ(RowWeights(b0, b1), terms[p].b) << "term " << p;
    EXPECT_EQ(c, terms[p].c) << "term " << p;
    ++p;
  });
  EXPECT_EQ(p, terms.size());
  coupling.clear();
  EXPECT_TRUE(coupling.empty());
  EXPECT_EQ(coupling.size(), 0u);
  std::vector<Vec3d> y(9, Vec3d::Ones());
  coupling.multiplyAdd(randomVector(9, 1), y);
  for (const Vec3d& v : y) EXPECT_EQ(v, Vec3d::Ones());
  // Terms added after a clear: only they count.
  const std::vector<Term> later = randomTerms(9, 3, 14);
  for (const Term& t : later) coupling.add(t.a, t.b, t.c);
  const std::vector<Vec3d> in = randomVector(9, 2);
  std::vector<Vec3d> out(9, Vec3d::Zero());
  coupling.multiplyAdd(in, out);
  const Eigen::VectorXd expected = denseCoupling(later, 9) * flat(in);
  EXPECT_LE((flat(out) - expected).norm(), 1e-12 * expected.norm());
}

// The conjugate gradients on A + X, with X joining two chains that A leaves independent,
// reach the dense solution of (A + X) x = b with either preconditioner path; the
// preconditioner is set up with A alone. Without the coupling the solution is another one
// (the coupling matters at these tolerances).
TEST(RowCoupling, ConjugateGradientsSolveTheCoupledSystem) {
  const int n1 = 60, n2 = 50;
  const CoupledSystem c = coupledSystem(n1, n2, chainTerms(n1, 21));
  const std::size_t rows = c.rows();
  const Eigen::MatrixXd ax = c.a + c.x;
  ASSERT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(ax).eigenvalues().minCoeff(), 0.0);
  const std::vector<Vec3d> b = randomVector(rows, 3);
  const Eigen::VectorXd exact = ax.ldlt().solve(flat(b));
  const Eigen::VectorXd uncoupled = c.a.ldlt().solve(flat(b));
  ASSERT_GT((exact - uncoupled).norm(), 1e-2 * exact.norm());

  RowWise rowWise(c.diagonalInverse);
  Applied applied(c.diagonalInverse, c.blocks.data());
  for (LinearPreconditioner* m : {static_cast<LinearPreconditioner*>(&rowWise),
                                  static_cast<LinearPreconditioner*>(&applied)}) {
    ConjugateGradients cg;
    cg.setOperator(c.view(), false);
    cg.setCoupling(&c.coupling);
    cg.setPreconditioner(*m);
    cg.setParams({1e-12, 1000});
    std::vector<Vec3d> x(rows, Vec3d::Zero());
    const ConjugateGradientStatus s = cg.mult(b, x);
    EXPECT_TRUE(s.converged && s.finite && s.preconditioned);
    EXPECT_GT(s.iterations, 0);
    EXPECT_LE((flat(x) - exact).norm(), 1e-9 * exact.norm());
    // The residual that the status reports is that of A + X.
    EXPECT_LE((flat(b) - ax * flat(x)).norm(), 2e-12 * flat(b).norm());
  }
  EXPECT_EQ(applied.setups, 1);
  // An empty coupling is no coupling: the solution of A alone.
  const RowCoupling none;
  ConjugateGradients cg;
  cg.setOperator(c.view(), false);
  cg.setCoupling(&none);
  cg.setPreconditioner(rowWise);
  cg.setParams({1e-12, 1000});
  std::vector<Vec3d> x(rows, Vec3d::Zero());
  EXPECT_TRUE(cg.mult(b, x).converged);
  EXPECT_LE((flat(x) - uncoupled).norm(), 1e-9 * uncoupled.norm());
}

// mult() starts from the residual b - (A + X) x of a nonzero start: with no iteration allowed
// the status reports exactly that residual; the exact solution of A + X as start has
// converged already; and a random start reaches the dense solution.
TEST(RowCoupling, ConjugateGradientsStartFromTheCoupledResidual) {
  const int n1 = 45, n2 = 40;
  const CoupledSystem c = coupledSystem(n1, n2, chainTerms(n1, 22));
  const std::size_t rows = c.rows();
  const Eigen::MatrixXd ax = c.a + c.x;
  const std::vector<Vec3d> b = randomVector(rows, 4);
  const Eigen::VectorXd exact = ax.ldlt().solve(flat(b));
  RowWise rowWise(c.diagonalInverse);
  ConjugateGradients cg;
  cg.setOperator(c.view(), false);
  cg.setCoupling(&c.coupling);
  cg.setPreconditioner(rowWise);

  const std::vector<Vec3d> start = randomVector(rows, 5);
  cg.setParams({1e-12, 0});
  std::vector<Vec3d> x = start;
  ConjugateGradientStatus s = cg.mult(b, x);
  EXPECT_EQ(s.iterations, 0);
  EXPECT_EQ(x, start);
  const double expected = (flat(b) - ax * flat(start)).norm() / flat(b).norm();
  const double withoutX = (flat(b) - c.a * flat(start)).norm() / flat(b).norm();
  ASSERT_GT(std::abs(expected - withoutX), 1e-3 * expected);  // the two residuals differ
  EXPECT_NEAR(s.residual, expected, 1e-12 * expected);

  cg.setParams({1e-9, 1000});
  x = unflat(exact);
  s = cg.mult(b, x);
  EXPECT_TRUE(s.converged);
  EXPECT_EQ(s.iterations, 0);

  cg.setParams({1e-12, 1000});
  x = start;
  s = cg.mult(b, x);
  EXPECT_TRUE(s.converged);
  EXPECT_LE((flat(x) - exact).norm(), 1e-9 * exact.norm());
}

// The coupled solve gives the same bits at one and two threads (the coupling's product runs
// on one thread, in term order; the rest in fixed chunks): more rows than one chunk.
TEST(RowCoupling, ConjugateGradientsSameBitsAtOneAndTwoThreads) {
  const int n1 = 200, n2 = 150;  // 350 rows: two chunks
  const CoupledSystem c = coupledSystem(n1, n2, chainTerms(n1, 23));
  const std::vector<Vec3d> b = randomVector(c.rows(), 6);
  std::vector<std::vector<Vec3d>> solutions;
  for (int threads : {1, 2}) {
    const ThreadLimit limit(threads);
    RowWise rowWise(c.diagonalInverse);
    ConjugateGradients cg;
    cg.setOperator(c.view(), true);
    cg.setCoupling(&c.coupling);
    cg.setPreconditioner(rowWise);
    cg.setParams({1e-10, 1000});
    std::vector<Vec3d> x = randomVector(c.rows(), 7);
    EXPECT_TRUE(cg.mult(b, x).converged);
    solutions.push_back(x);
  }
  EXPECT_EQ(solutions[0], solutions[1]);
}

// The projection onto two kept solutions W with the coupling solves the Galerkin problem of
// A + X: x = W (W^T (A + X) W)^-1 W^T b, against the dense computation; it reproduces a
// solution of A + X in the span; without the coupling it is A's Galerkin solution instead.
TEST(RowCoupling, SolutionProjectionIsTheCoupledGalerkinSolution) {
  const int n1 = 160, n2 = 140;  // more than one chunk of the sums
  const CoupledSystem c = coupledSystem(n1, n2, chainTerms(n1, 24));
  const std::size_t rows = c.rows();
  const Eigen::MatrixXd ax = c.a + c.x;
  const std::vector<Vec3d> w1 = randomVector(rows, 8), w2 = randomVector(rows, 9);
  const std::vector<Vec3d> b = randomVector(rows, 10);
  Eigen::MatrixXd w(static_cast<Eigen::Index>(3 * rows), 2);
  w.col(0) = flat(w1);
  w.col(1) = flat(w2);
  const auto galerkin = [&](const Eigen::MatrixXd& m) {
    const Eigen::Matrix2d g = w.transpose() * m * w;
    return Eigen::VectorXd(w * g.ldlt().solve(w.transpose() * flat(b)));
  };
  const Eigen::VectorXd expected = galerkin(ax), plain = galerkin(c.a);
  ASSERT_GT((expected - plain).norm(), 1e-3 * expected.norm());

  SolutionProjection p(2);
  p.add(w1);
  p.add(w2);
  std::vector<Vec3d> x;
  ASSERT_TRUE(p.project(c.view(), b, x, false, &c.coupling));
  EXPECT_LE((flat(x) - expected).norm(), 1e-10 * expected.norm());
  // Its error is (A + X)-orthogonal to the kept solutions.
  const Eigen::Vector2d orthogonal = w.transpose() * (flat(b) - ax * flat(x));
  EXPECT_LE(orthogonal.norm(), 1e-10 * (w.transpose() * flat(b)).norm());
  ASSERT_TRUE(p.project(c.view(), b, x, false, nullptr));
  EXPECT_LE((flat(x) - plain).norm(), 1e-10 * plain.norm());
  // A solution of A + X in the span comes back.
  const Eigen::VectorXd target = 0.7 * flat(w1) - 1.3 * flat(w2);
  ASSERT_TRUE(p.project(c.view(), unflat(ax * target), x, false, &c.coupling));
  EXPECT_LE((flat(x) - target).norm(), 1e-10 * target.norm());
}

}  // namespace
}  // namespace voxcut
