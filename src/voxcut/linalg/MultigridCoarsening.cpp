/// @file MultigridCoarsening.cpp
/// One coarsening step of the multigrid hierarchy (coarsenRows, Multigrid.h): the cells
/// around each row, their copies split by the matrix's couplings, the coarse rows shared
/// between copies and the trilinear interpolation from them.

#include <array>
#include <limits>

#include "voxcut/core/Error.h"
#include "voxcut/core/FlatHashMap.h"
#include "voxcut/core/UnionFind.h"
#include "voxcut/linalg/Multigrid.h"
#include "voxcut/linalg/SparseRows.h"

namespace voxcut {

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

/// Key of a cell (coordinates shifted by one: a row on the grid's low planes also lies in the
/// cell below them).
std::uint64_t cellKey(const Index3& c) {
  return (static_cast<std::uint64_t>(c.x + 1) << 42) | (static_cast<std::uint64_t>(c.y + 1) << 21) |
         static_cast<std::uint64_t>(c.z + 1);
}

/// The cells around each row, as memberships (row, cell) numbered row by row.
struct CellMembers {
  std::vector<Index3> cellLow;  ///< per cell, its lowest corner (grid units)
  std::vector<std::uint32_t> memberStart;  ///< per row + 1: its memberships
  std::vector<std::uint32_t> memberCell;   ///< per membership, its cell
};

/// A corner a row has a weight on, and the weight.
struct Corner {
  Index3 point;
  double weight;
};

/// The cells around each row: along an axis, a coordinate on a cell boundary lies in the
/// cells on both sides; cells are numbered in the order the rows first reach them.
CellMembers cellsAroundRows(const std::vector<Index3>& coords, int s) {
  const std::size_t n = coords.size();
  CellMembers cm;
  FlatHashMap<std::uint32_t> cellId;
  cm.memberStart.assign(n + 1, 0);
  cm.memberCell.reserve(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Index3& x = coords[i];
    VOXCUT_ASSERT(x.x >= 0 && x.y >= 0 && x.z >= 0, "grid points are non-negative");
    std::array<std::array<int, 2>, 3> options{};
    std::array<int, 3> count{};
    for (int axis = 0; axis < 3; ++axis) {
      const int v = axis == 0 ? x.x : axis == 1 ? x.y : x.z;
      const int q = v / s;
      if (v % s == 0) {
        options[axis] = {q - 1, q};
        count[axis] = 2;
      } else {
        options[axis] = {q, q};
        count[axis] = 1;
      }
    }
    for (int cz = 0; cz < count[2]; ++cz)
      for (int cy = 0; cy < count[1]; ++cy)
        for (int cx = 0; cx < count[0]; ++cx) {
          const Index3 c{options[0][cx], options[1][cy], options[2][cz]};
          const std::uint64_t key = cellKey(c);
          std::uint32_t* id = cellId.find(key);
          if (id == nullptr) {
            cellId.set(key, static_cast<std::uint32_t>(cm.cellLow.size()));
            cm.memberCell.push_back(static_cast<std::uint32_t>(cm.cellLow.size()));
            cm.cellLow.push_back({c.x * s, c.y * s, c.z * s});
          } else {
            cm.memberCell.push_back(*id);
          }
        }
    cm.memberStart[i + 1] = static_cast<std::uint32_t>(cm.memberCell.size());
  }
  return cm;
}

/// Per membership, its cell copy: the parts of each cell (its memberships joined along the
/// matrix's couplings), one copy per part, numbered by the part's lowest membership.
std::vector<std::uint32_t> cellCopies(const BlockMatrixView& a, const CellMembers& cm,
                                      std::uint32_t& copies) {
  const std::vector<std::uint32_t>& memberStart = cm.memberStart;
  const std::vector<std::uint32_t>& memberCell = cm.memberCell;
  UnionFind parts(memberCell.size());
  for (std::size_t i = 0; i < a.rows; ++i)
    for (std::uint32_t slot = a.rowStart[i]; slot < a.rowStart[i + 1]; ++slot) {
      const std::uint32_t j = a.column[slot];
      if (j <= i) continue;
      for (std::uint32_t mi = memberStart[i]; mi < memberStart[i + 1]; ++mi)
        for (std::uint32_t mj = memberStart[j]; mj < memberStart[j + 1]; ++mj)
          if (memberCell[mi] == memberCell[mj]) parts.unite(mi, mj);
    }
  std::vector<std::uint32_t> copyOf(memberCell.size(), kNone);
  copies = 0;
  for (std::uint32_t m = 0; m < memberCell.size(); ++m) {
    const std::uint32_t root = parts.find(m);
    if (copyOf[root] == kNone) copyOf[root] = copies++;
    copyOf[m] = copyOf[root];
  }
  return copyOf;
}

/// The corners row i has a weight on, and their weights, into `out`; returns their count.
/// From its first cell: every cell around it gives the same corners, those of the face, edge
/// or corner it lies on.
int cornersOf(const std::vector<Index3>& coords, const CellMembers& cm, int s, std::size_t i,
              std::array<Corner, 8>& out) {
  const Index3& x = coords[i];
  const Index3& lo = cm.cellLow[cm.memberCell[cm.memberStart[i]]];
  const double t[3] = {static_cast<double>(x.x - lo.x) / s, static_cast<double>(x.y - lo.y) / s,
                       static_cast<double>(x.z - lo.z) / s};
  int count = 0;
  for (int c = 0; c < 8; ++c) {
    double w = 1.0;
    for (int axis = 0; axis < 3; ++axis) w *= (c >> axis) & 1 ? t[axis] : 1.0 - t[axis];
    if (w == 0.0) continue;
    out[static_cast<std::size_t>(count++)] = {
        {lo.x + (c & 1) * s, lo.y + ((c >> 1) & 1) * s, lo.z + ((c >> 2) & 1) * s}, w};
  }
  return count;
}

/// The number (0..7) of corner `p` of the cell with lowest corner `lo` and edge s.
std::uint32_t cornerIndex(const Index3& lo, const Index3& p, int s) {
  return static_cast<std::uint32_t>((p.x - lo.x) / s + 2 * ((p.y - lo.y) / s) +
                                    4 * ((p.z - lo.z) / s));
}

/// Coarse rows: (cell copy, corner) pairs joined wherever a row of several copies has a
/// weight on the corner, so every row interpolates from one set of coarse rows.
UnionFind joinCorners(const std::vector<Index3>& coords, const CellMembers& cm,
                      const std::vector<std::uint32_t>& copyOf, std::uint32_t copies, int s) {
  UnionFind corners(static_cast<std::size_t>(copies) * 8);
  std::array<Corner, 8> cs{};
  for (std::size_t i = 0; i < coords.size(); ++i) {
    const int count = cornersOf(coords, cm, s, i, cs);
    const std::uint32_t m0 = cm.memberStart[i];
    for (int k = 0; k < count; ++k) {
      const Index3& p = cs[static_cast<std::size_t>(k)].point;
      const std::uint32_t first = copyOf[m0] * 8 + cornerIndex(cm.cellLow[cm.memberCell[m0]], p, s);
      for (std::uint32_t m = m0 + 1; m < cm.memberStart[i + 1]; ++m)
        corners.unite(first, copyOf[m] * 8 + cornerIndex(cm.cellLow[cm.memberCell[m]], p, s));
    }
  }
  return corners;
}

/// The interpolation from the coarse rows (numbered in the order the fine rows first reach
/// them) and its transpose, with the coarse rows' grid points.
Coarsening interpolate(const std::vector<Index3>& coords, const CellMembers& cm,
                       const std::vector<std::uint32_t>& copyOf, std::uint32_t copies,
                       UnionFind& corners, int s) {
  const std::size_t n = coords.size();
  Coarsening out;
  Interpolation& p = out.interpolation;
  p.start.assign(n + 1, 0);
  std::vector<std::uint32_t> coarseOf(static_cast<std::size_t>(copies) * 8, kNone);
  std::array<Corner, 8> cs{};
  for (std::size_t i = 0; i < n; ++i) {
    const int count = cornersOf(coords, cm, s, i, cs);
    const std::uint32_t m0 = cm.memberStart[i];
    for (int k = 0; k < count; ++k) {
      const Corner& c = cs[static_cast<std::size_t>(k)];
      const std::uint32_t root =
          corners.find(copyOf[m0] * 8 + cornerIndex(cm.cellLow[cm.memberCell[m0]], c.point, s));
      if (coarseOf[root] == kNone) {
        coarseOf[root] = static_cast<std::uint32_t>(out.coords.size());
        out.coords.push_back(c.point);
      }
      p.index.push_back(coarseOf[root]);
      p.weight.push_back(c.weight);
    }
    p.start[i + 1] = static_cast<std::uint32_t>(p.index.size());
  }
  transposeRows(p.start, p.index, p.weight, out.coords.size(), p.tStart, p.tIndex, p.tWeight);
  return out;
}

}  // namespace

Coarsening coarsenRows(const BlockMatrixView& a, const std::vector<Index3>& coords, int cellSize) {
  VOXCUT_ASSERT(coords.size() == a.rows, "one grid point per row");
  VOXCUT_ASSERT(cellSize >= 1 && (cellSize & (cellSize - 1)) == 0, "cell size a power of two");
  const int s = cellSize;
  const CellMembers cm = cellsAroundRows(coords, s);
  std::uint32_t copies = 0;
  const std::vector<std::uint32_t> copyOf = cellCopies(a, cm, copies);
  UnionFind corners = joinCorners(coords, cm, copyOf, copies, s);
  return interpolate(coords, cm, copyOf, copies, corners, s);
}

}  // namespace voxcut
