#include "voxcut/linalg/Multigrid.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/UnionFind.h"

namespace voxcut {

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
constexpr std::size_t kGrain = 256;
/// Largest group of weak rows (MultigridParams::maxGroupRows is clamped to it): a group's
/// right-hand side lives on the stack.
constexpr std::size_t kMaxGroupRows = 64;
/// Relative lift of the coarse matrices' diagonals (Multigrid::galerkin).
constexpr double kDiagonalLift = 1e-9;

/// The slot of column `col` in row `row` of `a`, kNone when absent.
std::uint32_t findSlot(const BlockMatrixView& a, std::size_t row, std::uint32_t col) {
  const std::uint32_t* first = a.column + a.rowStart[row];
  const std::uint32_t* last = a.column + a.rowStart[row + 1];
  const std::uint32_t* it = std::lower_bound(first, last, col);
  return it != last && *it == col ? static_cast<std::uint32_t>(it - a.column) : kNone;
}

/// The inverse of the symmetric 3x3 block `d` (its lower triangle read) into `out`
/// (column-major) by cofactors; false unless d is positive definite (positive leading minors,
/// Sylvester's criterion) and the inverse finite.
bool symmetricInverse(const Eigen::Matrix3d& d, double* out) {
  const double a = d(0, 0), b = d(1, 0), c = d(2, 0), e = d(1, 1), f = d(2, 1), i = d(2, 2);
  const double c00 = e * i - f * f, c01 = c * f - b * i, c02 = b * f - e * c;
  const double c11 = a * i - c * c, c12 = b * c - a * f, c22 = a * e - b * b;
  const double det = a * c00 + b * c01 + c * c02;
  if (!(a > 0.0) || !(c22 > 0.0) || !(det > 0.0)) return false;
  const double s = 1.0 / det;
  const double v[9] = {c00 * s, c01 * s, c02 * s, c01 * s, c11 * s,
                       c12 * s, c02 * s, c12 * s, c22 * s};
  bool finite = true;
  for (int k = 0; k < 9; ++k) {
    out[k] = v[k];
    finite = finite && std::isfinite(v[k]);
  }
  return finite;
}

/// In-place Cholesky factor (lower, column-major n x n); false when not positive definite.
bool choleskyInPlace(double* a, int n) {
  for (int j = 0; j < n; ++j) {
    double d = a[j * n + j];
    for (int k = 0; k < j; ++k) d -= a[k * n + j] * a[k * n + j];
    if (!(d > 0.0) || !std::isfinite(d)) return false;
    const double l = std::sqrt(d);
    a[j * n + j] = l;
    for (int i = j + 1; i < n; ++i) {
      double s = a[j * n + i];
      for (int k = 0; k < j; ++k) s -= a[k * n + i] * a[k * n + j];
      a[j * n + i] = s / l;
    }
  }
  return true;
}

/// Solves L L^T x = b in place with the factor of choleskyInPlace. The forward substitution
/// runs by columns of L (contiguous, and no chain of dependent sums), in the same order of
/// terms as by rows; the backward one by rows of L^T, which are columns of L, with two partial
/// sums.
void choleskySolve(const double* l, int n, double* x) {
  for (int k = 0; k < n; ++k) {
    const double* col = l + static_cast<std::ptrdiff_t>(k) * n;
    const double xk = x[k] / col[k];
    x[k] = xk;
    for (int i = k + 1; i < n; ++i) x[i] -= col[i] * xk;
  }
  for (int i = n - 1; i >= 0; --i) {
    const double* col = l + static_cast<std::ptrdiff_t>(i) * n;
    double s0 = 0.0, s1 = 0.0;
    int k = i + 1;
    for (; k + 1 < n; k += 2) {
      s0 += col[k] * x[k];
      s1 += col[k + 1] * x[k + 1];
    }
    if (k < n) s0 += col[k] * x[k];
    x[i] = (x[i] - (s0 + s1)) / col[i];
  }
}

/// Rows in the groups the smoother relaxes together: rows of group k are
/// rows[rowsStart[k] ...), ascending; groups are numbered in the order of their first row.
struct RowGroups {
  std::vector<std::uint32_t> rowsStart{0}, rows, groupOf;
  std::size_t groupedRows = 0;  ///< rows in groups of more than one
};

/// Per row, the root of its set of weak rows coupled to each other (a row is its own set
/// unless weak: the trace of its diagonal block below `weakRatio` of the largest trace among
/// the rows it is coupled to).
std::vector<std::uint32_t> weakSets(const BlockMatrixView& a, double weakRatio) {
  const std::size_t n = a.rows;
  std::vector<double> trace(n);
  for (std::size_t i = 0; i < n; ++i) trace[i] = a.blocks[a.diagonal[i]].trace();
  std::vector<std::uint8_t> weak(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    double strongest = 0.0;
    for (std::uint32_t slot = a.rowStart[i]; slot < a.rowStart[i + 1]; ++slot)
      strongest = std::max(strongest, trace[a.column[slot]]);
    weak[i] = trace[i] < weakRatio * strongest ? 1 : 0;
  }
  UnionFind sets(n);
  for (std::size_t i = 0; i < n; ++i)
    if (weak[i])
      for (std::uint32_t slot = a.rowStart[i]; slot < a.rowStart[i + 1]; ++slot)
        if (weak[a.column[slot]]) sets.unite(static_cast<std::uint32_t>(i), a.column[slot]);
  std::vector<std::uint32_t> root(n);
  for (std::size_t i = 0; i < n; ++i) root[i] = sets.find(static_cast<std::uint32_t>(i));
  return root;
}

/// Groups: a set of weak rows (by `root`) larger than `cap` is cut into pieces grown breadth
/// first from its lowest row not yet taken, so a group holds rows coupled to each other.
RowGroups growGroups(const BlockMatrixView& a, const std::vector<std::uint32_t>& root,
                     std::size_t cap) {
  const std::size_t n = a.rows;
  RowGroups rg;
  std::vector<std::uint32_t>& rowsStart = rg.rowsStart;
  std::vector<std::uint32_t>& rows = rg.rows;
  std::vector<std::uint32_t>& groupOf = rg.groupOf;
  groupOf.assign(n, kNone);
  rows.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (groupOf[i] != kNone) continue;
    const auto group = static_cast<std::uint32_t>(rowsStart.size() - 1);
    const std::size_t begin = rows.size();
    groupOf[i] = group;
    rows.push_back(static_cast<std::uint32_t>(i));
    for (std::size_t k = begin; k < rows.size() && rows.size() - begin < cap; ++k) {
      const std::uint32_t row = rows[k];
      for (std::uint32_t slot = a.rowStart[row]; slot < a.rowStart[row + 1]; ++slot) {
        const std::uint32_t j = a.column[slot];
        if (groupOf[j] != kNone || root[j] != root[i]) continue;
        groupOf[j] = group;
        rows.push_back(j);
        if (rows.size() - begin == cap) break;
      }
    }
    std::sort(rows.begin() + static_cast<std::ptrdiff_t>(begin), rows.end());
    if (rows.size() - begin > 1) rg.groupedRows += rows.size() - begin;
    rowsStart.push_back(static_cast<std::uint32_t>(rows.size()));
  }
  return rg;
}

/// Per group, its colour: greedily, in group order, the lowest colour no coupled group has
/// yet. Groups of one colour share no block, so a sweep relaxes them in any order, or in
/// parallel, with the same result; and no row waits for the row just before it.
std::vector<std::uint32_t> colourGroups(const BlockMatrixView& a, const RowGroups& rg,
                                        std::uint32_t& colours) {
  const std::vector<std::uint32_t>& rowsStart = rg.rowsStart;
  const std::vector<std::uint32_t>& rows = rg.rows;
  const std::size_t groups = rowsStart.size() - 1;
  std::vector<std::uint32_t> colour(groups, kNone);
  std::vector<std::uint32_t> seenBy;  // per colour, the last group that saw it taken
  colours = 0;
  for (std::size_t g = 0; g < groups; ++g) {
    for (std::uint32_t k = rowsStart[g]; k < rowsStart[g + 1]; ++k)
      for (std::uint32_t slot = a.rowStart[rows[k]]; slot < a.rowStart[rows[k] + 1]; ++slot) {
        const std::uint32_t c = colour[rg.groupOf[a.column[slot]]];
        if (c != kNone) seenBy[c] = static_cast<std::uint32_t>(g);
      }
    std::uint32_t c = 0;
    while (c < colours && seenBy[c] == g) ++c;
    if (c == colours) {
      ++colours;
      seenBy.push_back(kNone);
    }
    colour[g] = c;
  }
  return colour;
}

}  // namespace

/// A level's smoother. Its rows are renumbered so that every group is a run of consecutive
/// rows ("position" order; groups in the order of their lowest row), and it keeps its own copy
/// of the level's matrix in that order with blocks in single precision: the sweeps read half
/// the bytes, and with groups contiguous the forward sweep from zero reads only the blocks left
/// of a row's group and the residual after it only those right of it (Multigrid::cycle).
struct Multigrid::Smoother {
  std::vector<std::uint32_t> groupStart{0};   ///< per group + 1: its rows, in position order
  std::vector<std::uint32_t> colourStart{0};  ///< per colour + 1: its groups
  std::vector<std::uint32_t> order;           ///< per position, the level's row
  std::vector<std::uint32_t> position;        ///< per row of the level, its position
  std::vector<std::uint32_t> rowStart{0};     ///< the copy by positions: per position + 1
  std::vector<std::uint32_t> column;          ///< positions, ascending per row
  std::vector<std::uint32_t> lowerEnd;    ///< per position: first slot right of its group's start
  std::vector<std::uint32_t> upperStart;  ///< per position: first slot past its group's end
  std::vector<std::uint32_t> source;      ///< per slot, the level matrix's slot
  std::vector<Eigen::Matrix3f> blocks;
  std::vector<std::uint32_t> factorStart;  ///< per group, into factor
  /// Per group of one row, its diagonal block's inverse; of g rows, the Cholesky factor of
  /// its 3g x 3g diagonal part (column-major).
  std::vector<double> factor;
  std::size_t groupedRows = 0;

  [[nodiscard]] std::size_t groups() const { return groupStart.size() - 1; }
};

struct Multigrid::Level {
  BlockMatrix matrix;                 ///< coarse levels: the Galerkin product (level 0: none)
  std::vector<std::uint32_t> mirror;  ///< coarse levels: per slot (i, k), the slot (k, i)
  Interpolation toCoarse;             ///< from the next level's rows (none on the last)
  /// toCoarse by positions of this level and of the next (the cycle's vectors are in
  /// position order; the last level's positions are its rows)
  Interpolation cycleInterpolation;
  Smoother smoother;
  std::vector<Vec3d> r, u, t;  ///< by position
};

Multigrid::Multigrid() = default;
Multigrid::Multigrid(Multigrid&&) noexcept = default;
Multigrid& Multigrid::operator=(Multigrid&&) noexcept = default;
Multigrid::~Multigrid() = default;

Multigrid::Multigrid(const Multigrid& other) : LinearPreconditioner(other) {
  *this = other;
}

Multigrid& Multigrid::operator=(const Multigrid& other) {
  if (this == &other) return *this;
  params_ = other.params_;
  levels_.clear();
  for (const auto& l : other.levels_) levels_.push_back(std::make_unique<Level>(*l));
  coarsest_ = other.coarsest_;
  coarsestPattern_ = other.coarsestPattern_;
  coarsestBlocks_ = other.coarsestBlocks_;
  analysed_ = other.analysed_;
  // A single-level hierarchy factorises the caller's matrix at its next setup.
  valid_ = other.valid_ && levels_.size() > 1;
  operator_ = {};
  return *this;
}

std::vector<std::size_t> Multigrid::rowsPerLevel() const {
  std::vector<std::size_t> out;
  for (const auto& l : levels_) out.push_back(l->r.size());
  return out;
}

std::vector<std::size_t> Multigrid::smootherBlocksPerLevel() const {
  std::vector<std::size_t> out;
  for (const auto& l : levels_) out.push_back(l->smoother.blocks.size());
  return out;
}

std::vector<std::size_t> Multigrid::groupedRowsPerLevel() const {
  std::vector<std::size_t> out;
  for (const auto& l : levels_) out.push_back(l->smoother.groupedRows);
  return out;
}

void Multigrid::build(const BlockMatrixView& fine, const std::vector<Index3>& coords,
                      const MultigridParams& params, bool threaded) {
  (void)threaded;
  params_ = params;
  levels_.clear();
  coarsest_ = BlockCholesky{};
  coarsestBlocks_.clear();
  analysed_ = false;
  valid_ = false;
  operator_ = {};
  auto level0 = std::make_unique<Level>();
  level0->r.resize(fine.rows);
  level0->u.resize(fine.rows);
  level0->t.resize(fine.rows);
  levels_.push_back(std::move(level0));
  if (fine.rows == 0) return;
  std::vector<Index3> levelCoords = coords;
  int cellSize = 1;
  while (levels_.size() < static_cast<std::size_t>(params_.maxLevels)) {
    Level& f = *levels_.back();
    const BlockMatrixView a = levels_.size() == 1 ? fine : f.matrix.view();
    if (a.rows <= params_.coarsestRows && analyseCoarsest(a, fine.rowStart[fine.rows])) break;
    // The smallest cell size, twice the last or more, that coarsens enough.
    Coarsening c;
    bool found = false;
    for (cellSize *= 2; cellSize <= (1 << 20); cellSize *= 2) {
      c = coarsenRows(a, levelCoords, cellSize);
      if (static_cast<double>(c.coords.size()) <=
          params_.maxCoarseRatio * static_cast<double>(a.rows)) {
        found = true;
        break;
      }
    }
    if (!found) break;
    // The coarse pattern: (a, b) wherever a fine block (i, j) has i interpolating from a and
    // j from b.
    const Interpolation& p = c.interpolation;
    const std::size_t m = c.coords.size();
    auto next = std::make_unique<Level>();
    BlockMatrix& cm = next->matrix;
    cm.rowStart.assign(m + 1, 0);
    std::vector<std::vector<std::uint32_t>> cols(m);
    parallelFor(
        0, m, 64,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t row = b; row < e; ++row) {
            std::vector<std::uint32_t>& out = cols[row];
            for (std::uint32_t k = p.tStart[row]; k < p.tStart[row + 1]; ++k) {
              const std::uint32_t i = p.tIndex[k];
              for (std::uint32_t slot = a.rowStart[i]; slot < a.rowStart[i + 1]; ++slot) {
                const std::uint32_t j = a.column[slot];
                for (std::uint32_t q = p.start[j]; q < p.start[j + 1]; ++q)
                  out.push_back(p.index[q]);
              }
            }
            std::sort(out.begin(), out.end());
            out.erase(std::unique(out.begin(), out.end()), out.end());
          }
        },
        threaded);
    for (std::size_t row = 0; row < m; ++row)
      cm.rowStart[row + 1] = cm.rowStart[row] + static_cast<std::uint32_t>(cols[row].size());
    cm.column.resize(cm.rowStart[m]);
    cm.diagonal.resize(m);
    for (std::size_t row = 0; row < m; ++row) {
      std::copy(cols[row].begin(), cols[row].end(), cm.column.begin() + cm.rowStart[row]);
      std::vector<std::uint32_t>().swap(cols[row]);
    }
    cm.blocks.assign(cm.column.size(), Eigen::Matrix3d::Zero());
    const BlockMatrixView cv = cm.view();
    for (std::size_t row = 0; row < m; ++row)
      cm.diagonal[row] = findSlot(cv, row, static_cast<std::uint32_t>(row));
    next->mirror.resize(cm.column.size());
    for (std::size_t row = 0; row < m; ++row)
      for (std::uint32_t slot = cm.rowStart[row]; slot < cm.rowStart[row + 1]; ++slot)
        next->mirror[slot] = findSlot(cv, cm.column[slot], static_cast<std::uint32_t>(row));
    next->r.resize(m);
    next->u.resize(m);
    next->t.resize(m);
    f.toCoarse = std::move(c.interpolation);
    levelCoords = std::move(c.coords);
    levels_.push_back(std::move(next));
  }
}

void Multigrid::galerkin(std::size_t level, bool threaded) {
  // A_c = P^T A P, row by row of A_c, upper triangle only; the lower one is its mirror, so
  // A_c is symmetric exactly. Each block is a sum in a fixed order (any thread count).
  const Level& f = *levels_[level];
  Level& c = *levels_[level + 1];
  const BlockMatrixView a = level == 0 ? *fine_ : f.matrix.view();
  const Interpolation& p = f.toCoarse;
  BlockMatrix& cm = c.matrix;
  const BlockMatrixView cv = cm.view();
  const std::size_t m = cm.rows();
  parallelFor(
      0, m, 16,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t row = b; row < e; ++row) {
          const std::uint32_t first = cm.diagonal[row], last = cm.rowStart[row + 1];
          for (std::uint32_t s = first; s < last; ++s) cm.blocks[s].setZero();
          for (std::uint32_t k = p.tStart[row]; k < p.tStart[row + 1]; ++k) {
            const std::uint32_t i = p.tIndex[k];
            const double wi = p.tWeight[k];
            for (std::uint32_t slot = a.rowStart[i]; slot < a.rowStart[i + 1]; ++slot) {
              const std::uint32_t j = a.column[slot];
              const Eigen::Matrix3d& aij = a.blocks[slot];
              for (std::uint32_t q = p.start[j]; q < p.start[j + 1]; ++q) {
                const std::uint32_t col = p.index[q];
                if (col < row) continue;
                const std::uint32_t* it =
                    std::lower_bound(cv.column + first, cv.column + last, col);
                cm.blocks[static_cast<std::size_t>(it - cv.column)] += (wi * p.weight[q]) * aij;
              }
            }
          }
          // Symmetric, and lifted by kDiagonalLift of its diagonal: a cell copy whose rows
          // do not determine all its corners (a lone row inside it) makes P rank deficient,
          // A_c singular on exactly the combinations P maps to zero, which nothing then
          // excites; the lift keeps every factor positive definite there.
          Eigen::Matrix3d& d = cm.blocks[first];
          d = 0.5 * (d + d.transpose()).eval();
          d.diagonal() *= 1.0 + kDiagonalLift;
        }
      },
      threaded);
  parallelFor(
      0, m, 64,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t row = b; row < e; ++row)
          for (std::uint32_t s = cm.rowStart[row]; s < cm.diagonal[row]; ++s)
            cm.blocks[s] = cm.blocks[c.mirror[s]].transpose();
      },
      threaded);
}

void Multigrid::groupRows(const BlockMatrixView& a, Smoother& s) const {
  const std::size_t n = a.rows;
  const std::size_t cap = std::clamp<std::size_t>(params_.maxGroupRows, 1, kMaxGroupRows);
  const RowGroups rg = growGroups(a, weakSets(a, params_.weakRatio), cap);
  s.groupedRows = rg.groupedRows;
  std::uint32_t colours = 0;
  const std::vector<std::uint32_t> colour = colourGroups(a, rg, colours);
  // Positions: colour by colour, groups in their order within a colour.
  const std::size_t groups = rg.rowsStart.size() - 1;
  s.colourStart.assign(colours + 1, 0);
  for (std::uint32_t c : colour) ++s.colourStart[c + 1];
  for (std::uint32_t c = 0; c < colours; ++c) s.colourStart[c + 1] += s.colourStart[c];
  std::vector<std::uint32_t> slotOf(s.colourStart.begin(), s.colourStart.end() - 1);
  std::vector<std::uint32_t> sorted(groups);
  for (std::size_t g = 0; g < groups; ++g)
    sorted[slotOf[colour[g]]++] = static_cast<std::uint32_t>(g);
  s.groupStart.assign(1, 0);
  s.order.clear();
  s.order.reserve(n);
  for (std::uint32_t g : sorted) {
    s.order.insert(s.order.end(), rg.rows.begin() + rg.rowsStart[g],
                   rg.rows.begin() + rg.rowsStart[g + 1]);
    s.groupStart.push_back(static_cast<std::uint32_t>(s.order.size()));
  }
  s.position.resize(n);
  for (std::size_t p = 0; p < n; ++p) s.position[s.order[p]] = static_cast<std::uint32_t>(p);
  s.factorStart.resize(s.groups());
  std::size_t total = 0;
  for (std::size_t g = 0; g < s.groups(); ++g) {
    s.factorStart[g] = static_cast<std::uint32_t>(total);
    const std::size_t dim = 3 * (s.groupStart[g + 1] - s.groupStart[g]);
    total += dim * dim;
  }
  s.factor.resize(total);
  copyPattern(a, s);
}

void Multigrid::copyPattern(const BlockMatrixView& a, Smoother& s) {
  // The copy by positions: each row's slots with their columns renumbered, sorted; then the
  // split points around the row's group.
  const std::size_t n = a.rows;
  s.rowStart.assign(n + 1, 0);
  for (std::size_t p = 0; p < n; ++p) {
    const std::uint32_t i = s.order[p];
    s.rowStart[p + 1] = s.rowStart[p] + (a.rowStart[i + 1] - a.rowStart[i]);
  }
  s.column.resize(s.rowStart[n]);
  s.source.resize(s.rowStart[n]);
  s.blocks.resize(s.rowStart[n]);
  s.lowerEnd.resize(n);
  s.upperStart.resize(n);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> row;
  for (std::size_t g = 0; g < s.groups(); ++g)
    for (std::uint32_t p = s.groupStart[g]; p < s.groupStart[g + 1]; ++p) {
      const std::uint32_t i = s.order[p];
      row.clear();
      for (std::uint32_t slot = a.rowStart[i]; slot < a.rowStart[i + 1]; ++slot)
        row.emplace_back(s.position[a.column[slot]], slot);
      std::sort(row.begin(), row.end());
      std::uint32_t out = s.rowStart[p];
      s.lowerEnd[p] = s.upperStart[p] = s.rowStart[p + 1];
      for (const auto& [col, slot] : row) {
        if (col >= s.groupStart[g] && s.lowerEnd[p] == s.rowStart[p + 1]) s.lowerEnd[p] = out;
        if (col >= s.groupStart[g + 1] && s.upperStart[p] == s.rowStart[p + 1])
          s.upperStart[p] = out;
        s.column[out] = col;
        s.source[out++] = slot;
      }
    }
}

void Multigrid::copyBlocks(const BlockMatrixView& a, Smoother& s, bool threaded) const {
  parallelFor(
      0, s.blocks.size(), 4096,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t k = b; k < e; ++k) s.blocks[k] = a.blocks[s.source[k]].cast<float>();
      },
      threaded);
}

bool Multigrid::factorSmoother(const BlockMatrixView& a, Smoother& s, bool threaded) const {
  // Each group writes only its own factor: the groups run in parallel.
  std::atomic<bool> failed = false;
  parallelFor(
      0, s.groups(), 256,
      [&](std::size_t begin, std::size_t end) {
        for (std::size_t g = begin; g < end && !failed.load(std::memory_order_relaxed); ++g) {
          const std::uint32_t* rows = s.order.data() + s.groupStart[g];
          const int count = static_cast<int>(s.groupStart[g + 1] - s.groupStart[g]);
          double* f = s.factor.data() + s.factorStart[g];
          bool ok = false;
          if (count == 1) {
            ok = symmetricInverse(a.blocks[a.diagonal[rows[0]]], f);
          } else {
            const int dim = 3 * count;
            Eigen::Map<Eigen::MatrixXd> m(f, dim, dim);
            m.setZero();
            for (int p = 0; p < count; ++p)
              for (int q = 0; q < count; ++q) {
                const std::uint32_t slot = findSlot(a, rows[p], rows[q]);
                if (slot != kNone) m.block<3, 3>(3 * p, 3 * q) = a.blocks[slot];
              }
            ok = choleskyInPlace(f, dim);
          }
          if (!ok) failed.store(true, std::memory_order_relaxed);
        }
      },
      threaded);
  return !failed.load();
}

void Multigrid::arrangeInterpolation(std::size_t level) {
  // toCoarse with both sides renumbered by position; the transpose keeps its order of fine
  // rows (ascending rows of the level), so every restricted sum is summed as before.
  Level& f = *levels_[level];
  const Level& c = *levels_[level + 1];
  const bool coarseLast = level + 2 == levels_.size();
  auto coarsePosition = [&](std::uint32_t row) {
    return coarseLast ? row : c.smoother.position[row];
  };
  const Interpolation& p = f.toCoarse;
  Interpolation& q = f.cycleInterpolation;
  const std::size_t n = p.start.size() - 1, m = p.tStart.size() - 1;
  q.start.assign(n + 1, 0);
  q.index.resize(p.index.size());
  q.weight.resize(p.weight.size());
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = f.smoother.order[k];
    q.start[k + 1] = q.start[k] + (p.start[i + 1] - p.start[i]);
    std::uint32_t out = q.start[k];
    for (std::uint32_t e = p.start[i]; e < p.start[i + 1]; ++e, ++out) {
      q.index[out] = coarsePosition(p.index[e]);
      q.weight[out] = p.weight[e];
    }
  }
  q.tStart.assign(m + 1, 0);
  q.tIndex.resize(p.tIndex.size());
  q.tWeight.resize(p.tWeight.size());
  std::vector<std::uint32_t> rowOf(m);
  for (std::size_t a = 0; a < m; ++a)
    rowOf[coarsePosition(static_cast<std::uint32_t>(a))] = static_cast<std::uint32_t>(a);
  for (std::size_t k = 0; k < m; ++k) {
    const std::uint32_t a = rowOf[k];
    q.tStart[k + 1] = q.tStart[k] + (p.tStart[a + 1] - p.tStart[a]);
    std::uint32_t out = q.tStart[k];
    for (std::uint32_t e = p.tStart[a]; e < p.tStart[a + 1]; ++e, ++out) {
      q.tIndex[out] = f.smoother.position[p.tIndex[e]];
      q.tWeight[out] = p.tWeight[e];
    }
  }
}

bool Multigrid::analyseCoarsest(const BlockMatrixView& a, std::size_t fineBlocks) {
  coarsestPattern_.rowStart.assign(a.rowStart, a.rowStart + a.rows + 1);
  coarsestPattern_.column.assign(a.column, a.column + a.rowStart[a.rows]);
  coarsestPattern_.diagonal.assign(a.diagonal, a.diagonal + a.rows);
  coarsest_.analyse(coarsestPattern_);
  analysed_ = true;
  return static_cast<double>(coarsest_.offDiagonalBlocks()) <=
         params_.maxCoarsestFill * static_cast<double>(fineBlocks);
}

bool Multigrid::factorCoarsest(const BlockMatrixView& a, bool threaded) {
  if (!analysed_ || coarsest_.rows() != a.rows) (void)analyseCoarsest(a, 0);
  // The last level's own blocks, or a copy of the fine ones (a hierarchy of one level).
  const std::vector<Eigen::Matrix3d>* blocks = &coarsestBlocks_;
  if (levels_.size() > 1)
    blocks = &levels_.back()->matrix.blocks;
  else
    coarsestBlocks_.assign(a.blocks, a.blocks + a.rowStart[a.rows]);
  return coarsest_.factorise(coarsestPattern_, *blocks, threaded);
}

bool Multigrid::setup(const BlockMatrixView& fine, bool threaded) {
  valid_ = false;
  operator_ = fine;
  threaded_ = threaded;
  if (levels_.empty() || fine.rows == 0) return false;
  fine_ = &fine;
  for (std::size_t l = 0; l + 1 < levels_.size(); ++l) galerkin(l, threaded);
  fine_ = nullptr;
  for (std::size_t l = 0; l + 1 < levels_.size(); ++l) {
    const BlockMatrixView a = l == 0 ? fine : levels_[l]->matrix.view();
    Smoother& s = levels_[l]->smoother;
    groupRows(a, s);
    copyBlocks(a, s, threaded);
    if (!factorSmoother(a, s, threaded)) return false;
  }
  for (std::size_t l = 0; l + 1 < levels_.size(); ++l) arrangeInterpolation(l);
  const BlockMatrixView last = levels_.size() == 1 ? fine : levels_.back()->matrix.view();
  valid_ = factorCoarsest(last, threaded);
  return valid_;
}

bool Multigrid::updateFine(const BlockMatrixView& fine, bool threaded) {
  operator_ = fine;
  threaded_ = threaded;
  if (levels_.empty() || fine.rows == 0) return valid_ = false;
  if (levels_.size() == 1) return valid_ = factorCoarsest(fine, threaded);
  Smoother& s = levels_[0]->smoother;
  copyBlocks(fine, s, threaded);
  return valid_ = factorSmoother(fine, s, threaded);
}

void Multigrid::cycle(std::size_t level, bool threaded) {
  Level& l = *levels_[level];
  const std::size_t n = l.r.size();
  if (level + 1 == levels_.size()) {
    coarsest_.solve(l.r, l.u);
    return;
  }
  Smoother& s = l.smoother;
  const Eigen::Matrix3f* blocks = s.blocks.data();
  const std::uint32_t* column = s.column.data();
  // Relaxes group g: u_g += A_gg^-1 (r_g - sum over the slots [first(p), last(p)) of each row
  // p of the group). Group rows are consecutive positions.
  auto relax = [&](std::size_t g, auto first, auto last) {
    const std::uint32_t begin = s.groupStart[g], end = s.groupStart[g + 1];
    const double* f = s.factor.data() + s.factorStart[g];
    if (end - begin == 1) {
      const Vec3d res =
          l.r[begin] - blockRowProduct(blocks, column, l.u.data(), first(begin), last(begin));
      // f is the inverse of the diagonal block (column-major), written out: this runs once
      // per row and sweep.
      l.u[begin] += Vec3d(f[0] * res[0] + f[3] * res[1] + f[6] * res[2],
                          f[1] * res[0] + f[4] * res[1] + f[7] * res[2],
                          f[2] * res[0] + f[5] * res[1] + f[8] * res[2]);
      return;
    }
    const int count = static_cast<int>(end - begin);
    std::array<double, 3 * kMaxGroupRows> rhs;
    for (std::uint32_t p = begin; p < end; ++p) {
      const Vec3d res = l.r[p] - blockRowProduct(blocks, column, l.u.data(), first(p), last(p));
      for (int c = 0; c < 3; ++c) rhs[3 * (p - begin) + static_cast<std::size_t>(c)] = res[c];
    }
    choleskySolve(f, 3 * count, rhs.data());
    for (std::uint32_t p = begin; p < end; ++p)
      l.u[p] += Vec3d(rhs[3 * (p - begin)], rhs[3 * (p - begin) + 1], rhs[3 * (p - begin) + 2]);
  };
  auto rowFirst = [&](std::uint32_t p) { return s.rowStart[p]; };
  auto rowEnd = [&](std::uint32_t p) { return s.rowStart[p + 1]; };
  auto lowerEnd = [&](std::uint32_t p) { return s.lowerEnd[p]; };
  // Colour by colour (forward: ascending; backward: descending), the groups of one colour in
  // parallel: they share no block, so the result is the same for any thread count.
  auto sweep = [&](bool forward, auto first, auto last) {
    const std::size_t colours = s.colourStart.size() - 1;
    for (std::size_t k = 0; k < colours; ++k) {
      const std::size_t c = forward ? k : colours - 1 - k;
      parallelFor(
          s.colourStart[c], s.colourStart[c + 1], 128,
          [&](std::size_t b, std::size_t e) {
            for (std::size_t g = b; g < e; ++g) relax(g, first, last);
          },
          threaded);
    }
  };
  // Forward sweep from u = 0: a row's group sees only the rows before the group (the rest is
  // still zero, or of its own colour and so not coupled), so only the slots left of it are read.
  std::fill(l.u.begin(), l.u.end(), Vec3d::Zero());
  sweep(true, rowFirst, lowerEnd);
  // Its residual: each group solved r_g - A_(g, before) u = A_gg u_g, so r - A u is minus the
  // product with the slots right of the group.
  Level& c = *levels_[level + 1];
  parallelFor(
      0, n, kGrain,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t p = b; p < e; ++p)
          l.t[p] = -blockRowProduct(blocks, column, l.u.data(), s.upperStart[p], s.rowStart[p + 1]);
      },
      threaded);
  const Interpolation& ip = l.cycleInterpolation;
  parallelFor(
      0, c.r.size(), kGrain,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t row = b; row < e; ++row) {
          Vec3d sum = Vec3d::Zero();
          for (std::uint32_t k = ip.tStart[row]; k < ip.tStart[row + 1]; ++k)
            sum += ip.tWeight[k] * l.t[ip.tIndex[k]];
          c.r[row] = sum;
        }
      },
      threaded);
  cycle(level + 1, threaded);
  parallelFor(
      0, n, kGrain,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t p = b; p < e; ++p) {
          Vec3d sum = Vec3d::Zero();
          for (std::uint32_t k = ip.start[p]; k < ip.start[p + 1]; ++k)
            sum += ip.weight[k] * c.u[ip.index[k]];
          l.u[p] += sum;
        }
      },
      threaded);
  sweep(false, rowFirst, rowEnd);
}

void Multigrid::apply(const BlockMatrixView& fine, const std::vector<Vec3d>& r,
                      std::vector<Vec3d>& z, bool threaded) {
  VOXCUT_ASSERT(
      valid_ && !levels_.empty() && levels_[0]->r.size() == fine.rows && r.size() == fine.rows,
      "multigrid applied without a valid setup for this matrix");
  Level& l0 = *levels_[0];
  z.resize(fine.rows);
  if (levels_.size() == 1) {
    std::copy(r.begin(), r.end(), l0.r.begin());
    cycle(0, threaded);
    std::copy(l0.u.begin(), l0.u.end(), z.begin());
    return;
  }
  const std::vector<std::uint32_t>& order = l0.smoother.order;
  for (std::size_t p = 0; p < fine.rows; ++p) l0.r[p] = r[order[p]];
  cycle(0, threaded);
  for (std::size_t p = 0; p < fine.rows; ++p) z[order[p]] = l0.u[p];
}

}  // namespace voxcut
