#include "voxcut/linalg/SolutionProjection.h"

#include <Eigen/Eigenvalues>
#include <algorithm>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/linalg/ChunkedSum.h"

namespace voxcut {

void SolutionProjection::setCapacity(std::size_t capacity) {
  if (capacity == capacity_) return;
  // Keep the newest min(kept, capacity) solutions, newest first, in a fresh ring.
  std::vector<std::vector<Vec3d>> kept;
  const std::size_t keep = std::min(kept_, capacity);
  for (std::size_t k = 0; k < keep; ++k)
    kept.push_back(std::move(slots_[(newest_ + slots_.size() - k) % slots_.size()]));
  slots_.assign(capacity, {});
  for (std::size_t k = 0; k < keep; ++k) slots_[keep - 1 - k] = std::move(kept[k]);
  capacity_ = capacity;
  kept_ = keep;
  newest_ = keep > 0 ? keep - 1 : 0;
}

void SolutionProjection::add(const std::vector<Vec3d>& x) {
  if (capacity_ == 0) return;
  if (slots_.size() != capacity_) slots_.resize(capacity_);
  if (kept_ > 0 && slots_[newest_].size() != x.size()) kept_ = 0;
  newest_ = kept_ == 0 ? 0 : (newest_ + 1) % capacity_;
  slots_[newest_] = x;
  kept_ = std::min(kept_ + 1, capacity_);
}

bool SolutionProjection::project(const BlockMatrixView& a, const std::vector<Vec3d>& b,
                                 std::vector<Vec3d>& x, bool threaded,
                                 const RowCoupling* coupling) {
  const std::size_t k = kept_, rows = a.rows;
  if (k == 0) return false;
  VOXCUT_ASSERT(b.size() == rows && slots_[newest_].size() == rows,
                "the kept solutions do not match the matrix");
  // The kept solutions, newest first, and A times each (one pass over A's rows for all).
  std::vector<const Vec3d*> w(k);
  for (std::size_t j = 0; j < k; ++j) w[j] = slots_[(newest_ + capacity_ - j) % capacity_].data();
  product_.resize(k);
  for (auto& p : product_) p.resize(rows);
  parallelFor(
      0, rows, 256,
      [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i)
          for (std::size_t j = 0; j < k; ++j) product_[j][i] = blockRowProduct(a, w[j], i);
      },
      threaded);
  if (coupling != nullptr && !coupling->empty()) {
    std::vector<Vec3d> column(rows);
    for (std::size_t j = 0; j < k; ++j) {
      std::copy(w[j], w[j] + rows, column.begin());
      coupling->multiplyAdd(column, product_[j], threaded);
    }
  }
  // W^T A W (upper triangle) and W^T b, each summed in fixed chunks.
  const std::size_t sums = k * (k + 1) / 2 + k;
  const std::vector<double> total =
      chunkedSums(rows, sums, partial_, threaded, [&](std::size_t i, double* out) {
        std::size_t m = 0;
        for (std::size_t p = 0; p < k; ++p) {
          for (std::size_t q = p; q < k; ++q) out[m++] += w[p][i].dot(product_[q][i]);
          out[m++] += w[p][i].dot(b[i]);
        }
      });
  Eigen::MatrixXd g(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(k));
  Eigen::VectorXd wb(static_cast<Eigen::Index>(k));
  std::size_t m = 0;
  for (std::size_t p = 0; p < k; ++p) {
    const auto ip = static_cast<Eigen::Index>(p);
    for (std::size_t q = p; q < k; ++q) {
      const auto iq = static_cast<Eigen::Index>(q);
      g(ip, iq) = g(iq, ip) = total[m++];
    }
    wb[ip] = total[m++];
  }
  if (!g.allFinite() || !wb.allFinite()) return false;
  // Pseudo-inverse on the clearly positive eigenvalues: successive solutions of a smooth
  // motion are close to linearly dependent.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(g);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const double largest = lambda.maxCoeff();
  if (!(largest > 0.0)) return false;
  Eigen::VectorXd inverted = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(k));
  for (Eigen::Index j = 0; j < inverted.size(); ++j)
    if (lambda[j] > 1e-12 * largest) inverted[j] = 1.0 / lambda[j];
  const Eigen::VectorXd c =
      eig.eigenvectors() * (inverted.asDiagonal() * (eig.eigenvectors().transpose() * wb));
  if (!c.allFinite()) return false;
  x.resize(rows);
  parallelFor(
      0, rows, 256,
      [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) {
          Vec3d s = Vec3d::Zero();
          for (std::size_t j = 0; j < k; ++j) s += c[static_cast<Eigen::Index>(j)] * w[j][i];
          x[i] = s;
        }
      },
      threaded);
  return true;
}

}  // namespace voxcut
