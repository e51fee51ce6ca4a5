#include "voxcut/linalg/BlockCholesky.h"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/linalg/BlockSparsity.h"

namespace voxcut {

namespace {

constexpr std::uint32_t kNone = 0xffffffffu;

/// Lower Cholesky factor of the symmetric 3x3 `a` (lower triangle read), inverted: returns
/// false when a pivot is not positive (or not finite), which also catches a pivot that lost
/// all but a rounding error of its diagonal entry.
bool invertedPivot(const Eigen::Matrix3d& a, Eigen::Matrix3d& inv) {
  const double eps = 1e-13;
  const double d0 = a(0, 0);
  if (!(d0 > 0.0) || !std::isfinite(d0)) return false;
  const double l00 = std::sqrt(d0);
  const double l10 = a(1, 0) / l00, l20 = a(2, 0) / l00;
  const double d1 = a(1, 1) - l10 * l10;
  if (!(d1 > eps * a(1, 1)) || !std::isfinite(d1)) return false;
  const double l11 = std::sqrt(d1);
  const double l21 = (a(2, 1) - l20 * l10) / l11;
  const double d2 = a(2, 2) - l20 * l20 - l21 * l21;
  if (!(d2 > eps * a(2, 2)) || !std::isfinite(d2)) return false;
  const double l22 = std::sqrt(d2);
  const double m00 = 1.0 / l00, m11 = 1.0 / l11, m22 = 1.0 / l22;
  const double m10 = -l10 * m00 * m11;
  const double m21 = -l21 * m11 * m22;
  const double m20 = -(l20 * m00 + l21 * m10) * m22;
  inv << m00, 0.0, 0.0, m10, m11, 0.0, m20, m21, m22;
  return true;
}

/// w[rows[q]] -= l[q] m^T for q in [0, count): the inner loop of the factorisation, written
/// out with m held in registers.
inline void subtractProducts(const Eigen::Matrix3d* l, const std::uint32_t* rows,
                             std::uint32_t count, const Eigen::Matrix3d& m, Eigen::Matrix3d* w) {
  // (l m^T)(r, c) = sum_t l(r, t) m(c, t); column-major: l(r, t) = l[3 t + r].
  const double* b = m.data();
  const double m00 = b[0], m10 = b[1], m20 = b[2], m01 = b[3], m11 = b[4], m21 = b[5], m02 = b[6],
               m12 = b[7], m22 = b[8];
  for (std::uint32_t q = 0; q < count; ++q) {
    const double* a = l[q].data();
    double* o = w[rows[q]].data();
    for (int r = 0; r < 3; ++r) {
      const double a0 = a[r], a1 = a[3 + r], a2 = a[6 + r];
      o[r] -= a0 * m00 + a1 * m01 + a2 * m02;
      o[3 + r] -= a0 * m10 + a1 * m11 + a2 * m12;
      o[6 + r] -= a0 * m20 + a1 * m21 + a2 * m22;
    }
  }
}

}  // namespace

void BlockCholesky::analyse(const BlockSparsity& sp) {
  factorised_ = false;
  const std::size_t n = sp.rowStart.size() - 1;
  // 1. Ordering on the node graph.
  perm_.resize(n);
  inverse_.resize(n);
  if (n > 0) {
    std::vector<Eigen::Triplet<double, int>> entries;
    entries.reserve(sp.blockCount());
    for (std::size_t i = 0; i < n; ++i)
      for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s)
        entries.emplace_back(static_cast<int>(i), static_cast<int>(sp.column[s]), 1.0);
    Eigen::SparseMatrix<double, Eigen::ColMajor, int> pattern(static_cast<int>(n),
                                                              static_cast<int>(n));
    pattern.setFromTriplets(entries.begin(), entries.end());
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> order;
    Eigen::AMDOrdering<int>()(pattern, order);
    // order.indices()[new] is the old index (Eigen's SimplicialCholesky reads it so).
    for (std::size_t j = 0; j < n; ++j) {
      const auto old = static_cast<std::uint32_t>(order.indices()[static_cast<Eigen::Index>(j)]);
      VOXCUT_ASSERT(old < n, "ordering out of range");
      perm_[j] = old;
      inverse_[old] = static_cast<std::uint32_t>(j);
    }
  }
  // 2. Elimination tree: parent of column k is the first row below k with a block in column
  // k of L. Liu's algorithm over the rows' entries left of the diagonal, ancestors
  // path-compressed.
  std::vector<std::uint32_t> parent(n, kNone), ancestor(n, kNone);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t old = perm_[i];
    for (std::uint32_t s = sp.rowStart[old]; s < sp.rowStart[old + 1]; ++s) {
      std::uint32_t k = inverse_[sp.column[s]];
      while (k < i) {
        const std::uint32_t up = ancestor[k];
        ancestor[k] = static_cast<std::uint32_t>(i);
        if (up == kNone) {
          parent[k] = static_cast<std::uint32_t>(i);
          break;
        }
        k = up;
      }
    }
  }
  // Row i of L has a block in column k exactly for k on the tree paths from each k' < i with
  // A(i, k') != 0 up to i (the row subtree). Count, then fill, visiting rows in order so
  // every column's rows ascend.
  std::vector<std::uint32_t> mark(n, kNone);
  colStart_.assign(n + 1, 0);
  auto walkRow = [&](std::size_t i, auto&& visit) {
    mark[i] = static_cast<std::uint32_t>(i);
    const std::uint32_t old = perm_[i];
    for (std::uint32_t s = sp.rowStart[old]; s < sp.rowStart[old + 1]; ++s) {
      std::uint32_t k = inverse_[sp.column[s]];
      if (k >= i) continue;
      while (mark[k] != i) {
        visit(k);
        mark[k] = static_cast<std::uint32_t>(i);
        k = parent[k];
      }
    }
  };
  for (std::size_t i = 0; i < n; ++i) walkRow(i, [&](std::uint32_t k) { ++colStart_[k + 1]; });
  for (std::size_t j = 0; j < n; ++j) colStart_[j + 1] += colStart_[j];
  row_.resize(colStart_[n]);
  std::vector<std::uint32_t> fill(colStart_.begin(), colStart_.end() - 1);
  std::fill(mark.begin(), mark.end(), kNone);
  for (std::size_t i = 0; i < n; ++i)
    walkRow(i, [&](std::uint32_t k) { row_[fill[k]++] = static_cast<std::uint32_t>(i); });
  // Row lists: for each row j, the blocks (j, k) of L left of the diagonal, k ascending, as
  // positions in their columns. Column j's update reads them in this fixed order.
  rowListStart_.assign(n + 1, 0);
  for (std::uint32_t r : row_) ++rowListStart_[r + 1];
  for (std::size_t j = 0; j < n; ++j) rowListStart_[j + 1] += rowListStart_[j];
  rowListColumn_.resize(row_.size());
  rowListBlock_.resize(row_.size());
  std::copy(rowListStart_.begin(), rowListStart_.end() - 1, fill.begin());
  for (std::size_t k = 0; k < n; ++k)
    for (std::uint32_t q = colStart_[k]; q < colStart_[k + 1]; ++q) {
      const std::uint32_t at = fill[row_[q]]++;
      rowListColumn_[at] = static_cast<std::uint32_t>(k);
      rowListBlock_[at] = q;
    }
  // Cost of each column: the block updates it gathers plus its scaling.
  std::vector<double> subtree(n, 0.0);
  updates_ = 0.0;
  for (std::size_t j = 0; j < n; ++j) {
    double cost = colStart_[j + 1] - colStart_[j];
    for (std::uint32_t at = rowListStart_[j]; at < rowListStart_[j + 1]; ++at)
      cost += colStart_[rowListColumn_[at] + 1] - rowListBlock_[at];
    updates_ += cost;
    subtree[j] += cost;
    if (parent[j] != kNone) subtree[parent[j]] += subtree[j];
  }
  planTasks(parent, subtree);
  lower_.clear();  // the numeric arrays come with the first factorise
  pivotInverse_.clear();
  y_.resize(n);
}

void BlockCholesky::planTasks(const std::vector<std::uint32_t>& parent,
                              const std::vector<double>& subtree) {
  // Split the elimination tree into disjoint subtrees (tasks, factorised in parallel) and the
  // columns above them (factorised after, in order): repeatedly move the root of the costliest
  // subtree to the top and its children into the task set, until no task holds more than an
  // eighth of the work. The split depends only on the structure.
  const std::size_t n = parent.size();
  std::vector<std::uint32_t> childStart(n + 1, 0), child(n);
  for (std::size_t j = 0; j < n; ++j)
    if (parent[j] != kNone) ++childStart[parent[j] + 1];
  for (std::size_t j = 0; j < n; ++j) childStart[j + 1] += childStart[j];
  {
    std::vector<std::uint32_t> at(childStart.begin(), childStart.end() - 1);
    for (std::size_t j = 0; j < n; ++j)
      if (parent[j] != kNone) child[at[parent[j]]++] = static_cast<std::uint32_t>(j);
  }
  double total = 0.0;
  std::vector<std::uint32_t> roots;
  for (std::size_t j = 0; j < n; ++j)
    if (parent[j] == kNone) {
      roots.push_back(static_cast<std::uint32_t>(j));
      total += subtree[j];
    }
  constexpr std::size_t kMaxTasks = 16;     // each needs a workspace of one block per row
  constexpr double kMinParallelWork = 2e4;  // block updates; below this one task does it all
  auto costlier = [&](std::uint32_t a, std::uint32_t b) {
    return subtree[a] < subtree[b] || (subtree[a] == subtree[b] && a > b);
  };
  std::vector<std::uint32_t> heap = roots;  // max-heap of task roots by cost
  std::make_heap(heap.begin(), heap.end(), costlier);
  std::vector<std::uint8_t> top(n, 0);
  if (total >= kMinParallelWork)
    while (!heap.empty() && subtree[heap.front()] > total / 8.0 &&
           heap.size() - 1 + (childStart[heap.front() + 1] - childStart[heap.front()]) <=
               kMaxTasks) {
      std::pop_heap(heap.begin(), heap.end(), costlier);
      const std::uint32_t v = heap.back();
      heap.pop_back();
      top[v] = 1;
      for (std::uint32_t c = childStart[v]; c < childStart[v + 1]; ++c) {
        heap.push_back(child[c]);
        std::push_heap(heap.begin(), heap.end(), costlier);
      }
    }
  // The subtrees, costliest first, go to at most kMaxTasks tasks (each to the least loaded
  // one: many small pieces of a cut body share a few workspaces), and the tasks are ordered
  // costliest first (the scheduler starts the big ones first). A task lists its columns in
  // ascending order; the top columns are ascending too.
  std::sort(heap.begin(), heap.end(),
            [&](std::uint32_t a, std::uint32_t b) { return costlier(b, a); });
  const std::size_t tasks =
      heap.empty() ? 0 : (total < kMinParallelWork ? 1 : std::min(kMaxTasks, heap.size()));
  std::vector<double> load(tasks, 0.0);
  std::vector<std::uint32_t> taskOf(n, kNone);
  for (std::uint32_t root : heap) {
    const auto least =
        static_cast<std::uint32_t>(std::min_element(load.begin(), load.end()) - load.begin());
    taskOf[root] = least;
    load[least] += subtree[root];
  }
  std::vector<std::uint32_t> rank(tasks);  // tasks by load, descending
  for (std::size_t t = 0; t < tasks; ++t) rank[t] = static_cast<std::uint32_t>(t);
  std::stable_sort(rank.begin(), rank.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return load[a] > load[b]; });
  std::vector<std::uint32_t> slot(tasks);
  for (std::size_t t = 0; t < tasks; ++t) slot[rank[t]] = static_cast<std::uint32_t>(t);
  for (std::uint32_t root : heap) taskOf[root] = slot[taskOf[root]];
  for (std::size_t j = n; j-- > 0;)
    if (!top[j] && taskOf[j] == kNone) taskOf[j] = taskOf[parent[j]];
  taskStart_.assign(tasks + 1, 0);
  topColumns_.clear();
  for (std::size_t j = 0; j < n; ++j) {
    if (top[j])
      topColumns_.push_back(static_cast<std::uint32_t>(j));
    else
      ++taskStart_[taskOf[j] + 1];
  }
  for (std::size_t t = 0; t < tasks; ++t) taskStart_[t + 1] += taskStart_[t];
  taskColumns_.resize(taskStart_.back());
  std::vector<std::uint32_t> at(taskStart_.begin(), taskStart_.end() - 1);
  for (std::size_t j = 0; j < n; ++j)
    if (!top[j]) taskColumns_[at[taskOf[j]]++] = static_cast<std::uint32_t>(j);
  work_.clear();  // allocated by the first factorise
}

bool BlockCholesky::factorColumn(const BlockSparsity& sp,
                                 const std::vector<Eigen::Matrix3d>& blocks, std::uint32_t j,
                                 Eigen::Matrix3d* work) {
  // Column j of A on and below the diagonal: A(i, j) = A_(perm i, perm j) is the transpose of
  // the block at row perm j, column perm i.
  const std::uint32_t old = perm_[j];
  for (std::uint32_t s = sp.rowStart[old]; s < sp.rowStart[old + 1]; ++s) {
    const std::uint32_t i = inverse_[sp.column[s]];
    if (i >= j) work[i] = blocks[s].transpose();
  }
  // Subtract L(j:n, k) L(j, k)^T for each earlier column k with a block in row j.
  for (std::uint32_t at = rowListStart_[j]; at < rowListStart_[j + 1]; ++at) {
    const std::uint32_t k = rowListColumn_[at], q = rowListBlock_[at];
    subtractProducts(&lower_[q], &row_[q], colStart_[k + 1] - q, lower_[q], work);
  }
  Eigen::Matrix3d inv = Eigen::Matrix3d::Zero();
  const bool positive = invertedPivot(work[j], inv);
  pivotInverse_[j] = inv;
  work[j].setZero();
  const Eigen::Matrix3d invT = inv.transpose();
  for (std::uint32_t q = colStart_[j]; q < colStart_[j + 1]; ++q) {
    Eigen::Matrix3d& w = work[row_[q]];
    if (positive) lower_[q].noalias() = w * invT;
    w.setZero();
  }
  // Every block this column touched lies in its pattern (the fill of L), so the workspace is
  // all zero again here.
  return positive;
}

bool BlockCholesky::factorise(const BlockSparsity& sp, const std::vector<Eigen::Matrix3d>& blocks,
                              bool threaded) {
  const std::size_t n = perm_.size();
  VOXCUT_ASSERT(sp.rowStart.size() == n + 1 && blocks.size() == sp.blockCount(),
                "the factor was analysed for another sparsity");
  factorised_ = false;
  lower_.resize(row_.size());
  pivotInverse_.resize(n);
  if (work_.empty())
    work_.assign(std::max<std::size_t>(taskStart_.size() - 1, 1),
                 std::vector<Eigen::Matrix3d>(n, Eigen::Matrix3d::Zero()));
  // A column reads only the finished columns of its own subtree, and writes only itself and
  // its task's workspace: the tasks run in parallel, each column computed the same way
  // whichever thread runs it.
  const std::size_t tasks = taskStart_.size() - 1;
  std::vector<std::uint8_t> failed(tasks, 0);
  parallelFor(
      0, tasks, 1,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t t = b; t < e; ++t)
          for (std::uint32_t c = taskStart_[t]; c < taskStart_[t + 1] && !failed[t]; ++c)
            failed[t] = factorColumn(sp, blocks, taskColumns_[c], work_[t].data()) ? 0 : 1;
      },
      threaded);
  for (std::uint8_t f : failed)
    if (f) return false;
  for (std::uint32_t j : topColumns_)
    if (!factorColumn(sp, blocks, j, work_[0].data())) return false;
  factorised_ = true;
  return true;
}

void BlockCholesky::solve(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) {
  VOXCUT_ASSERT(factorised_ && r.size() == perm_.size(), "no factor for this right-hand side");
  const std::size_t n = perm_.size();
  for (std::size_t j = 0; j < n; ++j) y_[j] = r[perm_[j]];
  // Forward: L y = r, column by column.
  for (std::size_t j = 0; j < n; ++j) {
    const Vec3d yj = pivotInverse_[j] * y_[j];
    y_[j] = yj;
    for (std::uint32_t q = colStart_[j]; q < colStart_[j + 1]; ++q) {
      const double* a = lower_[q].data();
      double* o = y_[row_[q]].data();
      o[0] -= a[0] * yj[0] + a[3] * yj[1] + a[6] * yj[2];
      o[1] -= a[1] * yj[0] + a[4] * yj[1] + a[7] * yj[2];
      o[2] -= a[2] * yj[0] + a[5] * yj[1] + a[8] * yj[2];
    }
  }
  // Backward: L^T x = y, row of L^T = column of L.
  for (std::size_t j = n; j-- > 0;) {
    double s0 = y_[j][0], s1 = y_[j][1], s2 = y_[j][2];
    for (std::uint32_t q = colStart_[j]; q < colStart_[j + 1]; ++q) {
      const double* a = lower_[q].data();
      const double* x = y_[row_[q]].data();
      s0 -= a[0] * x[0] + a[1] * x[1] + a[2] * x[2];
      s1 -= a[3] * x[0] + a[4] * x[1] + a[5] * x[2];
      s2 -= a[6] * x[0] + a[7] * x[1] + a[8] * x[2];
    }
    y_[j] = pivotInverse_[j].transpose() * Vec3d(s0, s1, s2);
  }
  z.resize(n);
  for (std::size_t j = 0; j < n; ++j) z[perm_[j]] = y_[j];
}

}  // namespace voxcut
