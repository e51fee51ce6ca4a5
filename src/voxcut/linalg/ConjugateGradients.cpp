#include "voxcut/linalg/ConjugateGradients.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/linalg/ChunkedSum.h"

namespace voxcut {

double ConjugateGradients::precondition(const std::vector<Vec3d>& r) {
  m_->apply(r, z_);
  return chunkedSum(a_.rows, partial_, threaded_, [&](std::size_t i) { return r[i].dot(z_[i]); });
}

std::optional<ConjugateGradientStatus> ConjugateGradients::trivialSolve(double bb,
                                                                        std::vector<Vec3d>& x) {
  ConjugateGradientStatus status;
  if (!std::isfinite(bb)) {
    status.finite = false;
    return status;
  }
  if (bb == 0.0) {
    std::fill(x.begin(), x.end(), Vec3d::Zero());
    status.converged = true;
    return status;
  }
  return std::nullopt;
}

ConjugateGradientStatus ConjugateGradients::mult(const std::vector<Vec3d>& b,
                                                 std::vector<Vec3d>& x) {
  const std::size_t rows = a_.rows;
  VOXCUT_ASSERT(b.size() == rows && x.size() == rows, "b and x must have one row per block row");
  const double bb =
      chunkedSum(rows, partial_, threaded_, [&](std::size_t i) { return b[i].squaredNorm(); });
  if (const std::optional<ConjugateGradientStatus> trivial = trivialSolve(bb, x)) return *trivial;
  r_.resize(rows);
  parallelFor(
      0, rows, 256,
      [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) r_[i] = b[i] - blockRowProduct(a_, x.data(), i);
      },
      threaded_);
  if (coupling_ != nullptr) coupling_->multiplySubtract(x, r_, threaded_);
  return iterate(bb, x, r_);
}

ConjugateGradientStatus ConjugateGradients::iterate(double bb, std::vector<Vec3d>& x,
                                                    std::vector<Vec3d>& r) {
  const std::size_t rows = a_.rows;
  VOXCUT_ASSERT(m_ != nullptr, "ConjugateGradients: setPreconditioner first");
  VOXCUT_ASSERT(x.size() == rows && r.size() == rows, "x and r must have one row per block row");
  const bool threaded = threaded_;
  const Eigen::Matrix3d* blocks = a_.blocks;
  const std::uint32_t* column = a_.column;
  const std::uint32_t* rowStart = a_.rowStart;
  // Row i of A x: most of the solve.
  auto multiply = [&](const std::vector<Vec3d>& in, std::size_t i) {
    return blockRowProduct(blocks, column, in.data(), rowStart[i], rowStart[i + 1]);
  };
  // A row-by-row preconditioner is fused into the vector updates; one that couples rows runs
  // as a pass of its own after them.
  const Eigen::Matrix3d* rowBlocks = m_->rowBlocks();
  const bool pointwise = rowBlocks != nullptr;
  z_.resize(rows);
  p_.resize(rows);
  q_.resize(rows);

  ConjugateGradientStatus status;
  const double stop = params_.tolerance * params_.tolerance * bb;
  auto [rz, rr] = chunkedSum2(rows, partial_, partial2_, threaded, [&](std::size_t i) {
    if (!pointwise) return std::pair{0.0, r[i].squaredNorm()};
    z_[i] = rowBlocks[i] * r[i];
    return std::pair{r[i].dot(z_[i]), r[i].squaredNorm()};
  });
  bool finite = std::isfinite(rr);
  if (finite && rr > stop && status.iterations < params_.maxIterations && !pointwise) {
    if (!m_->setOperator(a_, threaded)) {
      status.preconditioned = false;
      status.residual = std::sqrt(rr / bb);
      return status;
    }
    rz = precondition(r);
  }
  finite = finite && std::isfinite(rz);
  std::copy(z_.begin(), z_.end(), p_.begin());
  const bool coupled = coupling_ != nullptr && !coupling_->empty();
  while (finite && rr > stop && status.iterations < params_.maxIterations) {
    double pq = 0.0;
    if (coupled) {  // the block product, then the couplings', then (p, q)
      parallelFor(
          0, rows, 256,
          [&](std::size_t b, std::size_t e) {
            for (std::size_t i = b; i < e; ++i) q_[i] = multiply(p_, i);
          },
          threaded);
      coupling_->multiplyAdd(p_, q_, threaded);
      pq = chunkedSum(rows, partial_, threaded, [&](std::size_t i) { return p_[i].dot(q_[i]); });
    } else {
      pq = chunkedSum(rows, partial_, threaded, [&](std::size_t i) {
        q_[i] = multiply(p_, i);
        return p_[i].dot(q_[i]);
      });
    }
    const double alpha = rz / pq;
    if (!std::isfinite(alpha)) {
      finite = std::isfinite(pq);
      break;  // pq == 0 (breakdown) or a non-finite value
    }
    auto [rzNew, rrNew] = chunkedSum2(rows, partial_, partial2_, threaded, [&](std::size_t i) {
      x[i] += alpha * p_[i];
      r[i] -= alpha * q_[i];
      if (!pointwise) return std::pair{0.0, r[i].squaredNorm()};
      z_[i] = rowBlocks[i] * r[i];
      return std::pair{r[i].dot(z_[i]), r[i].squaredNorm()};
    });
    ++status.iterations;
    rr = rrNew;
    finite = std::isfinite(rr);
    if (!finite || rr <= stop) break;
    if (!pointwise) rzNew = precondition(r);
    finite = std::isfinite(rzNew);
    if (!finite) break;
    const double beta = rzNew / rz;
    rz = rzNew;
    parallelFor(
        0, rows, 256,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t i = b; i < e; ++i) p_[i] = z_[i] + beta * p_[i];
        },
        threaded);
  }
  status.finite = finite;
  status.residual = std::sqrt(rr / bb);
  status.converged = finite && rr <= stop;
  return status;
}

}  // namespace voxcut
