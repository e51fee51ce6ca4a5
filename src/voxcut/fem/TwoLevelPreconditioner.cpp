#include "voxcut/fem/TwoLevelPreconditioner.h"

#include <algorithm>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/fem/BlockPreconditioner.h"
#include "voxcut/fem/ElasticModel.h"

namespace voxcut {

NodeAggregation aggregateNodes(const BlockSparsity& sp) {
  const std::size_t rows = sp.diagonal.size();
  constexpr std::uint32_t kNone = 0xffffffffu;
  NodeAggregation out;
  out.aggregate.assign(rows, kNone);
  std::uint32_t count = 0;
  // First pass: roots whose whole 1-ring is still free take it.
  for (std::size_t i = 0; i < rows; ++i) {
    bool free = true;
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1] && free; ++s)
      free = out.aggregate[sp.column[s]] == kNone;
    if (!free) continue;
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s)
      out.aggregate[sp.column[s]] = count;
    ++count;
  }
  // Second pass: the rest join their first neighbour's first-pass aggregate. Every such row
  // has one: it was not a root because a neighbour was already taken.
  std::vector<std::uint32_t> first = out.aggregate;
  for (std::size_t i = 0; i < rows; ++i) {
    if (first[i] != kNone) continue;
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s)
      if (first[sp.column[s]] != kNone) {
        out.aggregate[i] = first[sp.column[s]];
        break;
      }
    VOXCUT_ASSERT(out.aggregate[i] != kNone, "a row without an aggregated neighbour");
  }
  // Members by aggregate, rows ascending (counting sort).
  out.start.assign(count + 1, 0);
  for (std::uint32_t a : out.aggregate) ++out.start[a + 1];
  for (std::uint32_t a = 0; a < count; ++a) out.start[a + 1] += out.start[a];
  out.member.resize(rows);
  std::vector<std::uint32_t> next(out.start.begin(), out.start.end() - 1);
  for (std::size_t i = 0; i < rows; ++i)
    out.member[next[out.aggregate[i]]++] = static_cast<std::uint32_t>(i);
  // Row-to-aggregate links: the distinct aggregates of each row's columns, ascending.
  out.slotLink.resize(sp.blockCount());
  std::vector<std::uint32_t> reached;
  for (std::size_t i = 0; i < rows; ++i) {
    reached.clear();
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s)
      reached.push_back(out.aggregate[sp.column[s]]);
    std::sort(reached.begin(), reached.end());
    reached.erase(std::unique(reached.begin(), reached.end()), reached.end());
    const auto base = static_cast<std::uint32_t>(out.linkAggregate.size());
    out.linkAggregate.insert(out.linkAggregate.end(), reached.begin(), reached.end());
    out.linkStart.push_back(static_cast<std::uint32_t>(out.linkAggregate.size()));
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s)
      out.slotLink[s] = base + static_cast<std::uint32_t>(
                                   std::lower_bound(reached.begin(), reached.end(),
                                                    out.aggregate[sp.column[s]]) -
                                   reached.begin());
  }
  return out;
}

bool TwoLevelPreconditioner::setup(const BlockSparsity& sp, const NodeAggregation& agg,
                                   const std::vector<Eigen::Matrix3d>& blocks, bool threaded) {
  VOXCUT_ASSERT(blocks.size() == sp.blockCount() && agg.aggregate.size() == sp.diagonal.size(),
                "the blocks or the aggregation do not match the sparsity");
  const auto n = static_cast<Eigen::Index>(3 * agg.count());
  // B_iJ: each row's blocks summed per aggregate, slots in ascending order.
  link_.resize(agg.linkAggregate.size());
  parallelFor(
      0, sp.diagonal.size(), 128,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          for (std::uint32_t k = agg.linkStart[i]; k < agg.linkStart[i + 1]; ++k)
            link_[k].setZero();
          for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s)
            link_[agg.slotLink[s]] += blocks[s];
        }
      },
      threaded);
  // A_c(I, J) = sum of B_iJ over the members i of I, ascending; row blocks of I are written
  // by I's task alone.
  coarse_.setZero(n, n);
  parallelFor(
      0, agg.count(), 4,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t a = b; a < e; ++a)
          for (std::uint32_t m = agg.start[a]; m < agg.start[a + 1]; ++m) {
            const std::uint32_t i = agg.member[m];
            for (std::uint32_t k = agg.linkStart[i]; k < agg.linkStart[i + 1]; ++k)
              coarse_.block<3, 3>(static_cast<Eigen::Index>(3 * a),
                                  3 * static_cast<Eigen::Index>(agg.linkAggregate[k])) += link_[k];
          }
      },
      threaded);
  factor_.compute(coarse_);
  valid_ = n > 0 && factor_.info() == Eigen::Success;
  return valid_;
}

void TwoLevelPreconditioner::apply(const BlockSparsity& sp, const NodeAggregation& agg,
                                   const std::vector<Eigen::Matrix3d>& blocks,
                                   const std::vector<Eigen::Matrix3d>& diagonalInverse,
                                   const std::vector<Vec3d>& r, std::vector<Vec3d>& z,
                                   bool threaded) {
  const std::size_t rows = sp.diagonal.size();
  z.resize(rows);
  u_.resize(rows);
  t_.resize(rows);
  const Eigen::Matrix3d* a = blocks.data();
  const std::uint32_t* column = sp.column.data();
  if (!valid_) {
    applySymmetricGaussSeidel(sp, blocks, diagonalInverse, r, z);
    return;
  }
  // u = (D + L)^-1 r.
  for (std::size_t i = 0; i < rows; ++i)
    u_[i] = diagonalInverse[i] *
            (r[i] - blockRowProduct(a, column, u_.data(), sp.rowStart[i], sp.diagonal[i]));
  // t = r - A u = -U u (the forward sweep solved (D + L) u = r exactly).
  parallelFor(
      0, rows, 256,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i)
          t_[i] = -blockRowProduct(a, column, u_.data(), sp.diagonal[i] + 1, sp.rowStart[i + 1]);
      },
      threaded);
  // Coarse correction c = T A_c^-1 T^T t.
  coarseRhs_.resize(coarse_.rows());
  parallelFor(
      0, agg.count(), 16,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t g = b; g < e; ++g) {
          Vec3d s = Vec3d::Zero();
          for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m) s += t_[agg.member[m]];
          coarseRhs_.segment<3>(static_cast<Eigen::Index>(3 * g)) = s;
        }
      },
      threaded);
  coarseSolution_.resize(agg.count());
  if (!coarseSolution_.empty())
    Eigen::Map<Eigen::VectorXd>(coarseSolution_[0].data(), coarse_.rows()) =
        factor_.solve(coarseRhs_);
  // u += c and t -= A c (A c = sum_J B_iJ c_J): t is again r - A u.
  const Vec3d* c = coarseSolution_.data();
  parallelFor(
      0, rows, 256,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          t_[i] -= blockRowProduct(link_.data(), agg.linkAggregate.data(), c, agg.linkStart[i],
                                   agg.linkStart[i + 1]);
          u_[i] += c[agg.aggregate[i]];
        }
      },
      threaded);
  // Backward sweep on the correction: (D + U) d = t (d overwrites t, row by row), z = u + d.
  for (std::size_t i = rows; i-- > 0;) {
    t_[i] = diagonalInverse[i] *
            (t_[i] - blockRowProduct(a, column, t_.data(), sp.diagonal[i] + 1, sp.rowStart[i + 1]));
    z[i] = u_[i] + t_[i];
  }
}

}  // namespace voxcut
