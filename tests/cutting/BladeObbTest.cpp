// The oriented bounding box of a blade sweep and its overlap tests.

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "voxcut/cutting/Blade.h"

namespace voxcut {
namespace {

std::vector<BladeSweep> sampleSweeps(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto rnd = [&] { return Vec3d(unit(rng), unit(rng), unit(rng)); };
  std::vector<BladeSweep> sweeps;
  for (int n = 0; n < 200; ++n) {
    const double scale = n % 3 == 0 ? 0.05 : (n % 3 == 1 ? 1.0 : 300.0);
    const Vec3d offset = scale * 10 * rnd();
    const BladePose from{offset + scale * rnd(), offset + scale * rnd()};
    const BladePose to{offset + scale * rnd(), offset + scale * rnd()};
    sweeps.push_back(makeSweep(from, to, 0));
  }
  // Degenerate motions: none, along the blade, a zero-length blade, a single point, a pivot.
  const BladePose p{Vec3d(0.1, 0.2, 0.3), Vec3d(0.5, -0.2, 0.9)};
  const Vec3d d = p.b - p.a;
  sweeps.push_back(makeSweep(p, p, 0));
  sweeps.push_back(makeSweep(p, {p.a + 0.5 * d, p.b + 0.5 * d}, 0));
  sweeps.push_back(makeSweep({p.a, p.a}, {p.b, p.b}, 0));
  sweeps.push_back(makeSweep({p.a, p.a}, {p.a, p.a}, 0));
  sweeps.push_back(makeSweep(p, {p.a, p.a + Vec3d(0, 0.4, 0)}, 0));
  return sweeps;
}

TEST(BladeObb, HoldsEverySweepPointAndHasOrthonormalAxes) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  for (const BladeSweep& s : sampleSweeps(rng)) {
    for (const double margin : {0.0, 0.01}) {
      const Obb obb = sweepObb(s, margin);
      EXPECT_LT((obb.axes.transpose() * obb.axes - Eigen::Matrix3d::Identity()).norm(), 1e-14);
      EXPECT_GT(obb.axes.determinant(), 0.0);
      for (const Vec3d& c : s.corners) ASSERT_TRUE(contains(obb, c));
      for (int n = 0; n < 2000; ++n) {
        double w1 = u01(rng), w2 = u01(rng);
        if (w1 + w2 > 1) {
          w1 = 1 - w1;
          w2 = 1 - w2;
        }
        const auto& t = BladeSweep::kTriangles[n % 2];
        const Vec3d p =
            (1 - w1 - w2) * s.corners[t[0]] + w1 * s.corners[t[1]] + w2 * s.corners[t[2]];
        ASSERT_TRUE(contains(obb, p)) << p.transpose();
        if (margin > 0) {
          const Vec3d away = p + 0.999 * margin * Vec3d::Random().normalized();
          ASSERT_TRUE(contains(obb, away));
        }
      }
    }
  }
}

TEST(BladeObb, TightForAPlanarRectangle) {
  const BladeSweep s =
      makeSweep({Vec3d(0, 0, 0), Vec3d(2, 0, 0)}, {Vec3d(0, 1, 0), Vec3d(2, 1, 0)}, 0);
  const Obb obb = sweepObb(s, 0.1);
  EXPECT_NEAR((obb.centre - Vec3d(1, 0.5, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((obb.halfExtents - Vec3d(1.1, 0.6, 0.1)).norm(), 0.0, 1e-9);
  EXPECT_FALSE(contains(obb, Vec3d(1, 0.5, 0.2)));
  EXPECT_FALSE(contains(obb, Vec3d(2.2, 0.5, 0)));
}

TEST(BladeObb, FarBoxesDoNotOverlapTouchingAndContainedOnesDo) {
  std::mt19937_64 rng(32);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const BladeSweep& s : sampleSweeps(rng)) {
    const Obb obb = sweepObb(s, 0.0);
    const double r = obb.halfExtents.norm();
    for (int n = 0; n < 50; ++n) {
      const Vec3d dir = Vec3d(unit(rng), unit(rng), unit(rng)).normalized();
      const Vec3d half = r * Vec3d(0.5 + unit(rng) * 0.4, 0.5, 0.7);
      const Vec3d far = obb.centre + dir * (3 * r + half.norm() + 1e-3);
      EXPECT_FALSE(overlaps(obb, Eigen::AlignedBox3d(far - half, far + half)));
      // A box around a point of the OBB overlaps it.
      const Vec3d inside = obb.centre + obb.axes * obb.halfExtents.cwiseProduct(
                                                       Vec3d(unit(rng), unit(rng), unit(rng)));
      EXPECT_TRUE(overlaps(obb, Eigen::AlignedBox3d(inside - half, inside + half)));
      EXPECT_TRUE(overlaps(obb, Eigen::AlignedBox3d(inside, inside)));
    }
    // Boxes touching the OBB at its extreme vertex along each world axis, from outside.
    for (int axis = 0; axis < 3; ++axis) {
      for (const double side : {-1.0, 1.0}) {
        Vec3d v = obb.centre;
        for (int k = 0; k < 3; ++k) {
          const double sgn = obb.axes(axis, k) * side >= 0 ? 1.0 : -1.0;
          v += sgn * obb.halfExtents[k] * obb.axes.col(k);
        }
        Vec3d lo = v - Vec3d::Constant(0.5 * r + 1e-3), hi = v + Vec3d::Constant(0.5 * r + 1e-3);
        if (side > 0)
          lo[axis] = v[axis];
        else
          hi[axis] = v[axis];
        EXPECT_TRUE(overlaps(obb, Eigen::AlignedBox3d(lo, hi)));
        // Moved away along the axis by a visible gap, it is separated.
        const double gap = 1e-6 * (1 + r) * side;
        lo[axis] += gap;
        hi[axis] += gap;
        EXPECT_FALSE(overlaps(obb, Eigen::AlignedBox3d(lo, hi)));
      }
    }
  }
}

// Never misses: random boxes that contain some point of the OBB always overlap it.
TEST(BladeObb, NeverMissesATrueOverlap) {
  std::mt19937_64 rng(33);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto sweeps = sampleSweeps(rng);
  int overlapping = 0;
  for (int n = 0; n < 200000; ++n) {
    const BladeSweep& s = sweeps[static_cast<std::size_t>(n) % sweeps.size()];
    const Obb obb = sweepObb(s, 0.0);
    const double r = obb.halfExtents.norm() + 1e-9;
    const Vec3d c = obb.centre + 1.5 * r * Vec3d(unit(rng), unit(rng), unit(rng));
    const Vec3d half = r * Vec3d(unit(rng), unit(rng), unit(rng)).cwiseAbs();
    const Eigen::AlignedBox3d box(c - half, c + half);
    bool truth = false;
    for (int k = 0; k < 64 && !truth; ++k) {
      const Vec3d q = obb.centre + obb.axes * obb.halfExtents.cwiseProduct(
                                                  Vec3d(unit(rng), unit(rng), unit(rng)));
      truth = box.contains(q);
    }
    if (truth) {
      ++overlapping;
      ASSERT_TRUE(overlaps(obb, box)) << n;
    }
  }
  EXPECT_GT(overlapping, 10000);
  EXPECT_FALSE(overlaps(sweepObb(sweeps[0], 0.0), Eigen::AlignedBox3d()));  // empty box
}

}  // namespace
}  // namespace voxcut
