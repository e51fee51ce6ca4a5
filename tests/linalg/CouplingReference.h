#pragma once
// Dense references for tests of couplings between block rows (linalg/RowCoupling.h): block
// vectors flattened to Eigen vectors and back, random block vectors, and a combination of
// block rows as a dense 3-column matrix. Shared by tests/linalg and tests/fem.

#include <Eigen/Dense>
#include <random>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/linalg/RowCoupling.h"

namespace voxcut::test {

/// One term of a coupling, kept apart to build the dense reference.
struct Term {
  RowWeights a, b;
  Eigen::Matrix3d c;
};

inline std::vector<Vec3d> randomVector(std::size_t rows, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3d> v(rows);
  for (Vec3d& x : v) x = Vec3d(u(rng), u(rng), u(rng));
  return v;
}

inline Eigen::VectorXd flat(const std::vector<Vec3d>& v) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(3 * v.size()));
  for (std::size_t i = 0; i < v.size(); ++i)
    out.segment<3>(3 * static_cast<Eigen::Index>(i)) = v[i];
  return out;
}

inline std::vector<Vec3d> unflat(const Eigen::VectorXd& v) {
  std::vector<Vec3d> out(static_cast<std::size_t>(v.size() / 3));
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = v.segment<3>(3 * static_cast<Eigen::Index>(i));
  return out;
}

/// S: the combination s of block rows as a 3 rows x 3 columns per block row matrix.
inline Eigen::MatrixXd selector(const RowWeights& s, std::size_t rows) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(3 * rows), 3);
  for (const auto& [row, weight] : s)
    out.block<3, 3>(3 * static_cast<Eigen::Index>(row), 0) += weight * Eigen::Matrix3d::Identity();
  return out;
}

}  // namespace voxcut::test
