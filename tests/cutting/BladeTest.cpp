// Blade sweeps: construction, exact crossings and consistent tie-breaking.

#include <gtest/gtest.h>

#include <algorithm>
#include <initializer_list>
#include <random>
#include <utility>
#include <vector>

#include "voxcut/core/Predicates.h"
#include "voxcut/cutting/Blade.h"

namespace voxcut {
namespace {

__extension__ typedef __int128 I128;

/// Number of triangles of all sweeps that the segment crosses.
int countHits(const std::vector<BladeSweep>& sweeps, const Vec3d& p0, const Vec3d& p1,
              std::uint64_t id0 = 0, std::uint64_t id1 = 1) {
  int hits = 0;
  for (const BladeSweep& s : sweeps) {
    for (int t = 0; t < 2; ++t) hits += intersectTriangle(s, t, p0, p1, id0, id1) ? 1 : 0;
  }
  return hits;
}

/// Consecutive sweeps through the poses, frames 0, 1, ...
std::vector<BladeSweep> sweepsThrough(const std::vector<BladePose>& poses) {
  std::vector<BladeSweep> sweeps;
  for (std::size_t k = 0; k + 1 < poses.size(); ++k) {
    sweeps.push_back(makeSweep(poses[k], poses[k + 1], k));
  }
  return sweeps;
}

TEST(Blade, SweepLayoutAndIds) {
  const BladePose p0{Vec3d(0, 0, 0), Vec3d(1, 0, 0)}, p1{Vec3d(0, 1, 0), Vec3d(1, 1, 0)};
  const BladeSweep s = makeSweep(p0, p1, 5);
  EXPECT_EQ(s.corners[0], p0.a);
  EXPECT_EQ(s.corners[1], p0.b);
  EXPECT_EQ(s.corners[2], p1.b);
  EXPECT_EQ(s.corners[3], p1.a);
  const BladeSweep next = makeSweep(p1, p0, 6);
  EXPECT_EQ(s.ids[3], next.ids[0]);  // a of the shared pose
  EXPECT_EQ(s.ids[2], next.ids[1]);  // b of the shared pose
  EXPECT_EQ(s.ids[0], 10u);
  EXPECT_EQ(s.ids[1], 11u);
  // Normal = blade x motion.
  EXPECT_NEAR((s.normals[0] - Vec3d::UnitZ()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((s.normals[1] - Vec3d::UnitZ()).norm(), 0.0, 1e-15);
}

TEST(Blade, SimpleCrossingParameterAndNormal) {
  const auto sweeps =
      sweepsThrough({{Vec3d(0, 0, 0), Vec3d(1, 0, 0)}, {Vec3d(0, 1, 0), Vec3d(1, 1, 0)}});
  const auto hit = intersectSegment(sweeps[0], Vec3d(0.3, 0.6, -1), Vec3d(0.3, 0.6, 3));
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->t, 0.25, 1e-15);
  EXPECT_NEAR((hit->normal - Vec3d::UnitZ()).norm(), 0.0, 1e-15);
  EXPECT_FALSE(intersectSegment(sweeps[0], Vec3d(0.3, 0.6, 1), Vec3d(0.3, 0.6, 3)));
  EXPECT_FALSE(intersectSegment(sweeps[0], Vec3d(1.3, 0.6, -1), Vec3d(1.3, 0.6, 3)));
  // Nearly touching: clamped parameter.
  const auto near = intersectSegment(sweeps[0], Vec3d(0.3, 0.6, -1e-12), Vec3d(0.3, 0.6, 1));
  ASSERT_TRUE(near);
  EXPECT_EQ(near->t, 1e-6);
}

// Segments through points of the shared diagonal, in many directions, planar and twisted
// patches: exactly one of the two triangles.
TEST(Blade, SegmentThroughTheDiagonalIsCountedOnce) {
  for (const double lift : {0.0, 4.0, -2.0}) {
    const BladeSweep s =
        makeSweep({Vec3d(0, 0, 0), Vec3d(4, 0, 0)}, {Vec3d(0, 4, 0), Vec3d(4, 4, lift)}, 3);
    for (int k = 1; k < 8; ++k) {
      const Vec3d c = (k / 8.0) * s.corners[2];  // on the diagonal a0 b1, exactly
      for (int dx = -2; dx <= 2; ++dx) {
        for (int dy = -2; dy <= 2; ++dy) {
          const Vec3d d(dx / 8.0, dy / 8.0, 1.0);
          for (const auto& [i0, i1] :
               std::initializer_list<std::pair<int, int>>{{0, 1}, {1, 0}, {17, 4}}) {
            ASSERT_EQ(countHits({s}, c - d, c + d, i0, i1), 1) << lift << " " << k;
            ASSERT_EQ(countHits({s}, c + d, c - d, i0, i1), 1);
          }
        }
      }
    }
  }
}

// Two adjacent sweeps in the plane z = 0 and a dense lattice of parallel segments (vertical
// and oblique) through lattice points, many of them on diagonals, on the shared edge and on
// vertices: every point strictly inside the union is counted exactly once, points on its
// boundary at most once, points outside never.
TEST(Blade, WatertightPlanarLattice) {
  const auto sweeps = sweepsThrough({{Vec3d(0, 0, 0), Vec3d(8, 0, 0)},
                                     {Vec3d(0, 8, 0), Vec3d(8, 8, 0)},
                                     {Vec3d(2, 16, 0), Vec3d(10, 16, 0)}});
  // Union: 0 <= y <= 16, x_left(y) <= x <= x_left(y) + 8, x_left = max(0, (y - 8) / 4).
  int interior = 0;
  for (const Vec3d& d : {Vec3d(0, 0, 1), Vec3d(0.25, 0.5, 1), Vec3d(-1, 0.75, 0.5)}) {
    for (int i = -2; i <= 24; ++i) {
      for (int j = -2; j <= 36; ++j) {
        const Vec3d c(i / 2.0, j / 2.0, 0.0);
        const double left = std::max(0.0, (c.y() - 8) / 4);
        const bool inside = c.y() > 0 && c.y() < 16 && c.x() > left && c.x() < left + 8;
        const bool outside = c.y() < 0 || c.y() > 16 || c.x() < left || c.x() > left + 8;
        const std::uint64_t id = 2 * static_cast<std::uint64_t>((i + 2) + 100 * (j + 2));
        const int hits = countHits(sweeps, c - d, c + d, id, id + 1);
        if (inside) {
          ASSERT_EQ(hits, 1) << c.transpose() << " dir " << d.transpose();
          ++interior;
        } else if (outside) {
          ASSERT_EQ(hits, 0) << c.transpose();
        } else {
          ASSERT_LE(hits, 1) << c.transpose();
        }
      }
    }
  }
  EXPECT_GT(interior, 1000);
}

// The same with non-planar sweeps (each triangle a graph z = f(x, y) with slope <= 1/2) and
// vertical segments, and with a pause (a sweep of zero motion) between two moves.
TEST(Blade, WatertightTwistedSweepsAndPause) {
  const BladePose p0{Vec3d(0, 0, 0), Vec3d(8, 0, 0)}, p1{Vec3d(0, 8, 0), Vec3d(8, 8, 4)};
  const BladePose p2{Vec3d(0, 16, 4), Vec3d(8, 16, -4)};
  for (const auto& sweeps : {sweepsThrough({p0, p1, p2}), sweepsThrough({p0, p1, p1, p2})}) {
    for (int i = -1; i <= 17; ++i) {
      for (int j = -1; j <= 33; ++j) {
        const Vec3d c(i / 2.0, j / 2.0, 0.0);
        const bool inside = c.x() > 0 && c.x() < 8 && c.y() > 0 && c.y() < 16;
        const bool outside = c.x() < 0 || c.x() > 8 || c.y() < 0 || c.y() > 16;
        const std::uint64_t id = 2 * static_cast<std::uint64_t>(i + 1 + 100 * (j + 1));
        const int hits = countHits(sweeps, c - Vec3d(0, 0, 20), c + Vec3d(0, 0, 20), id, id + 1);
        if (inside) {
          ASSERT_EQ(hits, 1) << c.transpose() << " sweeps " << sweeps.size();
        }
        if (outside) {
          ASSERT_EQ(hits, 0) << c.transpose();
        }
        if (!inside && !outside) {
          ASSERT_LE(hits, 1) << c.transpose();
        }
      }
    }
  }
}

// Voxels on an integer lattice, many exactly on the (tilted, planar) swept surface
// z = (x + y) / 4; links between lattice neighbours carry the voxel indices as ids. Along
// every grid line, the number of cut links is 1 when the line meets the surface strictly
// inside the sweep, 0 when outside, at most 1 on its boundary; a voxel exactly on the
// surface is on one side for both of its links.
TEST(Blade, VoxelsOnTheSurfaceAreOnOneSide) {
  const auto sweeps = sweepsThrough({{Vec3d(0, 0, 0), Vec3d(8, 0, 2)},
                                     {Vec3d(0, 8, 2), Vec3d(8, 8, 4)},
                                     {Vec3d(0, 16, 4), Vec3d(8, 16, 6)}});
  const int lo[3] = {-2, -2, -2}, hi[3] = {10, 18, 8};
  const auto id = [&](const int* v) {
    return static_cast<std::uint64_t>((v[0] - lo[0]) + 20 * ((v[1] - lo[1]) + 30 * (v[2] - lo[2])));
  };
  int checkedInside = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    for (int iu = lo[u]; iu <= hi[u]; ++iu) {
      for (int iw = lo[w]; iw <= hi[w]; ++iw) {
        int cuts = 0;
        for (int k = lo[axis]; k < hi[axis]; ++k) {
          int v0[3], v1[3];
          v0[u] = v1[u] = iu;
          v0[w] = v1[w] = iw;
          v0[axis] = k;
          v1[axis] = k + 1;
          const Vec3d p0(v0[0], v0[1], v0[2]), p1(v1[0], v1[1], v1[2]);
          for (const BladeSweep& s : sweeps)
            cuts += intersectSegment(s, p0, p1, id(v0), id(v1)) ? 1 : 0;
        }
        // Where the grid line meets the plane 4z = x + y, times 4 (exact integers).
        Vec3d c = Vec3d::Zero();
        c[u] = iu;
        c[w] = iw;
        const double x4 = 4 * (axis == 0 ? 4 * c.z() - c.y() : c.x());
        const double y4 = 4 * (axis == 1 ? 4 * c.z() - c.x() : c.y());
        const bool inside = x4 > 0 && x4 < 32 && y4 > 0 && y4 < 64;
        const bool outside = x4 < 0 || x4 > 32 || y4 < 0 || y4 > 64;
        if (inside) ++checkedInside;
        if (inside) {
          ASSERT_EQ(cuts, 1) << "axis " << axis << " at " << iu << "," << iw;
        }
        if (outside) {
          ASSERT_EQ(cuts, 0) << "axis " << axis << " at " << iu << "," << iw;
        }
        ASSERT_LE(cuts, 1);
      }
    }
  }
  EXPECT_GT(checkedInside, 150);
}

// A link lying in the blade's plane is not cut; of two collinear links meeting at a voxel on
// the plane, exactly one is, whichever the order of the ends.
TEST(Blade, LinksInThePlaneAndThroughAVoxelOnIt) {
  const auto sweeps =
      sweepsThrough({{Vec3d(0, 0, 0), Vec3d(4, 0, 0)}, {Vec3d(0, 4, 0), Vec3d(4, 4, 0)}});
  EXPECT_FALSE(intersectSegment(sweeps[0], Vec3d(1, 1, 0), Vec3d(2, 1, 0), 5, 6));
  EXPECT_FALSE(intersectSegment(sweeps[0], Vec3d(-1, 2, 0), Vec3d(5, 2, 0), 5, 6));
  for (const Vec3d& v : {Vec3d(1, 1, 0), Vec3d(2, 2, 0), Vec3d(4, 2, 0), Vec3d(1, 0, 0)}) {
    const Vec3d below = v - Vec3d(0.5, 0.25, 1), above = v + Vec3d(0.5, 0.25, 1);
    const bool lower = intersectSegment(sweeps[0], below, v, 7, 8).has_value();
    const bool upper = intersectSegment(sweeps[0], v, above, 8, 9).has_value();
    EXPECT_EQ(lower, intersectSegment(sweeps[0], v, below, 8, 7).has_value());
    EXPECT_EQ(upper, intersectSegment(sweeps[0], above, v, 9, 8).has_value());
    if (v.x() > 0 && v.x() < 4 && v.y() > 0 && v.y() < 4) {
      EXPECT_NE(lower, upper) << v.transpose();
      EXPECT_TRUE(lower);  // the voxel counts as displaced towards +z
    } else {
      EXPECT_FALSE(lower && upper);
    }
  }
}

// A segment crossing a twisted patch twice reports the first crossing.
TEST(Blade, TwiceCrossedTwistedPatchGivesTheFirstHit) {
  const BladeSweep s =
      makeSweep({Vec3d(0, 0, 0), Vec3d(4, 0, 0)}, {Vec3d(0, 4, 0), Vec3d(4, 4, 8)}, 0);
  const Vec3d p0(0.5, 3.5, 1.5), p1(3.5, 0.5, 1.5);
  EXPECT_EQ(countHits({s}, p0, p1), 2);
  const auto hit = intersectSegment(s, p0, p1);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->triangle, 1);
  EXPECT_NEAR(hit->t, 1.0 / 12.0, 1e-14);
  EXPECT_NEAR(intersectSegment(s, p1, p0)->t, 1.0 / 12.0, 1e-14);
}

TEST(Blade, DegenerateSweepsHaveUnitNormals) {
  const BladePose p{Vec3d(0, 0, 0), Vec3d(1, 0, 0)};
  for (const BladeSweep& s : {makeSweep(p, p, 0), makeSweep(p, {Vec3d(2, 0, 0), Vec3d(3, 0, 0)}, 0),
                              makeSweep(p, {Vec3d(0, 0, 0), Vec3d(0, 1, 0)}, 0)}) {
    for (const Vec3d& n : s.normals) {
      EXPECT_NEAR(n.norm(), 1.0, 1e-15);
      EXPECT_NEAR(n.dot(Vec3d::UnitX()), 0.0, 1e-15);
    }
    // Far from the blade's path: nothing.
    EXPECT_FALSE(intersectSegment(s, Vec3d(0.5, 3, -1), Vec3d(0.5, 3, 1)));
  }
  const BladeSweep still = makeSweep(p, p, 0);
  EXPECT_FALSE(intersectSegment(still, Vec3d(0.5, 0.5, -1), Vec3d(0.5, 0.5, 1)));
  // Exactly through the standing blade: decided by the perturbation, at most once.
  EXPECT_LE(countHits({still}, Vec3d(0.5, 0, -1), Vec3d(0.5, 0, 1)), 1);
}

// The per-triangle shortcut for voxels exactly on a triangle's plane agrees with the full
// simulation of simplicity, for any voxel position on the plane and any voxel id.
TEST(Blade, OnPlaneSideMatchesFullSimulationOfSimplicity) {
  std::mt19937_64 rng(23);
  std::uniform_int_distribution<int> dist(-3, 3);
  const auto rnd = [&] { return Vec3d(dist(rng), dist(rng), dist(rng)); };
  int checked = 0;
  for (int n = 0; n < 20000; ++n) {
    const BladeSweep s = makeSweep({rnd(), rnd()}, {rnd(), rnd()}, n % 7);
    for (int t = 0; t < 2; ++t) {
      const auto& x = BladeSweep::kTriangles[t];
      const Vec3d &a = s.corners[x[0]], &b = s.corners[x[1]], &c = s.corners[x[2]];
      const Vec3d p =
          a + static_cast<double>(dist(rng)) * (b - a) + static_cast<double>(dist(rng)) * (c - a);
      const int full = orient3dSoS(a, b, c, p, {1, s.ids[x[0]]}, {1, s.ids[x[1]]}, {1, s.ids[x[2]]},
                                   {0, rng() % 1000});
      if (s.onPlaneSide[t] != 0) {
        ASSERT_EQ(s.onPlaneSide[t], full) << n;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 10000);
}

/// Exact orient3d on integer-valued doubles (|coordinates| < 2^30).
I128 volume(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const auto i = [](double x) { return static_cast<I128>(x); };
  const I128 ux = i(b.x()) - i(a.x()), uy = i(b.y()) - i(a.y()), uz = i(b.z()) - i(a.z());
  const I128 vx = i(c.x()) - i(a.x()), vy = i(c.y()) - i(a.y()), vz = i(c.z()) - i(a.z());
  const I128 wx = i(d.x()) - i(a.x()), wy = i(d.y()) - i(a.y()), wz = i(d.z()) - i(a.z());
  return ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx);
}

// Random integer sweeps and segments: wherever the configuration is not degenerate, the
// decision matches exact integer arithmetic and t matches the exact ratio of volumes.
TEST(Blade, RandomCrossingsMatchExactIntegerReference) {
  std::mt19937_64 rng(21);
  int crossings = 0, compared = 0;
  for (int n = 0; n < 200000; ++n) {
    const std::int64_t range = n % 2 == 0 ? 8 : (1 << 20);
    std::uniform_int_distribution<std::int64_t> dist(-range, range);
    const auto rnd = [&] {
      return Vec3d(static_cast<double>(dist(rng)), static_cast<double>(dist(rng)),
                   static_cast<double>(dist(rng)));
    };
    const BladeSweep s = makeSweep({rnd(), rnd()}, {rnd(), rnd()}, n);
    const Vec3d p0 = rnd(), p1 = rnd();
    if (p0 == p1) continue;
    const auto hit = intersectSegment(s, p0, p1, 2 * n, 2 * n + 1);
    int referenceHits = 0;
    bool degenerate = false;
    double referenceT = 2.0, tolerance = 0.0;
    for (int t = 0; t < 2; ++t) {
      const auto& x = BladeSweep::kTriangles[t];
      const Vec3d &a = s.corners[x[0]], &b = s.corners[x[1]], &c = s.corners[x[2]];
      const I128 d0 = volume(a, b, c, p0), d1 = volume(a, b, c, p1);
      const I128 e0 = volume(p0, p1, a, b), e1 = volume(p0, p1, b, c), e2 = volume(p0, p1, c, a);
      degenerate = degenerate || d0 == 0 || d1 == 0 || e0 == 0 || e1 == 0 || e2 == 0;
      if ((d0 > 0) != (d1 > 0) && (e0 > 0) == (e1 > 0) && (e1 > 0) == (e2 > 0)) {
        ++referenceHits;
        const long double tt = static_cast<long double>(d0) / static_cast<long double>(d0 - d1);
        const double clamped = static_cast<double>(std::clamp(tt, 1e-6L, 1 - 1e-6L));
        if (clamped < referenceT) {
          referenceT = clamped;
          // Rounding in t grows as the segment turns parallel to the plane.
          const double along = std::abs((p1 - p0).dot(s.normals[t]));
          tolerance = 1e-12 * (1.0 + 8.0 * static_cast<double>(range) / along);
        }
      }
    }
    if (degenerate) continue;
    ++compared;
    ASSERT_EQ(hit.has_value(), referenceHits > 0) << n;
    if (hit) {
      ++crossings;
      EXPECT_NEAR(hit->t, referenceT, tolerance) << n;
    }
  }
  EXPECT_GT(compared, 100000);
  EXPECT_GT(crossings, 5000);
}

// Random real-valued sweeps against a long double evaluation, where it is unambiguous.
TEST(Blade, RandomRealCrossingsMatchLongDouble) {
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto rnd = [&] { return Vec3d(unit(rng), unit(rng), unit(rng)); };
  using V = Eigen::Matrix<long double, 3, 1>;
  const auto vol = [](const V& a, const V& b, const V& c, const V& d) {
    return (b - a).cross(c - a).dot(d - a);
  };
  int compared = 0;
  for (int n = 0; n < 100000; ++n) {
    const BladeSweep s = makeSweep({rnd(), rnd()}, {rnd(), rnd()}, 0);
    const Vec3d p0 = rnd(), p1 = rnd();
    bool clear = true, crosses = false;
    for (int t = 0; t < 2; ++t) {
      const auto& x = BladeSweep::kTriangles[t];
      const V a = s.corners[x[0]].cast<long double>(), b = s.corners[x[1]].cast<long double>();
      const V c = s.corners[x[2]].cast<long double>();
      const V q0 = p0.cast<long double>(), q1 = p1.cast<long double>();
      const long double v[5] = {vol(a, b, c, q0), vol(a, b, c, q1), vol(q0, q1, a, b),
                                vol(q0, q1, b, c), vol(q0, q1, c, a)};
      for (const long double x5 : v) clear = clear && std::abs(x5) > 1e-12L;
      crosses = crosses ||
                ((v[0] > 0) != (v[1] > 0) && (v[2] > 0) == (v[3] > 0) && (v[3] > 0) == (v[4] > 0));
    }
    if (!clear) continue;
    ++compared;
    ASSERT_EQ(intersectSegment(s, p0, p1).has_value(), crosses) << n;
  }
  EXPECT_GT(compared, 90000);
}

// Flat sweeps (a blade moving within its own plane): intersectSegment takes a shorter way there
// (BladeSweep::flat). On small integer coordinates, where segments run through corners, edges,
// the diagonal and the plane itself, it must decide exactly as the triangles tested one by one.
TEST(Blade, FlatSweepsDecideAsTheTrianglesOneByOne) {
  std::mt19937_64 rng(23);
  std::uniform_int_distribution<int> small(-3, 3);
  int flat = 0, hits = 0, onPlane = 0;
  for (int n = 0; n < 4000; ++n) {
    // A blade in a coordinate plane or a plane through a lattice diagonal, moving within it;
    // every fourth one goes to any pose in the plane (turning, or folding the sweep over its
    // diagonal: then not flat).
    const int kind = n % 3;
    const auto inPlane = [&] {
      Vec3d p(0.5 * small(rng), 0.5 * small(rng), 0.5 * small(rng));
      if (kind == 0) p.z() = 0.5;    // z = 1/2
      if (kind == 1) p.y() = 0.0;    // y = 0
      if (kind == 2) p.z() = p.x();  // x = z
      return p;
    };
    const BladePose from{inPlane(), inPlane()};
    BladePose to{from.a + Vec3d(1, 0, 1), from.b + Vec3d(1, 0, 1)};
    if (kind == 1) to = {from.a + Vec3d(0.5, 0, 1.5), from.b + Vec3d(0.5, 0, 1.5)};
    if (n % 4 == 0) to = {inPlane(), inPlane()};
    const BladeSweep s = makeSweep(from, to, static_cast<std::uint64_t>(n));
    if (!s.flat) continue;
    ++flat;
    for (int m = 0; m < 200; ++m) {
      const Vec3d p0(0.5 * small(rng), 0.5 * small(rng), 0.5 * small(rng));
      const Vec3d p1(0.5 * small(rng), 0.5 * small(rng), 0.5 * small(rng));
      if (p0 == p1) continue;
      const std::uint64_t id0 = static_cast<std::uint64_t>(m),
                          id1 = 1000 + static_cast<std::uint64_t>(m);
      const auto h0 = intersectTriangle(s, 0, p0, p1, id0, id1);
      const auto h1 = intersectTriangle(s, 1, p0, p1, id0, id1);
      const auto hit = intersectSegment(s, p0, p1, id0, id1);
      ASSERT_EQ(hit.has_value(), h0.has_value() || h1.has_value()) << n << " " << m;
      if (!hit) continue;
      ++hits;
      const int expected = h0 && (!h1 || h0->t <= h1->t) ? 0 : 1;
      EXPECT_EQ(hit->triangle, expected) << n << " " << m;
      onPlane += (std::abs(s.normals[0].dot(p0 - s.corners[0])) < 1e-12 ||
                  std::abs(s.normals[0].dot(p1 - s.corners[0])) < 1e-12)
                     ? 1
                     : 0;
    }
  }
  EXPECT_GT(flat, 2000);
  EXPECT_GT(hits, 20000);
  EXPECT_GT(onPlane, 1000);  // ends on the plane: the general way
}

TEST(Blade, FlatOnlyWhenCoplanarWithTheTrianglesOnEitherSideOfTheDiagonal) {
  const BladePose a{{0, 0, 0}, {1, 0, 0}};
  EXPECT_TRUE(makeSweep(a, {{0, 0, 1}, {1, 0, 1}}, 0).flat);     // pushed within its plane
  EXPECT_TRUE(makeSweep(a, {{0.5, 0, 1}, {2, 0, 2}}, 0).flat);   // turning within it
  EXPECT_FALSE(makeSweep(a, {{0, 0, 1}, {1, 0.5, 1}}, 0).flat);  // twisted
  EXPECT_FALSE(makeSweep(a, {{0, 0, 0}, {1, 0, 0}}, 0).flat);    // not moving
  // c1 and c3 on the same side of the diagonal c0-c2: the triangles overlap.
  EXPECT_FALSE(makeSweep(a, {{1.5, 0, 0.25}, {2, 0, 1}}, 0).flat);
}

}  // namespace
}  // namespace voxcut
