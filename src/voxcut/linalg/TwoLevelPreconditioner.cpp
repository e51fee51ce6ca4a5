#include "voxcut/linalg/TwoLevelPreconditioner.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/linalg/BlockPreconditioner.h"
#include "voxcut/linalg/BlockSparsity.h"

namespace voxcut {

namespace {

/// Merges aggregates in pairs: each aggregate not yet paired, in order, takes the unpaired
/// neighbour aggregate it shares the most blocks with (the lowest id on ties). Returns the
/// new count; `aggregate` is relabelled in order of first appearance of each pair.
std::uint32_t pairAggregates(const BlockSparsity& sp, std::vector<std::uint32_t>& aggregate,
                             std::uint32_t count) {
  constexpr std::uint32_t kNone = 0xffffffffu;
  // Couplings between aggregates: per I, (J, blocks between them), J in order of first meeting.
  std::vector<std::vector<std::uint32_t>> members(count);
  for (std::size_t i = 0; i < aggregate.size(); ++i)
    members[aggregate[i]].push_back(static_cast<std::uint32_t>(i));
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> couple(count);
  std::vector<std::uint32_t> seenBy(count, kNone), at(count, 0);
  for (std::uint32_t a = 0; a < count; ++a)
    for (std::uint32_t i : members[a])
      for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s) {
        const std::uint32_t b = aggregate[sp.column[s]];
        if (a == b) continue;
        if (seenBy[b] != a) {
          seenBy[b] = a;
          at[b] = static_cast<std::uint32_t>(couple[a].size());
          couple[a].emplace_back(b, 0u);
        }
        ++couple[a][at[b]].second;
      }
  std::vector<std::uint32_t> relabel(count, kNone);
  std::uint32_t next = 0;
  for (std::uint32_t a = 0; a < count; ++a) {
    if (relabel[a] != kNone) continue;
    std::uint32_t best = kNone, weight = 0;
    for (const auto& [b, w] : couple[a])
      if (relabel[b] == kNone && (w > weight || (w == weight && b < best))) {
        best = b;
        weight = w;
      }
    relabel[a] = next;
    if (best != kNone) relabel[best] = next;
    ++next;
  }
  for (std::uint32_t& a : aggregate) a = relabel[a];
  return next;
}

using LinkBlock = Eigen::Matrix<double, 3, 6>;
/// Per aggregate I, its blocks A_c(I, J) for J <= I, per neighbour J in the order first
/// reached.
using CoarseRows = std::vector<std::vector<std::pair<std::uint32_t, Eigen::Matrix<double, 6, 6>>>>;

/// Modes of each aggregate: translations, and rotations about its centroid (offsets scaled
/// by its RMS radius) where it has positions that are not all on one line. Writes each row's
/// scaled offset and each aggregate's first coarse column.
void aggregateModes(const NodeAggregation& agg, const std::vector<Vec3d>* positions,
                    std::vector<Vec3d>& offset, std::vector<std::uint32_t>& columnStart) {
  offset.assign(agg.aggregate.size(), Vec3d::Zero());
  columnStart.assign(agg.count() + 1, 0);
  for (std::size_t g = 0; g < agg.count(); ++g) {
    int modes = 3;
    if (positions != nullptr && agg.start[g + 1] - agg.start[g] >= 3) {
      Vec3d centre = Vec3d::Zero();
      for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m)
        centre += (*positions)[agg.member[m]];
      centre /= static_cast<double>(agg.start[g + 1] - agg.start[g]);
      Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();
      for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m) {
        const Vec3d d = (*positions)[agg.member[m]] - centre;
        moment += d * d.transpose();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(moment, Eigen::EigenvaluesOnly);
      const Vec3d lambda = eig.eigenvalues();  // ascending
      if (lambda(2) > 0.0 && lambda(1) > 1e-3 * lambda(2)) {
        modes = 6;
        const double radius = std::sqrt(moment.trace() / (agg.start[g + 1] - agg.start[g]));
        for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m)
          offset[agg.member[m]] = ((*positions)[agg.member[m]] - centre) / radius;
      }
    }
    columnStart[g + 1] = columnStart[g] + static_cast<std::uint32_t>(modes);
  }
}

/// B_iJ = sum over the slots of row i reaching J of A_ij T_j, slots in ascending order, per
/// row-to-aggregate link.
void linkBlocks(const BlockSparsity& sp, const NodeAggregation& agg,
                const std::vector<Eigen::Matrix3d>& blocks, const std::vector<Vec3d>& offset,
                std::vector<LinkBlock>& link, bool threaded) {
  link.resize(agg.linkAggregate.size());
  parallelFor(
      0, sp.diagonal.size(), 128,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          for (std::uint32_t k = agg.linkStart[i]; k < agg.linkStart[i + 1]; ++k)
            link[k].setZero();
          for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s) {
            LinkBlock& out = link[agg.slotLink[s]];
            const Eigen::Matrix3d& a = blocks[s];
            out.leftCols<3>() += a;
            // A S_j with S = -[d]x = [[0, dz, -dy], [-dz, 0, dx], [dy, -dx, 0]] (T_j = [I, S_j]
            // maps (t, w) to t + w x d_j), written out: S's zeros cost nothing.
            const Vec3d& d = offset[sp.column[s]];
            out.col(3) += a.col(1) * (-d.z()) + a.col(2) * d.y();
            out.col(4) += a.col(0) * d.z() + a.col(2) * (-d.x());
            out.col(5) += a.col(0) * (-d.y()) + a.col(1) * d.x();
          }
        }
      },
      threaded);
}

/// A_c(I, J) = sum over the members i of I, ascending, of T_i^T B_iJ, per aggregate I in its
/// own task, lower triangle only.
CoarseRows coarseRows(const NodeAggregation& agg, const std::vector<Vec3d>& offset,
                      const std::vector<LinkBlock>& link, bool threaded) {
  CoarseRows rowBlocks(agg.count());
  parallelFor(
      0, agg.count(), 4,
      [&](std::size_t b, std::size_t e) {
        std::vector<std::int32_t> slot(agg.count(), -1);
        for (std::size_t a = b; a < e; ++a) {
          auto& out = rowBlocks[a];
          for (std::uint32_t m = agg.start[a]; m < agg.start[a + 1]; ++m) {
            const std::uint32_t i = agg.member[m];
            const Vec3d& d = offset[i];
            for (std::uint32_t k = agg.linkStart[i]; k < agg.linkStart[i + 1]; ++k) {
              const std::uint32_t j = agg.linkAggregate[k];
              if (j > a) continue;  // the lower triangle is enough
              if (slot[j] < 0) {
                slot[j] = static_cast<std::int32_t>(out.size());
                out.emplace_back(j, Eigen::Matrix<double, 6, 6>::Zero());
              }
              Eigen::Matrix<double, 6, 6>& block = out[static_cast<std::size_t>(slot[j])].second;
              const LinkBlock& l = link[k];
              block.topRows<3>() += l;
              // S_i^T B_iJ, written out.
              block.row(3) += (-d.z()) * l.row(1) + d.y() * l.row(2);
              block.row(4) += d.z() * l.row(0) + (-d.x()) * l.row(2);
              block.row(5) += (-d.y()) * l.row(0) + d.x() * l.row(1);
            }
          }
          for (const auto& entry : out) slot[entry.first] = -1;
        }
      },
      threaded);
  return rowBlocks;
}

}  // namespace

NodeAggregation aggregateNodes(const BlockSparsity& sp, int pairings) {
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
  for (int k = 0; k < pairings; ++k) count = pairAggregates(sp, out.aggregate, count);
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
  std::vector<std::uint32_t> reached, seenBy(count, kNone), position(count, 0);
  for (std::size_t i = 0; i < rows; ++i) {
    reached.clear();
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s) {
      const std::uint32_t g = out.aggregate[sp.column[s]];
      if (seenBy[g] != i) {
        seenBy[g] = static_cast<std::uint32_t>(i);
        reached.push_back(g);
      }
    }
    std::sort(reached.begin(), reached.end());
    const auto base = static_cast<std::uint32_t>(out.linkAggregate.size());
    for (std::size_t k = 0; k < reached.size(); ++k)
      position[reached[k]] = base + static_cast<std::uint32_t>(k);
    out.linkAggregate.insert(out.linkAggregate.end(), reached.begin(), reached.end());
    out.linkStart.push_back(static_cast<std::uint32_t>(out.linkAggregate.size()));
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s)
      out.slotLink[s] = position[out.aggregate[sp.column[s]]];
  }
  return out;
}

TwoLevelPreconditioner::TwoLevelPreconditioner(const TwoLevelPreconditioner& other)
    : link_(other.link_),
      offset_(other.offset_),
      columnStart_(other.columnStart_),
      coarse_(other.coarse_),
      patternOuter_(other.patternOuter_),
      patternInner_(other.patternInner_),
      valid_(other.valid_),
      u_(other.u_),
      t_(other.t_),
      coarseRhs_(other.coarseRhs_),
      coarseSolution_(other.coarseSolution_) {
  if (other.factor_) {
    factor_ = std::make_unique<Factor>();
    factor_->analyzePattern(coarse_);
    factor_->factorize(coarse_);
  }
}

TwoLevelPreconditioner& TwoLevelPreconditioner::operator=(const TwoLevelPreconditioner& other) {
  if (this != &other) *this = TwoLevelPreconditioner(other);
  return *this;
}

TwoLevelPreconditioner::~TwoLevelPreconditioner() = default;

bool TwoLevelPreconditioner::setup(const BlockSparsity& sp, const NodeAggregation& agg,
                                   const std::vector<Eigen::Matrix3d>& blocks,
                                   const std::vector<Vec3d>* positions, bool threaded) {
  const std::size_t rows = sp.diagonal.size();
  VOXCUT_ASSERT(blocks.size() == sp.blockCount() && agg.aggregate.size() == rows &&
                    (positions == nullptr || positions->size() == rows),
                "the blocks, positions or aggregation do not match the sparsity");
  aggregateModes(agg, positions, offset_, columnStart_);
  const auto n = static_cast<Eigen::Index>(columnStart_.back());
  linkBlocks(sp, agg, blocks, offset_, link_, threaded);
  const CoarseRows rowBlocks = coarseRows(agg, offset_, link_, threaded);
  // The lower triangle as a sparse matrix; factorised by a sparse Cholesky (fill-reducing
  // ordering): a cut multiplies the aggregates, and a dense factor grows with their cube.
  coarseTriplets_.clear();
  for (std::size_t a = 0; a < agg.count(); ++a) {
    const Eigen::Index row = columnStart_[a], rowsI = columnStart_[a + 1] - row;
    for (const auto& [j, block] : rowBlocks[a]) {
      const Eigen::Index col = columnStart_[j], colsJ = columnStart_[j + 1] - col;
      for (Eigen::Index p = 0; p < rowsI; ++p)
        for (Eigen::Index q = 0; q < colsJ && col + q <= row + p; ++q)
          coarseTriplets_.emplace_back(row + p, col + q, block(p, q));
    }
  }
  coarse_.resize(n, n);
  coarse_.setFromTriplets(coarseTriplets_.begin(), coarseTriplets_.end());
  if (n == 0) {  // nothing free: no coarse system
    factor_.reset();
    valid_ = false;
    return valid_;
  }
  // The ordering and symbolic factor only change with the pattern (topology, or an
  // aggregate gaining or losing its rotations).
  const bool samePattern =
      factor_ && patternOuter_.size() == static_cast<std::size_t>(n) + 1 &&
      std::equal(patternOuter_.begin(), patternOuter_.end(), coarse_.outerIndexPtr()) &&
      patternInner_.size() == static_cast<std::size_t>(coarse_.nonZeros()) &&
      std::equal(patternInner_.begin(), patternInner_.end(), coarse_.innerIndexPtr());
  if (!samePattern) {
    factor_ = std::make_unique<Factor>();
    factor_->analyzePattern(coarse_);
    patternOuter_.assign(coarse_.outerIndexPtr(), coarse_.outerIndexPtr() + n + 1);
    patternInner_.assign(coarse_.innerIndexPtr(), coarse_.innerIndexPtr() + coarse_.nonZeros());
  }
  factor_->factorize(coarse_);
  valid_ = factor_->info() == Eigen::Success;
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
  // Coarse correction c = T A_c^-1 T^T t, with (T^T t)_I = sum over i in I of (t_i, d_i x t_i).
  coarseRhs_.resize(coarse_.rows());
  parallelFor(
      0, agg.count(), 16,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t g = b; g < e; ++g) {
          Vec3d force = Vec3d::Zero(), torque = Vec3d::Zero();
          for (std::uint32_t m = agg.start[g]; m < agg.start[g + 1]; ++m) {
            const std::uint32_t i = agg.member[m];
            force += t_[i];
            torque += offset_[i].cross(t_[i]);
          }
          const auto col = static_cast<Eigen::Index>(columnStart_[g]);
          coarseRhs_.segment<3>(col) = force;
          if (columnStart_[g + 1] - columnStart_[g] == 6) coarseRhs_.segment<3>(col + 3) = torque;
        }
      },
      threaded);
  const Eigen::VectorXd solution = factor_->solve(coarseRhs_);
  coarseSolution_.resize(agg.count());
  for (std::size_t g = 0; g < agg.count(); ++g) {
    const auto col = static_cast<Eigen::Index>(columnStart_[g]);
    coarseSolution_[g].head<3>() = solution.segment<3>(col);
    if (columnStart_[g + 1] - columnStart_[g] == 6)
      coarseSolution_[g].tail<3>() = solution.segment<3>(col + 3);
    else
      coarseSolution_[g].tail<3>().setZero();
  }
  // u += c (c_i = t_J + w_J x d_i) and t -= A c (A c = sum_J B_iJ (t_J, w_J)): t is again
  // r - A u.
  parallelFor(
      0, rows, 256,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          Vec3d ac = Vec3d::Zero();
          for (std::uint32_t k = agg.linkStart[i]; k < agg.linkStart[i + 1]; ++k)
            ac.noalias() += link_[k] * coarseSolution_[agg.linkAggregate[k]];
          t_[i] -= ac;
          const Mode& mode = coarseSolution_[agg.aggregate[i]];
          u_[i] += mode.head<3>() + mode.tail<3>().cross(offset_[i]);
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

double TwoLevelPreconditioner::coarseFactorEntries() const {
  if (!factor_ || !valid_) return 0.0;
  return static_cast<double>(factor_->matrixL().nestedExpression().nonZeros());
}

}  // namespace voxcut
