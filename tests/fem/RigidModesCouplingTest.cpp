// The rigid-mode correction with a coupling (fem/RigidModes.h, setOperator(az, coupling)):
// the step's matrix is A + X (linalg/RowCoupling.h) while the products az are A's alone.
// After correct(x, r) from r = b - (A + X) x, r must still be b - (A + X) x for the new x and
// be orthogonal to every piece's six modes; x must move by the dense Galerkin correction over
// the modes of all pieces a coupling joins. Cases: one term joining two pieces, terms within
// one piece, and three pieces of which two are joined.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "voxcut/fem/RigidModes.h"
#include "voxcut/linalg/BlockSparsity.h"
#include "voxcut/linalg/RowCoupling.h"

#include "../linalg/CouplingReference.h"

namespace voxcut {
namespace {

using test::flat;
using test::randomVector;
using test::selector;
using test::Term;
using test::unflat;

/// A positive semi-definite 3x3: k (n n^T) along a random normal plus a smaller shear part,
/// the shape of a contact spring.
Eigen::Matrix3d springMatrix(std::mt19937& rng, double k) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Vec3d n = Vec3d(u(rng), u(rng), u(rng)).normalized();
  return k * n * n.transpose() + 0.1 * k * (Eigen::Matrix3d::Identity() - n * n.transpose());
}

/// Pieces of the given sizes, each a block chain (rows coupled to the next two of the same
/// piece), with random positions and masses; A symmetric positive definite on each piece plus
/// the terms' diagonal parts S_a C S_a^T + S_b C S_b^T; X the terms' off-diagonal part, dense
/// and as a RowCoupling. Each side of a term must lie within two rows of one piece.
struct Pieces {
  BlockSparsity sp;
  std::vector<Eigen::Matrix3d> blocks;
  std::vector<std::size_t> pieceOf;
  std::vector<Vec3d> positions;
  std::vector<double> weights;
  RowCoupling coupling;
  Eigen::MatrixXd a, x;  ///< dense A and X

  [[nodiscard]] std::size_t rows() const { return pieceOf.size(); }
};

Pieces pieces(const std::vector<int>& sizes, const std::vector<Term>& terms, unsigned seed) {
  Pieces p;
  for (std::size_t k = 0; k < sizes.size(); ++k)
    for (int i = 0; i < sizes[k]; ++i) p.pieceOf.push_back(k);
  const int rows = static_cast<int>(p.pieceOf.size());
  const auto n = static_cast<std::size_t>(rows);
  const auto same = [&](int i, int k) {
    return p.pieceOf[static_cast<std::size_t>(i)] == p.pieceOf[static_cast<std::size_t>(k)];
  };
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  p.a = Eigen::MatrixXd::Zero(3 * rows, 3 * rows);
  for (int i = 0; i < rows; ++i) {
    Eigen::Matrix3d d = Eigen::Matrix3d::Identity() * (6.0 + (i % 4));
    d(0, 2) = d(2, 0) = 0.4;
    p.a.block<3, 3>(3 * i, 3 * i) = d;
    for (int k = 1; k <= 2 && i + k < rows && same(i, k + i); ++k) {
      Eigen::Matrix3d b = -Eigen::Matrix3d::Identity() / (k + 0.5);
      b(1, 0) = 0.2 * u(rng);
      p.a.block<3, 3>(3 * i, 3 * (i + k)) = b;
      p.a.block<3, 3>(3 * (i + k), 3 * i) = b.transpose();
    }
    // Positions about a centre per piece, in 3D (no piece on a line: all six modes count).
    const double centre = 10.0 * static_cast<double>(p.pieceOf[static_cast<std::size_t>(i)]);
    p.positions.push_back(Vec3d(centre + u(rng), u(rng), 0.5 * u(rng)));
    p.weights.push_back(1.0 + 0.5 * (1.0 + u(rng)));
  }
  p.x = Eigen::MatrixXd::Zero(3 * rows, 3 * rows);
  for (const Term& t : terms) {
    const Eigen::MatrixXd sa = selector(t.a, n), sb = selector(t.b, n);
    p.a += sa * t.c * sa.transpose() + sb * t.c * sb.transpose();
    p.x -= sa * t.c * sb.transpose() + sb * t.c * sa.transpose();
    p.coupling.add(t.a, t.b, t.c);
  }
  Eigen::MatrixXd rest = p.a;
  for (int i = 0; i < rows; ++i) {
    for (int k = std::max(0, i - 2); k <= std::min(rows - 1, i + 2); ++k) {
      if (!same(i, k)) continue;
      if (i == k) p.sp.diagonal.push_back(static_cast<std::uint32_t>(p.sp.column.size()));
      p.sp.column.push_back(static_cast<std::uint32_t>(k));
      p.blocks.push_back(p.a.block<3, 3>(3 * i, 3 * k));
      rest.block<3, 3>(3 * i, 3 * k).setZero();
    }
    p.sp.rowStart.push_back(static_cast<std::uint32_t>(p.sp.column.size()));
  }
  p.sp.mirror = blockMirrors(p.sp);
  EXPECT_EQ(rest.norm(), 0.0) << "a term's diagonal part does not fit the pattern";
  return p;
}

/// The modes set up for the pieces, with setOperator(A mode(k), coupling).
void setUpModes(const Pieces& p, RigidModes& modes, const RowCoupling* coupling) {
  modes.setup(p.sp, 1, p.positions, p.weights);
  std::array<std::vector<Vec3d>, 6> az;
  const BlockMatrixView view = p.sp.view(p.blocks);
  for (int k = 0; k < 6; ++k) {
    std::vector<Vec3d>& v = az[static_cast<std::size_t>(k)];
    v.resize(p.rows());
    for (std::size_t i = 0; i < p.rows(); ++i)
      v[i] = blockRowProduct(view, modes.mode(k).data(), i);
  }
  modes.setOperator(az, coupling);
}

/// Z: 6 columns per piece, mode k of piece q in column 6 q + k (zero off the piece).
Eigen::MatrixXd modeMatrix(const RigidModes& modes, std::size_t pieceCount) {
  const std::vector<std::uint32_t>& piece = modes.piece();
  Eigen::MatrixXd z = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(3 * piece.size()),
                                            static_cast<Eigen::Index>(6 * pieceCount));
  for (std::size_t i = 0; i < piece.size(); ++i)
    for (int k = 0; k < 6; ++k)
      z.block<3, 1>(3 * static_cast<Eigen::Index>(i), 6 * static_cast<Eigen::Index>(piece[i]) + k) =
          modes.mode(k)[i];
  return z;
}

/// Runs correct() on a random x with r = b - (A + X) x and checks: r is b - (A + X) x for
/// the new x, Z^T r = 0 for every mode of every piece, x moved by the dense Galerkin
/// correction Z (Z^T (A + X) Z)^-1 Z^T r, and coarseCorrection adds the same Z c.
void checkCorrection(const Pieces& p, std::size_t pieceCount, unsigned seed) {
  RigidModes modes;
  setUpModes(p, modes, &p.coupling);
  ASSERT_EQ(modes.pieceCount(), pieceCount);
  for (std::size_t i = 0; i < p.rows(); ++i) ASSERT_EQ(modes.piece()[i], p.pieceOf[i]);
  const Eigen::MatrixXd ax = p.a + p.x;
  const Eigen::MatrixXd z = modeMatrix(modes, pieceCount);
  const std::vector<Vec3d> b = randomVector(p.rows(), seed), x0 = randomVector(p.rows(), seed + 1);
  const Eigen::VectorXd r0 = flat(b) - ax * flat(x0);
  std::vector<Vec3d> x = x0, r = unflat(r0);
  modes.correct(x, r);

  const Eigen::MatrixXd g = z.transpose() * ax * z;
  const Eigen::VectorXd c = g.ldlt().solve(z.transpose() * r0);
  const Eigen::VectorXd step = z * c;
  ASSERT_GT(step.norm(), 1e-3 * flat(x0).norm());  // the correction does something
  const Eigen::VectorXd recomputed = flat(b) - ax * flat(x);
  const double scale = flat(b).norm() + ax.norm() * flat(x).norm();
  EXPECT_LE((flat(r) - recomputed).norm(), 1e-12 * scale) << "r is not b - (A + X) x";
  const Eigen::VectorXd load = z.transpose() * flat(r);
  for (Eigen::Index m = 0; m < load.size(); ++m) {
    const double modeScale = z.col(m).norm() * (r0.norm() + (ax * step).norm());
    EXPECT_LE(std::abs(load[m]), 1e-10 * modeScale)
        << "piece " << m / 6 << " mode " << m % 6 << ": Z^T r = " << load[m];
  }
  EXPECT_LE((flat(x) - flat(x0) - step).norm(), 1e-9 * step.norm());
  std::vector<Vec3d> coarse(p.rows(), Vec3d::Zero());
  modes.coarseCorrection(unflat(r0), coarse);
  EXPECT_LE((flat(coarse) - step).norm(), 1e-9 * step.norm());
}

// One term joins an interpolated point of piece 0 to one of piece 1: the two pieces are
// corrected together, and all twelve modes see a residual of A + X that is zero on them.
TEST(RigidModesCoupling, OneTermJoiningTwoPieces) {
  std::mt19937 rng(31);
  const std::vector<Term> terms = {
      {{{2, 0.3}, {3, 0.7}}, {{16, 0.5}, {17, 0.25}, {18, 0.25}}, springMatrix(rng, 40.0)}};
  const Pieces p = pieces({12, 10}, terms, 1);
  checkCorrection(p, 2, 101);
}

// Without the coupling, the correction is that of A alone, piece by piece: the residual of
// A + X is then not orthogonal to the modes (so the coupled case above is a real test).
TEST(RigidModesCoupling, WithoutTheCouplingTheModesSeeAnotherResidual) {
  std::mt19937 rng(32);
  const std::vector<Term> terms = {
      {{{2, 0.3}, {3, 0.7}}, {{16, 0.5}, {17, 0.25}, {18, 0.25}}, springMatrix(rng, 40.0)}};
  const Pieces p = pieces({12, 10}, terms, 2);
  RigidModes modes;
  setUpModes(p, modes, nullptr);
  const Eigen::MatrixXd ax = p.a + p.x;
  const Eigen::MatrixXd z = modeMatrix(modes, 2);
  const std::vector<Vec3d> b = randomVector(p.rows(), 7), x0 = randomVector(p.rows(), 8);
  const Eigen::VectorXd r0 = flat(b) - ax * flat(x0);
  std::vector<Vec3d> x = x0, r = unflat(r0);
  modes.correct(x, r);
  // The r it keeps is that of A: Z^T (b - A x) = 0 per piece, Z^T (b - (A + X) x) not.
  const Eigen::VectorXd ofA = z.transpose() * (flat(b) - p.x * flat(x0) - p.a * flat(x));
  const Eigen::VectorXd ofAx = z.transpose() * (flat(b) - ax * flat(x));
  EXPECT_LE(ofA.norm(), 1e-10 * (z.transpose() * r0).norm());
  EXPECT_GT(ofAx.norm(), 1e-3 * (z.transpose() * r0).norm());
}

// Terms that couple rows of one piece (two distant rows; a row against an interpolation that
// contains it): the piece is corrected alone with Z^T (A + X) Z, the other piece with A's.
TEST(RigidModesCoupling, TermsWithinOnePiece) {
  std::mt19937 rng(33);
  const std::vector<Term> terms = {
      {{{1, 1.0}}, {{9, 1.0}}, springMatrix(rng, 50.0)},
      {{{5, 1.0}}, {{5, 0.4}, {6, 0.6}}, springMatrix(rng, 20.0)},
      {{{14, 0.5}, {15, 0.5}}, {{20, 1.0}}, springMatrix(rng, 30.0)},
  };
  const Pieces p = pieces({12, 10}, terms, 3);
  checkCorrection(p, 2, 102);
}

// Three pieces: two terms join pieces 0 and 2 (not neighbours in the numbering), piece 1 has
// a term of its own and joins no other piece.
TEST(RigidModesCoupling, ThreePiecesTwoJoined) {
  std::mt19937 rng(34);
  const std::vector<Term> terms = {
      {{{1, 0.6}, {2, 0.4}}, {{20, 1.0}}, springMatrix(rng, 40.0)},
      {{{24, 0.2}, {25, 0.8}}, {{6, 0.5}, {7, 0.5}}, springMatrix(rng, 25.0)},
      {{{9, 1.0}}, {{15, 1.0}}, springMatrix(rng, 35.0)},
  };
  const Pieces p = pieces({8, 9, 10}, terms, 4);
  checkCorrection(p, 3, 103);
}

}  // namespace
}  // namespace voxcut
