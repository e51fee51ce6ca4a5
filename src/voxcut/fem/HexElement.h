#pragma once
/// @file HexElement.h
/// Pure kernels of the composite hexahedral element (docs/algorithms.md, "Composite
/// elements", "Corotation" and "Corotation from the material"): rest stiffness and lumped mass
/// of a level-L element integrated over the voxels it holds, each voxel with its own material;
/// the corotational frame (the deformation gradient averaged over the element's material and
/// its polar rotation).
///
/// Element frame. A level-L element is a cube of edge H = h * 2^L (h the voxel size, metres)
/// with unit coordinates t in [0, 1]^3; corner c in 0..7 sits at t = (c & 1, (c >> 1) & 1,
/// (c >> 2) & 1) and has the trilinear shape function N_c(t) = prod_k (bit_k ? t_k : 1 - t_k).
/// A voxel at offset o (integers in [0, 2^L)) occupies the sub-cube [o, o + 1] / 2^L. Local
/// DOF 3 * c + axis.
///
/// Integration is exact: every entry of B^T D B is a product over the three axes of
/// polynomials of degree <= 2 in one coordinate, so the stiffness over a set of voxels is a
/// fixed linear combination of the 27 moments  M[p + 3q + 9r] = sum_voxels  integral over the
/// voxel's sub-cube of tx^p ty^q tz^r dt  (p, q, r in 0..2), accumulated per material. The
/// lumped mass of corner c is the integral of rho N_c over the voxels (row-sum lumping), which
/// equals each voxel's mass spread with the trilinear weights at its centre (N_c is linear
/// along each axis, so its mean over a sub-cube is its value at the centre).
///
/// Thread-safety: every function here is pure (no shared state).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

/// One material's elastic constants, indexed by grid material (VoxelGrid::material(v), 1..N;
/// entry 0 stands for empty space and is never read).
struct ElasticMaterial {
  double youngModulus = 1e5;      ///< E (Pa), > 0
  double poissonRatio = 0.4;      ///< nu, in (-1, 0.5)
  double density = 1000.0;        ///< rho (kg/m^3), > 0
  double dampingMass = 0.0;       ///< Rayleigh alpha (1/s), >= 0: C = alpha M + beta K
  double dampingStiffness = 0.0;  ///< Rayleigh beta (s), >= 0

  /// Lame's first parameter lambda = E nu / ((1 + nu)(1 - 2 nu)) (Pa).
  [[nodiscard]] double lameLambda() const {
    return youngModulus * poissonRatio / ((1.0 + poissonRatio) * (1.0 - 2.0 * poissonRatio));
  }
  /// Shear modulus mu = E / (2 (1 + nu)) (Pa).
  [[nodiscard]] double lameMu() const { return youngModulus / (2.0 * (1.0 + poissonRatio)); }
};

/// The 27 moments of one material's occupied region in an element (see the file comment),
/// dimensionless (unit element coordinates).
struct MaterialMoments {
  std::uint8_t material = 0;
  std::array<double, 27> moment{};
};

/// Adds `count` voxels of `material` in a row along x to `region` (one entry per material,
/// appended on first use; a linear search, regions hold few materials): the voxels at offsets
/// (x0 .. x0 + count - 1, y, z) of a level-`level` element. Offsets must lie in [0, 2^level).
/// Cost: 27 multiply-adds per call whatever `count` (the x sums telescope).
void addVoxelRow(std::vector<MaterialMoments>& region, int level, int x0, int count, int y, int z,
                 std::uint8_t material);

/// Rest matrices of one element, integrated over the voxels it holds.
struct ElementMatrices {
  /// Rest stiffness K (N/m), 24 x 24, symmetric positive semi-definite, rows and columns
  /// 3 * corner + axis: K = sum_voxels integral of B^T D(E_v, nu_v) B dV.
  Eigen::Matrix<double, 24, 24> stiffness = Eigen::Matrix<double, 24, 24>::Zero();
  /// Lumped mass of each corner (kg): integral of rho N_c dV; sums to the element's mass.
  std::array<double, 8> mass{};
  /// Lumped mass-proportional damping of each corner (kg/s): integral of alpha rho N_c dV,
  /// exact per voxel.
  std::array<double, 8> massDamping{};
  /// Stiffness-proportional damping factor beta_e (s) of the whole element: the mean of its
  /// voxels' beta weighted by E_v (exact when the element holds one material).
  double stiffnessDamping = 0.0;
  /// Volume of the voxels it holds (m^3).
  double volume = 0.0;
  /// Mean over the voxels it holds of each corner's shape-function gradient in unit element
  /// coordinates, (1 / |V|) integral over V of grad_t N_c dt (dimensionless; the physical
  /// gradient divides by the edge H). The corotational frame reads the deformation gradient
  /// averaged over the material through it (materialDeformationGradient), so that corners far
  /// from the material do not steer the element's rotation. For a full element every entry
  /// is +-1/4, the gradient at the centre. Zero for an element that holds no voxel.
  std::array<Vec3d, 8> gradientMean{};
};

/// Stiffness and lumped mass of a level-`level` element of voxel size `voxelSize` (metres)
/// holding the voxels summarised in `region` (moments per material), with the material table
/// `materials` (indexed by material; every material in `region` must index it). The stiffness
/// scales linearly with the edge H = voxelSize * 2^level, the masses with H^3. Cost: about
/// 2 x 300 contractions of 27 moments, independent of the voxel count. Pure.
[[nodiscard]] ElementMatrices hexElementMatrices(int level, double voxelSize,
                                                 std::span<const MaterialMoments> region,
                                                 std::span<const ElasticMaterial> materials);

/// Deformation gradient averaged over an element's material, from its 8 current corners `x`
/// and rest corners `rest` (metres): F = I + sum_c ((x_c - xbar) - (X_c - Xbar)) g_c^T / edge
/// with g_c = ElementMatrices::gradientMean[c], xbar and Xbar the corners' means and `edge`
/// the rest edge (metres). The gradients sum to zero, so the means change nothing but the
/// round-off: differences of nearby corners are exact, while a displacement x_c - X_c of a
/// body far from its rest place (a long fall) would carry the round-off of its large
/// translation into F. Exactly I when x == rest. Trilinear F is linear along each axis in the
/// other coordinates, so for a full element this is exactly the centre's gradient; for an
/// element holding a few voxels in a corner it follows the corners around them, which a
/// centre gradient would weigh no more than the empty side. Pure.
[[nodiscard]] Eigen::Matrix3d materialDeformationGradient(const std::array<Vec3d, 8>& x,
                                                          const std::array<Vec3d, 8>& rest,
                                                          const std::array<Vec3d, 8>& gradientMean,
                                                          double edge);

/// Rotation R of the polar decomposition F = R S. For det F clearly positive: Higham's scaled
/// Newton iteration X <- (g X + X^-T / g) / 2 from X = F until a step changes X by at most
/// 1e-14 (a few iterations, much cheaper than an SVD). Otherwise (inverted, nearly singular,
/// or no convergence): with the SVD F = U Sigma V^T (singular values descending),
/// R = U diag(1, 1, d) V^T, d = sign det(U V^T), so R is always a proper rotation; for an
/// inverted element (det F <= 0) the axis of least stretch is reflected. Returns exactly the
/// identity for F = I and for a non-finite F. Deterministic. Pure.
[[nodiscard]] Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& f);

/// Corotated displacement of an element, 24 entries (3 * corner + axis, metres):
/// y_c = R^T (x_c - xbar) - (X_c - Xbar), with xbar, Xbar the means of the current and rest
/// corners (K annihilates translations, so this equals R^T x - X up to one; centring keeps
/// round-off at the element's scale). Zero for a rigid motion when R is its rotation. Pure.
[[nodiscard]] Eigen::Matrix<double, 24, 1> corotatedDisplacement(const Eigen::Matrix3d& rotation,
                                                                 const std::array<Vec3d, 8>& x,
                                                                 const std::array<Vec3d, 8>& rest);

}  // namespace voxcut
