#include "voxcut/fem/RigidModes.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <map>

#include "voxcut/core/Error.h"
#include "voxcut/core/UnionFind.h"
#include "voxcut/fem/ElasticModel.h"

namespace voxcut {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// The pseudo-inverse of a symmetric positive semi-definite matrix, on the eigenvalues that
/// are clearly positive (zero when it is not finite or has none).
template <class Matrix>
Matrix pseudoInverse(const Matrix& m) {
  const Matrix g = 0.5 * (m + m.transpose());  // the round-off's asymmetry away
  Matrix out = Matrix::Zero(m.rows(), m.cols());
  if (!g.allFinite()) return out;
  const Eigen::SelfAdjointEigenSolver<Matrix> eig(g);
  const auto& lambda = eig.eigenvalues();
  const double largest = lambda.maxCoeff();
  if (!(largest > 0.0)) return out;
  auto inverted = lambda;
  for (Eigen::Index k = 0; k < lambda.size(); ++k)
    inverted[k] = lambda[k] > 1e-10 * largest ? 1.0 / lambda[k] : 0.0;
  return eig.eigenvectors() * inverted.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace

void RigidModes::setup(const BlockSparsity& sparsity, std::uint64_t revision,
                       const std::vector<Vec3d>& positions, const std::vector<double>& weights) {
  const std::size_t rows = sparsity.rowStart.size() - 1;
  VOXCUT_ASSERT(positions.size() == rows && weights.size() == rows,
                "one position and weight per free node");
  if (!labelled_ || revision != revision_ || piece_.size() != rows) {
    UnionFind sets(rows);
    for (std::size_t i = 0; i < rows; ++i)
      for (std::uint32_t s = sparsity.rowStart[i]; s < sparsity.rowStart[i + 1]; ++s)
        sets.unite(static_cast<std::uint32_t>(i), sparsity.column[s]);
    // Pieces numbered in order of their first row: deterministic.
    piece_.assign(rows, 0);
    std::vector<std::uint32_t> label(rows, kNotFree);
    pieceCount_ = 0;
    for (std::size_t i = 0; i < rows; ++i) {
      const std::uint32_t root = sets.find(static_cast<std::uint32_t>(i));
      if (label[root] == kNotFree) label[root] = static_cast<std::uint32_t>(pieceCount_++);
      piece_[i] = label[root];
    }
    revision_ = revision;
    labelled_ = true;
  }

  // Weighted centroid and radius of gyration per piece; plain ones where the weights vanish.
  std::vector<Vec3d> centre(pieceCount_, Vec3d::Zero()), plainCentre(pieceCount_, Vec3d::Zero());
  std::vector<double> weight(pieceCount_, 0.0), count(pieceCount_, 0.0);
  for (std::size_t i = 0; i < rows; ++i) {
    const std::uint32_t p = piece_[i];
    centre[p] += weights[i] * positions[i];
    weight[p] += weights[i];
    plainCentre[p] += positions[i];
    count[p] += 1.0;
  }
  for (std::size_t p = 0; p < pieceCount_; ++p)
    centre[p] = weight[p] > 0.0 ? Vec3d(centre[p] / weight[p]) : Vec3d(plainCentre[p] / count[p]);
  std::vector<double> spread(pieceCount_, 0.0);
  for (std::size_t i = 0; i < rows; ++i)
    spread[piece_[i]] += (positions[i] - centre[piece_[i]]).squaredNorm();
  std::vector<double> inverseRadius(pieceCount_, 0.0);
  for (std::size_t p = 0; p < pieceCount_; ++p) {
    const double radius = std::sqrt(spread[p] / count[p]);
    inverseRadius[p] = radius > 0.0 ? 1.0 / radius : 0.0;
  }
  for (auto& m : modes_) m.resize(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    const Vec3d d = (positions[i] - centre[piece_[i]]) * inverseRadius[piece_[i]];
    for (int a = 0; a < 3; ++a) {
      modes_[static_cast<std::size_t>(a)][i] = Vec3d::Unit(a);
      modes_[static_cast<std::size_t>(3 + a)][i] = Vec3d::Unit(a).cross(d);
    }
  }
}

std::array<Vec3d, 6> RigidModes::rowProducts(const Eigen::Matrix3d* blocks,
                                             const std::uint32_t* column, std::uint32_t begin,
                                             std::uint32_t end) const {
  // t: the sums of the blocks' entries (column a of their sum is the product with e_a); r:
  // the rotations' products, three rows each. Blocks are column-major: row q of a block
  // times v is a[q] v0 + a[q + 3] v1 + a[q + 6] v2.
  std::array<double, 9> t{};
  std::array<double, 9> r{};
  const Vec3d* rx = modes_[3].data();
  const Vec3d* ry = modes_[4].data();
  const Vec3d* rz = modes_[5].data();
  for (std::uint32_t slot = begin; slot < end; ++slot) {
    const double* a = blocks[slot].data();
    for (std::size_t j = 0; j < 9; ++j) t[j] += a[j];
    const double* u = rx[column[slot]].data();  // (0, u1, u2)
    const double* v = ry[column[slot]].data();  // (v0, 0, v2)
    const double* w = rz[column[slot]].data();  // (w0, w1, 0)
    for (std::size_t q = 0; q < 3; ++q) {
      r[q] += a[q + 3] * u[1] + a[q + 6] * u[2];
      r[3 + q] += a[q] * v[0] + a[q + 6] * v[2];
      r[6 + q] += a[q] * w[0] + a[q + 3] * w[1];
    }
  }
  return {Vec3d(t[0], t[1], t[2]), Vec3d(t[3], t[4], t[5]), Vec3d(t[6], t[7], t[8]),
          Vec3d(r[0], r[1], r[2]), Vec3d(r[3], r[4], r[5]), Vec3d(r[6], r[7], r[8])};
}

void RigidModes::setOperator(std::array<std::vector<Vec3d>, 6>& az, const RowCoupling* coupling) {
  const std::size_t rows = piece_.size();
  for (const auto& v : az) VOXCUT_ASSERT(v.size() == rows, "one product per free node");
  products_.swap(az);
  std::vector<Matrix6d> gram(pieceCount_, Matrix6d::Zero());
  for (std::size_t i = 0; i < rows; ++i) {
    Matrix6d& g = gram[piece_[i]];
    for (std::size_t k = 0; k < 6; ++k)
      for (std::size_t l = 0; l < 6; ++l)
        g(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(l)) +=
            modes_[k][i].dot(products_[l][i]);
  }
  // Z^T X Z, by pairs of pieces: each term's two sides projected onto the modes of the pieces
  // their rows lie in (a 3 x 6 per piece), and the pieces a term joins in one group.
  coupling_ = coupling != nullptr && !coupling->empty() ? coupling : nullptr;
  groups_.clear();
  groupInverse_.clear();
  std::map<std::pair<std::uint32_t, std::uint32_t>, Matrix6d> cross;
  UnionFind sets(static_cast<std::uint32_t>(pieceCount_));
  if (coupling_ != nullptr) {
    using Projection = std::vector<std::pair<std::uint32_t, Eigen::Matrix<double, 3, 6>>>;
    using Entry = std::pair<std::uint32_t, double>;
    auto project = [&](const Entry* begin, const Entry* end) {
      Projection out;
      for (const Entry* e = begin; e != end; ++e) {
        const std::uint32_t p = piece_[e->first];
        auto it = std::find_if(out.begin(), out.end(), [&](const auto& x) { return x.first == p; });
        if (it == out.end()) it = out.insert(out.end(), {p, Eigen::Matrix<double, 3, 6>::Zero()});
        for (std::size_t k = 0; k < 6; ++k)
          it->second.col(static_cast<Eigen::Index>(k)) += e->second * modes_[k][e->first];
      }
      return out;
    };
    coupling_->forEachTerm([&](const Entry* a0, const Entry* a1, const Entry* b0, const Entry* b1,
                               const Eigen::Matrix3d& c) {
      const Projection pa = project(a0, a1), pb = project(b0, b1);
      for (const auto& [p, ma] : pa)
        for (const auto& [q, mb] : pb) {
          const Matrix6d block = -(ma.transpose() * c * mb);
          auto add = [&](std::uint32_t i, std::uint32_t j, const Matrix6d& m) {
            auto [it, fresh] = cross.try_emplace({i, j}, m);
            if (!fresh) it->second += m;
          };
          add(p, q, block);
          add(q, p, block.transpose());
          sets.unite(p, q);
        }
    });
    for (const auto& [pq, block] : cross)
      if (pq.first == pq.second) gram[pq.first] += block;
  }
  inverse_.assign(pieceCount_, Matrix6d::Zero());
  for (std::size_t p = 0; p < pieceCount_; ++p) inverse_[p] = pseudoInverse(gram[p]);
  if (cross.empty()) return;
  // Groups of more than one piece, in order of their first piece: one dense problem each.
  std::vector<std::vector<std::uint32_t>> members(pieceCount_);
  for (std::uint32_t p = 0; p < pieceCount_; ++p) members[sets.find(p)].push_back(p);
  for (auto& m : members)
    if (m.size() > 1) groups_.push_back(std::move(m));
  std::sort(groups_.begin(), groups_.end());
  for (const std::vector<std::uint32_t>& g : groups_) {
    const auto size = static_cast<Eigen::Index>(6 * g.size());
    Eigen::MatrixXd big = Eigen::MatrixXd::Zero(size, size);
    for (std::size_t i = 0; i < g.size(); ++i) {
      const auto oi = static_cast<Eigen::Index>(6 * i);
      big.block<6, 6>(oi, oi) = gram[g[i]];
      for (std::size_t j = 0; j < g.size(); ++j) {
        const auto it = cross.find({g[i], g[j]});
        if (i != j && it != cross.end())
          big.block<6, 6>(oi, static_cast<Eigen::Index>(6 * j)) = it->second;
      }
    }
    groupInverse_.push_back(pseudoInverse(big));
  }
}

std::vector<Eigen::Matrix<double, 6, 1>> RigidModes::coefficients(
    const std::vector<Vec3d>& r) const {
  const std::size_t rows = piece_.size();
  std::vector<Vector6d> load(pieceCount_, Vector6d::Zero());
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t k = 0; k < 6; ++k)
      load[piece_[i]][static_cast<Eigen::Index>(k)] += modes_[k][i].dot(r[i]);
  std::vector<Vector6d> coefficient(pieceCount_);
  for (std::size_t p = 0; p < pieceCount_; ++p)
    coefficient[p] = load[p].allFinite() ? Vector6d(inverse_[p] * load[p]) : Vector6d::Zero();
  for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
    const std::vector<std::uint32_t>& g = groups_[gi];
    Eigen::VectorXd stacked(static_cast<Eigen::Index>(6 * g.size()));
    for (std::size_t i = 0; i < g.size(); ++i)
      stacked.segment<6>(static_cast<Eigen::Index>(6 * i)) = load[g[i]];
    Eigen::VectorXd c = Eigen::VectorXd::Zero(stacked.size());
    if (stacked.allFinite()) c = groupInverse_[gi] * stacked;
    for (std::size_t i = 0; i < g.size(); ++i)
      coefficient[g[i]] = c.segment<6>(static_cast<Eigen::Index>(6 * i));
  }
  return coefficient;
}

void RigidModes::coarseCorrection(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) const {
  const std::vector<Vector6d> coefficient = coefficients(r);
  for (std::size_t i = 0; i < piece_.size(); ++i) {
    const Vector6d& c = coefficient[piece_[i]];
    for (std::size_t k = 0; k < 6; ++k) z[i] += c[static_cast<Eigen::Index>(k)] * modes_[k][i];
  }
}

void RigidModes::correct(std::vector<Vec3d>& x, std::vector<Vec3d>& r) const {
  const std::size_t rows = piece_.size();
  VOXCUT_ASSERT(x.size() == rows && r.size() == rows && inverse_.size() == pieceCount_,
                "one value per free node, after setOperator");
  const std::vector<Vector6d> coefficient = coefficients(r);
  std::vector<Vec3d> zc(coupling_ != nullptr ? rows : 0, Vec3d::Zero());
  for (std::size_t i = 0; i < rows; ++i) {
    const Vector6d& c = coefficient[piece_[i]];
    for (std::size_t k = 0; k < 6; ++k) {
      x[i] += c[static_cast<Eigen::Index>(k)] * modes_[k][i];
      r[i] -= c[static_cast<Eigen::Index>(k)] * products_[k][i];
      if (coupling_ != nullptr) zc[i] += c[static_cast<Eigen::Index>(k)] * modes_[k][i];
    }
  }
  if (coupling_ != nullptr) coupling_->multiplySubtract(zc, r);  // r -= X Z c
}

}  // namespace voxcut
