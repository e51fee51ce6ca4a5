#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>
#include <vector>

#include "voxcut/fem/HexElement.h"

namespace voxcut {
namespace {

using Mat24 = Eigen::Matrix<double, 24, 24>;

struct Voxel {
  int x, y, z;
  std::uint8_t material;
};

std::vector<ElasticMaterial> twoMaterials() {
  std::vector<ElasticMaterial> m(3);
  m[1] = {2e5, 0.3, 900.0, 0.5, 0.01};
  m[2] = {7e6, 0.45, 1300.0, 2.0, 0.002};
  return m;
}

/// Independent reference: 2x2x2 Gauss points in every voxel's sub-cube (exact for the
/// degree <= 2 per axis integrand), B-matrix in Voigt form, D from (E, nu).
void bruteForce(int level, double h, const std::vector<Voxel>& voxels,
                const std::vector<ElasticMaterial>& mats, Mat24& k, std::array<double, 8>& mass) {
  const int n = 1 << level;
  const double edge = h * n;
  k.setZero();
  mass.fill(0.0);
  const double g = 0.5 / std::sqrt(3.0);
  for (const Voxel& v : voxels) {
    const ElasticMaterial& m = mats[v.material];
    const double lambda = m.lameLambda(), mu = m.lameMu();
    Eigen::Matrix<double, 6, 6> d = Eigen::Matrix<double, 6, 6>::Zero();
    d.topLeftCorner<3, 3>().setConstant(lambda);
    for (int i = 0; i < 3; ++i) d(i, i) += 2 * mu;
    for (int i = 3; i < 6; ++i) d(i, i) = mu;
    const double vol = std::pow(edge / n, 3);
    for (int q = 0; q < 8; ++q) {
      const double t[3] = {(v.x + 0.5 + ((q & 1) ? g : -g)) / n,
                           (v.y + 0.5 + ((q & 2) ? g : -g)) / n,
                           (v.z + 0.5 + ((q & 4) ? g : -g)) / n};
      Eigen::Matrix<double, 6, 24> b = Eigen::Matrix<double, 6, 24>::Zero();
      for (int c = 0; c < 8; ++c) {
        double f[3], df[3];
        for (int a = 0; a < 3; ++a) {
          const bool bit = (c >> a) & 1;
          f[a] = bit ? t[a] : 1 - t[a];
          df[a] = (bit ? 1.0 : -1.0) / edge;
        }
        const double gx = df[0] * f[1] * f[2], gy = f[0] * df[1] * f[2], gz = f[0] * f[1] * df[2];
        b(0, 3 * c) = gx;
        b(1, 3 * c + 1) = gy;
        b(2, 3 * c + 2) = gz;
        b(3, 3 * c + 1) = gz;
        b(3, 3 * c + 2) = gy;
        b(4, 3 * c) = gz;
        b(4, 3 * c + 2) = gx;
        b(5, 3 * c) = gy;
        b(5, 3 * c + 1) = gx;
        mass[static_cast<std::size_t>(c)] += m.density * vol / 8 * f[0] * f[1] * f[2];
      }
      k += b.transpose() * d * b * (vol / 8);
    }
  }
}

ElementMatrices viaMoments(int level, double h, const std::vector<Voxel>& voxels,
                           const std::vector<ElasticMaterial>& mats) {
  std::vector<MaterialMoments> region;
  for (const Voxel& v : voxels) addVoxelRow(region, level, v.x, 1, v.y, v.z, v.material);
  return hexElementMatrices(level, h, region, mats);
}

TEST(HexElement, CompositeStiffnessMatchesGaussQuadrature) {
  const auto mats = twoMaterials();
  std::mt19937 rng(7);
  for (int level : {0, 1, 2}) {
    const int n = 1 << level;
    std::vector<Voxel> voxels;
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const auto r = static_cast<unsigned>(rng() % 5);
          if (level > 0 && r == 0) continue;  // partially filled
          voxels.push_back({x, y, z, static_cast<std::uint8_t>(1 + (r % 2))});
        }
    const double h = 0.003;
    Mat24 kRef;
    std::array<double, 8> mRef;
    bruteForce(level, h, voxels, mats, kRef, mRef);
    const ElementMatrices em = viaMoments(level, h, voxels, mats);
    EXPECT_LE((em.stiffness - kRef).cwiseAbs().maxCoeff(), 1e-12 * kRef.cwiseAbs().maxCoeff())
        << "level " << level;
    for (int c = 0; c < 8; ++c)
      EXPECT_NEAR(em.mass[static_cast<std::size_t>(c)], mRef[static_cast<std::size_t>(c)],
                  1e-12 * mRef[0]);
    EXPECT_LE((em.stiffness - em.stiffness.transpose()).cwiseAbs().maxCoeff(),
              1e-14 * kRef.cwiseAbs().maxCoeff());
  }
}

TEST(HexElement, RowsEqualSingleVoxelsAndMassesAddUp) {
  const auto mats = twoMaterials();
  const int level = 3;
  std::vector<MaterialMoments> rows, singles;
  addVoxelRow(rows, level, 1, 6, 2, 5, 2);
  addVoxelRow(rows, level, 0, 8, 7, 7, 1);
  for (int x = 1; x < 7; ++x) addVoxelRow(singles, level, x, 1, 2, 5, 2);
  for (int x = 0; x < 8; ++x) addVoxelRow(singles, level, x, 1, 7, 7, 1);
  ASSERT_EQ(rows.size(), 2u);
  ASSERT_EQ(singles.size(), 2u);
  for (std::size_t m = 0; m < 2; ++m)
    for (std::size_t k = 0; k < 27; ++k)
      EXPECT_NEAR(rows[m].moment[k], singles[m].moment[k], 1e-15);
  const double h = 0.002;
  const ElementMatrices em = hexElementMatrices(level, h, rows, mats);
  double total = 0;
  for (double m : em.mass) total += m;
  const double v = h * h * h;
  EXPECT_NEAR(total, 6 * v * mats[2].density + 8 * v * mats[1].density, 1e-12 * total);
  EXPECT_NEAR(em.volume, 14 * v, 1e-15);
  // E-weighted beta.
  const double beta = (6 * mats[2].youngModulus * mats[2].dampingStiffness +
                       8 * mats[1].youngModulus * mats[1].dampingStiffness) /
                      (6 * mats[2].youngModulus + 8 * mats[1].youngModulus);
  EXPECT_NEAR(em.stiffnessDamping, beta, 1e-15);
  double alphaMass = 0;
  for (double m : em.massDamping) alphaMass += m;
  EXPECT_NEAR(
      alphaMass,
      v * (6 * mats[2].density * mats[2].dampingMass + 8 * mats[1].density * mats[1].dampingMass),
      1e-12 * alphaMass);
}

TEST(HexElement, FullElementIsTheStandardHexAndScalesWithEdge) {
  const auto mats = twoMaterials();
  const double h = 0.001;
  std::vector<MaterialMoments> full, one;
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y) addVoxelRow(full, 2, 0, 4, y, z, 1);
  addVoxelRow(one, 0, 0, 1, 0, 0, 1);
  const ElementMatrices coarse = hexElementMatrices(2, h, full, mats);
  const ElementMatrices single = hexElementMatrices(0, 4 * h, one, mats);
  const ElementMatrices small = hexElementMatrices(0, h, one, mats);
  const double scale = single.stiffness.cwiseAbs().maxCoeff();
  EXPECT_LE((coarse.stiffness - single.stiffness).cwiseAbs().maxCoeff(), 1e-13 * scale);
  EXPECT_LE((4 * small.stiffness - single.stiffness).cwiseAbs().maxCoeff(), 1e-13 * scale);
  for (int c = 0; c < 8; ++c) {
    EXPECT_NEAR(coarse.mass[static_cast<std::size_t>(c)], mats[1].density * std::pow(4 * h, 3) / 8,
                1e-15);
  }
  // Symmetric positive semi-definite with exactly the 6 rigid modes in its kernel.
  const Eigen::SelfAdjointEigenSolver<Mat24> eig(single.stiffness);
  const auto& ev = eig.eigenvalues();
  for (int i = 0; i < 6; ++i) EXPECT_LE(std::abs(ev(i)), 1e-10 * ev(23));
  EXPECT_GT(ev(6), 1e-3 * ev(23));
  // A rigid rotation field (small) and a translation give zero force.
  Eigen::Matrix<double, 24, 1> rot, trans;
  for (int c = 0; c < 8; ++c) {
    const Vec3d x((c & 1) * 4 * h, ((c >> 1) & 1) * 4 * h, ((c >> 2) & 1) * 4 * h);
    rot.segment<3>(3 * c) = Vec3d(0.3, -0.2, 0.7).cross(x);
    trans.segment<3>(3 * c) = Vec3d(1, 2, 3);
  }
  EXPECT_LE((single.stiffness * rot).norm(), 1e-12 * scale * h);
  EXPECT_LE((single.stiffness * trans).norm(), 1e-12 * scale);
}

// The mean shape-function gradients of a full element: the centre's, +-1/4 per axis.
std::array<Vec3d, 8> fullElementGradients() {
  std::array<Vec3d, 8> g;
  for (int c = 0; c < 8; ++c)
    for (int k = 0; k < 3; ++k) g[static_cast<std::size_t>(c)][k] = (c >> k) & 1 ? 0.25 : -0.25;
  return g;
}

TEST(HexElement, DeformationGradientOfAnAffineField) {
  const double edge = 0.02;
  Eigen::Matrix3d a;
  a << 0.1, -0.3, 0.2, 0.05, 0.2, -0.1, 0.3, 0.0, -0.2;
  std::array<Vec3d, 8> rest, x;
  for (int c = 0; c < 8; ++c) {
    const auto k = static_cast<std::size_t>(c);
    rest[k] = Vec3d(0.4, -1.0, 2.0) + edge * Vec3d(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    x[k] = rest[k] + a * rest[k] + Vec3d(0.1, 0.2, 0.3);
  }
  const Eigen::Matrix3d f = materialDeformationGradient(x, rest, fullElementGradients(), edge);
  EXPECT_LE((f - (Eigen::Matrix3d::Identity() + a)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(materialDeformationGradient(rest, rest, fullElementGradients(), edge),
            Eigen::Matrix3d::Identity());
}

TEST(HexElement, PolarRotationIsAProperRotationEvenWhenInverted) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Matrix3d q =
        Eigen::AngleAxisd(3.0 * u(rng), Vec3d(u(rng), u(rng), u(rng)).normalized())
            .toRotationMatrix();
    Eigen::Matrix3d s0 = Eigen::Matrix3d::Random() * 0.2;
    const Eigen::Matrix3d s = Eigen::Matrix3d::Identity() + s0 * s0.transpose();  // SPD
    const Eigen::Matrix3d r = polarRotation(q * s);
    EXPECT_LE((r - q).cwiseAbs().maxCoeff(), 1e-12);
    // Inverted: reflect one axis. Still a proper rotation, and deterministic.
    const Eigen::Matrix3d inverted = q * s * Vec3d(1, 1, -1).asDiagonal();
    const Eigen::Matrix3d ri = polarRotation(inverted);
    EXPECT_NEAR(ri.determinant(), 1.0, 1e-12);
    EXPECT_LE((ri * ri.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_EQ(ri, polarRotation(inverted));
  }
  EXPECT_EQ(polarRotation(Eigen::Matrix3d::Identity()), Eigen::Matrix3d::Identity());
  EXPECT_NEAR(polarRotation(Eigen::Matrix3d::Zero()).determinant(), 1.0, 1e-12);
  Eigen::Matrix3d bad = Eigen::Matrix3d::Identity();
  bad(1, 2) = std::nan("");
  EXPECT_EQ(polarRotation(bad), Eigen::Matrix3d::Identity());
}

TEST(HexElement, PolarRotationOfStronglyStretchedElements) {
  // Large, anisotropic stretches (the Newton iteration's hard cases) and a nearly flat element
  // (left to the SVD) still give the rotation to round-off.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const Vec3d& stretch :
       {Vec3d(10, 1, 0.05), Vec3d(0.01, 3, 2), Vec3d(1e-7, 1, 1), Vec3d(1, 1 + 1e-12, 1)}) {
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::Matrix3d q =
          Eigen::AngleAxisd(3.0 * u(rng), Vec3d(u(rng), u(rng), u(rng)).normalized())
              .toRotationMatrix();
      const Eigen::Matrix3d v =
          Eigen::AngleAxisd(3.0 * u(rng), Vec3d(u(rng), u(rng), u(rng)).normalized())
              .toRotationMatrix();
      const Eigen::Matrix3d s = v * stretch.asDiagonal() * v.transpose();
      const Eigen::Matrix3d r = polarRotation(q * s);
      EXPECT_LE((r - q).cwiseAbs().maxCoeff(), 1e-9 * std::max(1.0, 1e-7 / stretch.minCoeff()))
          << stretch.transpose();
      EXPECT_LE((r * r.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-13);
    }
  }
}

TEST(HexElement, CorotatedDisplacementOfARigidMotionIsZero) {
  const Eigen::Matrix3d q =
      Eigen::AngleAxisd(2.5, Vec3d(1, -2, 0.5).normalized()).toRotationMatrix();
  std::array<Vec3d, 8> rest, x;
  for (std::size_t c = 0; c < 8; ++c) {
    const int k = static_cast<int>(c);
    rest[c] = Vec3d(0.3, 0.1, -0.2) + 0.016 * Vec3d(k & 1, (k >> 1) & 1, (k >> 2) & 1);
    x[c] = q * rest[c] + Vec3d(5, -3, 1);
  }
  const Eigen::Matrix3d r =
      polarRotation(materialDeformationGradient(x, rest, fullElementGradients(), 0.016));
  EXPECT_LE((r - q).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE(corotatedDisplacement(r, x, rest).cwiseAbs().maxCoeff(), 1e-15);
}

}  // namespace
}  // namespace voxcut

namespace voxcut {
namespace {

// The mean shape-function gradients over the material: +-1/4 for a full element (the centre's
// gradient), and for a single voxel the gradient at its centre (bilinear in the other
// coordinates, so its mean over a sub-cube is its value at the sub-cube's centre).
TEST(HexElementGradientMean, FullElementAndSingleVoxel) {
  const std::vector<ElasticMaterial> mats(2);
  std::vector<MaterialMoments> full;
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y) addVoxelRow(full, 2, 0, 4, y, z, 1);
  const ElementMatrices f = hexElementMatrices(2, 0.01, full, mats);
  for (int c = 0; c < 8; ++c)
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(f.gradientMean[static_cast<std::size_t>(c)][k], ((c >> k) & 1 ? 0.25 : -0.25),
                  1e-15);
  std::vector<MaterialMoments> one;
  addVoxelRow(one, 2, 3, 1, 0, 2, 1);  // voxel (3, 0, 2) of 4^3: centre t = (7, 1, 5) / 8
  const ElementMatrices s = hexElementMatrices(2, 0.01, one, mats);
  const Vec3d t(7.0 / 8, 1.0 / 8, 5.0 / 8);
  for (int c = 0; c < 8; ++c) {
    Vec3d expected;
    for (int k = 0; k < 3; ++k) {
      double g = 1.0;
      for (int j = 0; j < 3; ++j) {
        const bool bit = (c >> j) & 1;
        g *= j == k ? (bit ? 1.0 : -1.0) : (bit ? t[j] : 1.0 - t[j]);
      }
      expected[k] = g;
    }
    EXPECT_LE((s.gradientMean[static_cast<std::size_t>(c)] - expected).norm(), 1e-14);
  }
}

// An affine motion x = A X + b gives F = A over any material, exactly I at rest, and the
// polar rotation of a rotated partial element is its rotation, whatever corner it fills.
TEST(HexElementGradientMean, MaterialDeformationGradientOfAnAffineField) {
  const std::vector<ElasticMaterial> mats(2);
  std::vector<MaterialMoments> corner;
  addVoxelRow(corner, 3, 6, 2, 7, 0, 1);
  const ElementMatrices e = hexElementMatrices(3, 0.002, corner, mats);
  const double edge = 0.016;
  Eigen::Matrix3d a;
  a << 1.1, -0.3, 0.2, 0.05, 0.9, -0.1, 0.3, 0.0, 1.2;
  std::array<Vec3d, 8> rest, x;
  for (std::size_t c = 0; c < 8; ++c) {
    const int k = static_cast<int>(c);
    rest[c] = Vec3d(5e4, -1.0, 2.0) + edge * Vec3d(k & 1, (k >> 1) & 1, (k >> 2) & 1);
    x[c] = a * rest[c] + Vec3d(0.1, 0.2, 0.3);
  }
  EXPECT_LE((materialDeformationGradient(x, rest, e.gradientMean, edge) - a).cwiseAbs().maxCoeff(),
            1e-9);
  EXPECT_EQ(materialDeformationGradient(rest, rest, e.gradientMean, edge),
            Eigen::Matrix3d::Identity());
  const Eigen::Matrix3d q =
      Eigen::AngleAxisd(1.2, Vec3d(0.2, -1, 0.4).normalized()).toRotationMatrix();
  for (std::size_t c = 0; c < 8; ++c) x[c] = q * rest[c] + Vec3d(-3, 2, 1);
  EXPECT_LE((polarRotation(materialDeformationGradient(x, rest, e.gradientMean, edge)) - q)
                .cwiseAbs()
                .maxCoeff(),
            1e-9);
}

}  // namespace
}  // namespace voxcut
