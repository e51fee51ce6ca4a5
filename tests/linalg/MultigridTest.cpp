// The multigrid V-cycle (linalg/Multigrid.h): coarsening (interpolation of linear fields,
// parts kept apart), the V-cycle as a symmetric positive definite preconditioner whose
// iterations barely grow with size, weak rows relaxed in groups, and thread independence.

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>

#include "voxcut/core/Parallel.h"
#include "voxcut/linalg/Multigrid.h"

namespace voxcut {
namespace {

/// A block matrix on the points of a grid: every pair of points within one step along each
/// axis (26 neighbours) joined by a spring along their direction, plus `mass` on the
/// diagonal. `keep(a, b)` says whether the spring between points a and b exists; `scale(a, b)`
/// scales it (and scale(a, a) point a's mass).
struct GridSystem {
  BlockMatrix matrix;
  std::vector<Index3> coords;
};

GridSystem springGrid(int n, double mass, int spacing = 1,
                      const std::function<bool(const Index3&, const Index3&)>& keep = nullptr,
                      const std::function<double(const Index3&, const Index3&)>& scale = nullptr) {
  GridSystem s;
  std::map<std::tuple<int, int, int>, std::uint32_t> id;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        id[{x, y, z}] = static_cast<std::uint32_t>(s.coords.size());
        s.coords.push_back({x * spacing, y * spacing, z * spacing});
      }
  const std::size_t rows = s.coords.size();
  std::vector<std::map<std::uint32_t, Eigen::Matrix3d>> row(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    const double si = scale ? scale(s.coords[i], s.coords[i]) : 1.0;
    row[i][static_cast<std::uint32_t>(i)] = mass * si * Eigen::Matrix3d::Identity();
  }
  for (std::size_t i = 0; i < rows; ++i) {
    const Index3 a = s.coords[i];
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int x = a.x / spacing + dx, y = a.y / spacing + dy, z = a.z / spacing + dz;
          if ((dx == 0 && dy == 0 && dz == 0) || x < 0 || y < 0 || z < 0 || x >= n || y >= n ||
              z >= n)
            continue;
          const std::uint32_t j = id[{x, y, z}];
          if (j < i) continue;
          const Index3 b = s.coords[j];
          if (keep && !keep(a, b)) continue;
          const Vec3d d = Vec3d(dx, dy, dz).normalized();
          double k = 1.0 / Vec3d(dx, dy, dz).norm();
          if (scale) k *= scale(a, b);
          const Eigen::Matrix3d block = k * d * d.transpose();
          row[i][static_cast<std::uint32_t>(i)] += block;
          row[j][j] += block;
          row[i][j] = -block;
          row[j][static_cast<std::uint32_t>(i)] = -block;
        }
  }
  BlockMatrix& m = s.matrix;
  m.diagonal.resize(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    for (const auto& [c, b] : row[i]) {
      if (c == i) m.diagonal[i] = static_cast<std::uint32_t>(m.column.size());
      m.column.push_back(c);
      m.blocks.push_back(b);
    }
    m.rowStart.push_back(static_cast<std::uint32_t>(m.column.size()));
  }
  return s;
}

double dot(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i].dot(b[i]);
  return s;
}

std::vector<Vec3d> multiply(const BlockMatrixView& a, const std::vector<Vec3d>& x) {
  std::vector<Vec3d> y(a.rows);
  for (std::size_t i = 0; i < a.rows; ++i) y[i] = blockRowProduct(a, x.data(), i);
  return y;
}

/// Conjugate gradients preconditioned by `mg` on a x = b to |r| <= 1e-8 |b|; the iterations.
int solve(const BlockMatrixView& a, Multigrid& mg, const std::vector<Vec3d>& b) {
  std::vector<Vec3d> x(a.rows, Vec3d::Zero()), r = b, z, p;
  mg.apply(a, r, z, true);
  p = z;
  double rz = dot(r, z);
  const double bb = dot(b, b);
  for (int it = 1; it <= 500; ++it) {
    const std::vector<Vec3d> q = multiply(a, p);
    const double alpha = rz / dot(p, q);
    for (std::size_t i = 0; i < a.rows; ++i) {
      x[i] += alpha * p[i];
      r[i] -= alpha * q[i];
    }
    if (dot(r, r) <= 1e-16 * bb) return it;
    mg.apply(a, r, z, true);
    const double next = dot(r, z);
    for (std::size_t i = 0; i < a.rows; ++i) p[i] = z[i] + next / rz * p[i];
    rz = next;
  }
  return 1000;
}

std::vector<Vec3d> randomVector(std::size_t n, unsigned seed) {
  std::vector<Vec3d> v(n);
  unsigned state = seed;
  auto next = [&] {
    state = state * 1664525u + 1013904223u;
    return static_cast<double>(state >> 8) / static_cast<double>(1u << 24) - 0.5;
  };
  for (Vec3d& x : v) x = Vec3d(next(), next(), next());
  return v;
}

TEST(Coarsening, InterpolatesLinearFieldsExactlyWithWeightsSummingToOne) {
  const GridSystem s = springGrid(7, 1e-3);
  const Coarsening c = coarsenRows(s.matrix.view(), s.coords, 2);
  // Points with all-even coordinates are the coarse rows: 4^3 of them.
  EXPECT_EQ(c.coords.size(), 64u);
  const Interpolation& p = c.interpolation;
  for (std::size_t i = 0; i < s.coords.size(); ++i) {
    double sum = 0.0;
    Vec3d x = Vec3d::Zero();
    for (std::uint32_t k = p.start[i]; k < p.start[i + 1]; ++k) {
      sum += p.weight[k];
      const Index3& g = c.coords[p.index[k]];
      x += p.weight[k] * Vec3d(g.x, g.y, g.z);
    }
    EXPECT_DOUBLE_EQ(sum, 1.0) << i;
    EXPECT_LE((x - Vec3d(s.coords[i].x, s.coords[i].y, s.coords[i].z)).norm(), 1e-12) << i;
  }
  // The transpose holds the same entries.
  ASSERT_EQ(p.tIndex.size(), p.index.size());
  for (std::size_t c2 = 0; c2 + 1 < p.tStart.size(); ++c2)
    for (std::uint32_t k = p.tStart[c2]; k < p.tStart[c2 + 1]; ++k) {
      const std::uint32_t i = p.tIndex[k];
      bool found = false;
      for (std::uint32_t q = p.start[i]; q < p.start[i + 1]; ++q)
        found = found || (p.index[q] == c2 && p.weight[q] == p.tWeight[k]);
      EXPECT_TRUE(found);
    }
}

TEST(Coarsening, PartsCutApartKeepTheirOwnCoarseRows) {
  // Springs across the plane between x = 2 and x = 3 cut (x = 3 is not a coarse plane): the
  // two sides must not share a coarse row, though cells of edge 4 straddle the cut.
  const auto apart = [](const Index3& a, const Index3& b) { return (a.x <= 2) == (b.x <= 2); };
  const GridSystem s = springGrid(9, 1e-3, 1, apart);
  const Coarsening c = coarsenRows(s.matrix.view(), s.coords, 4);
  const Interpolation& p = c.interpolation;
  std::vector<int> side(c.coords.size(), -1);
  for (std::size_t i = 0; i < s.coords.size(); ++i) {
    const int mine = s.coords[i].x <= 2 ? 0 : 1;
    for (std::uint32_t k = p.start[i]; k < p.start[i + 1]; ++k) {
      int& sd = side[p.index[k]];
      EXPECT_TRUE(sd == -1 || sd == mine) << "coarse row " << p.index[k] << " shared";
      sd = mine;
    }
  }
  // Without the cut the same cells give fewer coarse rows.
  const GridSystem whole = springGrid(9, 1e-3);
  EXPECT_LT(coarsenRows(whole.matrix.view(), whole.coords, 4).coords.size(), c.coords.size());
}

TEST(Multigrid, VCycleIsSymmetricPositiveDefinite) {
  const GridSystem s = springGrid(12, 1e-3);
  const BlockMatrixView a = s.matrix.view();
  Multigrid mg;
  MultigridParams params;
  params.coarsestRows = 30;
  mg.build(a, s.coords, params, true);
  ASSERT_TRUE(mg.setup(a, true));
  EXPECT_GE(mg.levelCount(), 3u);
  const std::vector<Vec3d> x = randomVector(a.rows, 1), y = randomVector(a.rows, 2);
  std::vector<Vec3d> mx, my;
  mg.apply(a, x, mx, true);
  mg.apply(a, y, my, true);
  // Symmetric up to the rounding of the smoothers' single-precision blocks.
  EXPECT_NEAR(dot(y, mx), dot(x, my), 1e-6 * std::sqrt(dot(mx, mx) * dot(y, y)));
  EXPECT_GT(dot(x, mx), 0.0);
  EXPECT_GT(dot(y, my), 0.0);
}

TEST(Multigrid, CoarsestIsTheFirstLevelWhoseFactorIsSmall) {
  // 1,728 rows, within coarsestRows: a 3D grid's factor fills in far beyond maxCoarsestFill,
  // so the hierarchy coarsens on; allowed any fill, the matrix is its own coarsest level and
  // the V-cycle is its exact inverse.
  const GridSystem s = springGrid(12, 1e-3);
  const BlockMatrixView a = s.matrix.view();
  MultigridParams params;
  Multigrid mg;
  mg.build(a, s.coords, params, true);
  EXPECT_GT(mg.levelCount(), 1u);
  params.maxCoarsestFill = 1e9;
  mg.build(a, s.coords, params, true);
  ASSERT_TRUE(mg.setup(a, true));
  EXPECT_EQ(mg.levelCount(), 1u);
  EXPECT_EQ(solve(a, mg, randomVector(a.rows, 7)), 1);
}

TEST(Multigrid, IterationsBarelyGrowWithSize) {
  // Stiff springs, light mass: the condition number grows with the square of the size.
  int iterations[2] = {};
  const int sizes[2] = {9, 25};
  for (int k = 0; k < 2; ++k) {
    const GridSystem s = springGrid(sizes[k], 1e-4);
    const BlockMatrixView a = s.matrix.view();
    Multigrid mg;
    mg.build(a, s.coords, {}, true);
    ASSERT_TRUE(mg.setup(a, true));
    iterations[k] = solve(a, mg, randomVector(a.rows, 3));
  }
  RecordProperty("iterations_small", iterations[0]);
  RecordProperty("iterations_large", iterations[1]);
  EXPECT_LT(iterations[1], 40);
  EXPECT_LE(iterations[1], 2 * iterations[0] + 2);
}

TEST(Multigrid, WeakRowsAreRelaxedTogether) {
  // Pairs of points held to the body a million times more weakly than to each other, with
  // next to no mass (the far nodes of a composite element that holds a few voxels in one
  // corner): a pair moving as one is nearly free. Single-row relaxation barely moves that
  // mode and the coarse levels, which move the pair with the body around it, cannot; each
  // pair, held by a different strength, then costs the conjugate gradients an iteration.
  auto pairOf = [](const Index3& p) {
    // Pairs (x, x + 1) at odd x, y and z inside the grid, one in every other cell.
    if (p.y % 2 == 0 || p.z % 2 == 0 || p.y > 11 || p.z > 11) return -1;
    if (p.x == 3 || p.x == 4) return 0;
    if (p.x == 7 || p.x == 8) return 1;
    return -1;
  };
  auto id = [&](const Index3& p) { return pairOf(p) < 0 ? -1 : p.y * 100 + p.z * 2 + pairOf(p); };
  const auto scale = [&](const Index3& a, const Index3& b) {
    const int ia = id(a), ib = id(b);
    if (ia < 0 && ib < 0) return 1.0;
    if (a == b) return 1e-6;            // mass
    if (ia == ib) return 1e-3;          // within a pair
    const int pair = std::max(ia, ib);  // to the body: each pair its own strength
    return 1e-9 * (1.0 + (pair % 97) * 0.37);
  };
  const GridSystem s = springGrid(13, 1e-4, 1, nullptr, scale);
  const BlockMatrixView a = s.matrix.view();
  MultigridParams grouped;
  MultigridParams single;
  single.weakRatio = 0.0;
  Multigrid g, n;
  g.build(a, s.coords, grouped, true);
  n.build(a, s.coords, single, true);
  ASSERT_TRUE(g.setup(a, true));
  ASSERT_TRUE(n.setup(a, true));
  EXPECT_GT(g.groupedRowsPerLevel()[0], 0u);
  EXPECT_EQ(n.groupedRowsPerLevel()[0], 0u);
  const std::vector<Vec3d> b = randomVector(a.rows, 4);
  const int withGroups = solve(a, g, b);
  const int without = solve(a, n, b);
  RecordProperty("with_groups", withGroups);
  RecordProperty("without_groups", without);
  EXPECT_LT(2 * withGroups, without);
}

TEST(Multigrid, SameBitsAtOneAndTwoThreads) {
  const GridSystem s = springGrid(14, 1e-3);
  const BlockMatrixView a = s.matrix.view();
  const std::vector<Vec3d> r = randomVector(a.rows, 5);
  std::vector<Vec3d> z[2];
  for (int t = 0; t < 2; ++t) {
    const ThreadLimit limit(t + 1);
    Multigrid mg;
    mg.build(a, s.coords, {}, true);
    ASSERT_TRUE(mg.setup(a, true));
    mg.apply(a, r, z[t], true);
  }
  for (std::size_t i = 0; i < a.rows; ++i) ASSERT_EQ(z[0][i], z[1][i]) << i;
}

TEST(Multigrid, CopiesApplyTheSameCycle) {
  const GridSystem s = springGrid(10, 1e-3);
  const BlockMatrixView a = s.matrix.view();
  Multigrid mg;
  mg.build(a, s.coords, {}, true);
  ASSERT_TRUE(mg.setup(a, true));
  const Multigrid copy = mg;
  Multigrid moved = copy;
  const std::vector<Vec3d> r = randomVector(a.rows, 6);
  std::vector<Vec3d> z0, z1;
  mg.apply(a, r, z0, true);
  moved.apply(a, r, z1, true);
  for (std::size_t i = 0; i < a.rows; ++i) ASSERT_EQ(z0[i], z1[i]) << i;
}

}  // namespace
}  // namespace voxcut
