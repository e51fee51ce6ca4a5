#include "voxcut/fem/HexElement.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>

#include "voxcut/core/Error.h"

namespace voxcut {

namespace {

/// Coefficients (c0, c1) of the 1D factor of a shape function along one axis: the hat
/// (1 - t or t for corner bit 0 or 1) or its derivative (-1 or 1), indexed [bit][derivative].
constexpr double kFactor[2][2][2] = {{{1.0, -1.0}, {-1.0, 0.0}}, {{0.0, 1.0}, {1.0, 0.0}}};

int cornerBit(int c, int axis) {
  return (c >> axis) & 1;
}

/// Integral over the region of prod_k P_k(t_k), P_k of degree <= 2 given by 3 coefficients.
double contract(const std::array<double, 27>& m, const double (&px)[3], const double (&py)[3],
                const double (&pz)[3]) {
  double sum = 0.0;
  for (int r = 0; r < 3; ++r) {
    if (pz[r] == 0.0) continue;
    double sy = 0.0;
    for (int q = 0; q < 3; ++q) {
      if (py[q] == 0.0) continue;
      const double* row = &m[static_cast<std::size_t>(3 * q + 9 * r)];
      sy += py[q] * (px[0] * row[0] + px[1] * row[1] + px[2] * row[2]);
    }
    sum += pz[r] * sy;
  }
  return sum;
}

}  // namespace

void addVoxelRow(std::vector<MaterialMoments>& region, int level, int x0, int count, int y, int z,
                 std::uint8_t material) {
  const int n = 1 << level;
  VOXCUT_ASSERT(count > 0 && x0 >= 0 && x0 + count <= n && y >= 0 && y < n && z >= 0 && z < n,
                "voxel row outside the element");
  MaterialMoments* target = nullptr;
  for (MaterialMoments& mm : region)
    if (mm.material == material) target = &mm;
  if (target == nullptr) {
    region.push_back(MaterialMoments{material, {}});
    target = &region.back();
  }
  const double dn = n;
  // Sums over the row of the 1D moments of [o, o + 1] / n: they telescope to differences of
  // powers, exact in double for every level we allow.
  const double x1 = x0 + count, xa = x0;
  const double sx[3] = {count / dn, (x1 * x1 - xa * xa) / (2.0 * dn * dn),
                        (x1 * x1 * x1 - xa * xa * xa) / (3.0 * dn * dn * dn)};
  auto moments1d = [dn](int o, double(&m)[3]) {
    const double d = o;
    m[0] = 1.0 / dn;
    m[1] = (2.0 * d + 1.0) / (2.0 * dn * dn);
    m[2] = (3.0 * d * d + 3.0 * d + 1.0) / (3.0 * dn * dn * dn);
  };
  double my[3], mz[3];
  moments1d(y, my);
  moments1d(z, mz);
  for (int r = 0; r < 3; ++r)
    for (int q = 0; q < 3; ++q) {
      const double yz = my[q] * mz[r];
      for (int p = 0; p < 3; ++p)
        target->moment[static_cast<std::size_t>(p + 3 * q + 9 * r)] += sx[p] * yz;
    }
}

ElementMatrices hexElementMatrices(int level, double voxelSize,
                                   std::span<const MaterialMoments> region,
                                   std::span<const ElasticMaterial> materials) {
  VOXCUT_ASSERT(level >= 0 && level <= 7, "element level out of range");
  const double edge = voxelSize * static_cast<double>(1 << level);
  // Material-weighted moments: lambda, mu (stiffness), rho and alpha rho (mass), and the
  // E-weighted beta.
  std::array<double, 27> ml{}, mm{}, mr{}, ma{};
  double volumeFraction = 0.0, sumE = 0.0, sumEBeta = 0.0;
  for (const MaterialMoments& part : region) {
    VOXCUT_ASSERT(part.material > 0 && part.material < materials.size(),
                  "material without an ElasticMaterial");
    const ElasticMaterial& mat = materials[part.material];
    const double lambda = mat.lameLambda(), mu = mat.lameMu();
    for (std::size_t k = 0; k < 27; ++k) {
      ml[k] += lambda * part.moment[k];
      mm[k] += mu * part.moment[k];
      mr[k] += mat.density * part.moment[k];
      ma[k] += mat.dampingMass * mat.density * part.moment[k];
    }
    volumeFraction += part.moment[0];
    sumE += mat.youngModulus * part.moment[0];
    sumEBeta += mat.youngModulus * mat.dampingStiffness * part.moment[0];
  }

  ElementMatrices out;
  const double h3 = edge * edge * edge;
  out.volume = volumeFraction * h3;
  out.stiffnessDamping = sumE > 0.0 ? sumEBeta / sumE : 0.0;
  for (int c = 0; c < 8; ++c) {
    double p[3][3];
    for (int k = 0; k < 3; ++k) {
      const double* f = kFactor[cornerBit(c, k)][0];
      p[k][0] = f[0];
      p[k][1] = f[1];
      p[k][2] = 0.0;
    }
    out.mass[static_cast<std::size_t>(c)] = h3 * contract(mr, p[0], p[1], p[2]);
    out.massDamping[static_cast<std::size_t>(c)] = h3 * contract(ma, p[0], p[1], p[2]);
  }

  // Mean shape-function gradients over the region (moments of the volume alone).
  std::array<double, 27> mv{};
  for (const MaterialMoments& part : region)
    for (std::size_t k = 0; k < 27; ++k) mv[k] += part.moment[k];
  if (volumeFraction > 0.0)
    for (int c = 0; c < 8; ++c)
      for (int i = 0; i < 3; ++i) {
        double p[3][3];
        for (int k = 0; k < 3; ++k) {
          const double* f = kFactor[cornerBit(c, k)][k == i ? 1 : 0];
          p[k][0] = f[0];
          p[k][1] = f[1];
          p[k][2] = 0.0;
        }
        out.gradientMean[static_cast<std::size_t>(c)][i] =
            contract(mv, p[0], p[1], p[2]) / volumeFraction;
      }

  // G^w(3a + i, 3b + j) = H * integral of w dN_a/dt_i dN_b/dt_j over the region (physical
  // gradients are dN/dt / H and dV = H^3 dt).
  Eigen::Matrix<double, 24, 24> gl, gm;
  for (int ai = 0; ai < 24; ++ai) {
    const int a = ai / 3, i = ai % 3;
    for (int bj = ai; bj < 24; ++bj) {
      const int b = bj / 3, j = bj % 3;
      double p[3][3];
      for (int k = 0; k < 3; ++k) {
        const double* fa = kFactor[cornerBit(a, k)][k == i ? 1 : 0];
        const double* fb = kFactor[cornerBit(b, k)][k == j ? 1 : 0];
        p[k][0] = fa[0] * fb[0];
        p[k][1] = fa[0] * fb[1] + fa[1] * fb[0];
        p[k][2] = fa[1] * fb[1];
      }
      gl(ai, bj) = gl(bj, ai) = edge * contract(ml, p[0], p[1], p[2]);
      gm(ai, bj) = gm(bj, ai) = edge * contract(mm, p[0], p[1], p[2]);
    }
  }
  // Isotropic elasticity: K_(a alpha)(b beta) = lambda int dN_a/dx_alpha dN_b/dx_beta
  //   + mu int dN_a/dx_beta dN_b/dx_alpha + delta_(alpha beta) mu int grad N_a . grad N_b.
  for (int a = 0; a < 8; ++a)
    for (int b = 0; b < 8; ++b) {
      const double trace = gm(3 * a, 3 * b) + gm(3 * a + 1, 3 * b + 1) + gm(3 * a + 2, 3 * b + 2);
      for (int al = 0; al < 3; ++al)
        for (int be = 0; be < 3; ++be)
          out.stiffness(3 * a + al, 3 * b + be) =
              gl(3 * a + al, 3 * b + be) + gm(3 * a + be, 3 * b + al) + (al == be ? trace : 0.0);
    }
  return out;
}

Eigen::Matrix3d materialDeformationGradient(const std::array<Vec3d, 8>& x,
                                            const std::array<Vec3d, 8>& rest,
                                            const std::array<Vec3d, 8>& gradientMean, double edge) {
  Vec3d xbar = Vec3d::Zero(), rbar = Vec3d::Zero();
  for (std::size_t c = 0; c < 8; ++c) {
    xbar += x[c];
    rbar += rest[c];
  }
  xbar *= 0.125;
  rbar *= 0.125;
  Eigen::Matrix3d f = Eigen::Matrix3d::Zero();
  for (std::size_t c = 0; c < 8; ++c)
    f += ((x[c] - xbar) - (rest[c] - rbar)) * gradientMean[c].transpose();
  return Eigen::Matrix3d::Identity() + f / edge;
}

namespace {

/// R of F = R S for det F > 0 by Higham's scaled Newton iteration X <- (g X + X^-T / g) / 2
/// (quadratic convergence, a few 3x3 inverses); false when it does not settle or F is nearly
/// singular, which leaves the SVD to decide.
bool newtonPolar(const Eigen::Matrix3d& f, Eigen::Matrix3d& r) {
  const double norm = f.norm();
  if (!(f.determinant() > 1e-6 * norm * norm * norm)) return false;
  Eigen::Matrix3d x = f;
  for (int k = 0; k < 30; ++k) {
    const Eigen::Matrix3d inverseT = x.inverse().transpose();
    // Frobenius scaling while far from orthogonal; unscaled near the end, where it would
    // only add round-off.
    const double g = k < 6 ? std::sqrt(inverseT.norm() / x.norm()) : 1.0;
    const Eigen::Matrix3d next = 0.5 * (g * x + inverseT / g);
    const double change = (next - x).norm();
    x = next;
    if (change <= 1e-14) {
      r = x;
      return true;
    }
  }
  return false;
}

}  // namespace

Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& f) {
  // The identity (an undeformed or purely translated element) is common and must give
  // exactly R = I, so that the rest state has exactly zero force.
  if (!f.allFinite() || f == Eigen::Matrix3d::Identity()) return Eigen::Matrix3d::Identity();
  Eigen::Matrix3d r;
  if (newtonPolar(f, r)) return r;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d& v = svd.matrixV();
  if ((u * v.transpose()).determinant() < 0.0) u.col(2) = -u.col(2);
  return u * v.transpose();
}

Eigen::Matrix<double, 24, 1> corotatedDisplacement(const Eigen::Matrix3d& rotation,
                                                   const std::array<Vec3d, 8>& x,
                                                   const std::array<Vec3d, 8>& rest) {
  Vec3d xbar = Vec3d::Zero(), rbar = Vec3d::Zero();
  for (int c = 0; c < 8; ++c) {
    xbar += x[static_cast<std::size_t>(c)];
    rbar += rest[static_cast<std::size_t>(c)];
  }
  xbar *= 0.125;
  rbar *= 0.125;
  Eigen::Matrix<double, 24, 1> y;
  for (int c = 0; c < 8; ++c) {
    const auto k = static_cast<std::size_t>(c);
    y.segment<3>(3 * c) = rotation.transpose() * (x[k] - xbar) - (rest[k] - rbar);
  }
  return y;
}

}  // namespace voxcut
