// The cutting tool collision's work follows the frame, not the history: after a free body has
// been chopped into pieces lying on a floor, a blade that passes just over them and cuts
// nothing positions and tests about as many voxels and links as the same pass over the uncut
// body (FrameReport::positionedVoxels, FrameReport::testedLinks).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"

namespace voxcut {
namespace {

/// The bunny at resolution 48, element level 3, free under gravity (-y), on a floor just
/// under it.
World freeBunny() {
  const std::string json = R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
    "solver": {"tolerance": 1e-3, "max_iterations": 200},
    "bodies": [{"model": "bunny", "resolution": 48, "element_level": 3,
      "materials": {"default": {"young_modulus": 2e5, "poisson_ratio": 0.4, "density": 1000,
                                "damping": [20, 0.005]}}}]})";
  const Scene scene = parseScene(json, "cut-work.json", std::filesystem::current_path());
  World w = World::fromScene(scene, voxelizeSceneBodies(scene));
  Eigen::AlignedBox3d box;
  for (const Vec3d& x : w.surfaceMesh(w.bodies()[0]).positions) box.extend(x);
  Obstacle floor;
  floor.normal = Vec3d::UnitY();
  floor.point = box.min() - 0.25 * w.bodyInfo(w.bodies()[0]).voxelSize * Vec3d::UnitY();
  w.addObstacle(floor);
  return w;
}

double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

Eigen::AlignedBox3d surfaceBox(World& w) {
  Eigen::AlignedBox3d box;
  for (const Vec3d& x : w.surfaceMesh(w.bodies()[0]).positions) box.extend(x);
  return box;
}

/// The most work of any frame of a pass and the links it cut.
struct PassWork {
  std::size_t positioned = 0, tested = 0, cut = 0;
};

/// An upright blade a quarter of the body's size, its edge half a voxel over the top of the
/// surface (every link lies below it), drawn across the whole body along x over its highest
/// point, at three voxels a frame.
PassWork passOver(World& w, ToolId blade) {
  const double h = w.bodyInfo(w.bodies()[0]).voxelSize;
  const Eigen::AlignedBox3d box = surfaceBox(w);
  const double size = box.sizes().maxCoeff();
  // Over the highest point, so that the blade passes close over material.
  Vec3d top = box.center();
  top.y() = -std::numeric_limits<double>::infinity();
  for (const Vec3d& x : w.surfaceMesh(w.bodies()[0]).positions)
    if (x.y() > top.y()) top = x;
  Vec3d a(box.min().x() - 2.0 * h, top.y() + 0.5 * h, top.z());
  const Vec3d b = a + 0.25 * size * Vec3d::UnitY();
  w.placeTool(blade, {a, b});
  PassWork most;
  const int frames = static_cast<int>(std::ceil((box.sizes().x() + 4.0 * h) / (3.0 * h)));
  for (int f = 1; f <= frames; ++f) {
    const Vec3d d(3.0 * h * f, 0.0, 0.3 * h * f);
    w.setToolPose(blade, {a + d, b + d});
    const FrameReport r = w.step();
    most.positioned = std::max(most.positioned, r.positionedVoxels);
    most.tested = std::max(most.tested, r.testedLinks);
    most.cut += r.cutLinks;
  }
  return most;
}

TEST(CutWork, ABladeThatCutsNothingCostsWhatItCostsOverTheUncutBody) {
  World w = freeBunny();
  const double h = w.bodyInfo(w.bodies()[0]).voxelSize;
  const Eigen::AlignedBox3d start = surfaceBox(w);
  const ToolId blade =
      w.addBlade({start.min() - start.sizes(), start.min() - start.sizes() + Vec3d(h, 0, 0)});
  for (int f = 0; f < 10; ++f) (void)w.step();
  const PassWork before = passOver(w, blade);
  ASSERT_EQ(before.cut, 0u);

  // Chopped: blades longer than the body drawn right through it at four voxels a frame,
  // upright across x or z at a random place, every third one level at a random height.
  std::mt19937_64 rng(7);
  std::size_t cutLinks = 0;
  for (int c = 0; c < 8; ++c) {
    const Eigen::AlignedBox3d box = surfaceBox(w);
    const Vec3d lo = box.min(), hi = box.max(), size = box.sizes();
    const bool flip = (rng() & 1) != 0;
    const int across = flip ? 0 : 2, along = flip ? 2 : 0;
    Vec3d a0 = Vec3d::Zero(), b0 = Vec3d::Zero();
    if (c % 3 == 2) {
      a0.y() = b0.y() = uniform(rng, lo.y() + 0.2 * size.y(), hi.y() - 0.2 * size.y());
      a0[across] = lo[across] - 0.1 * size[across];
      b0[across] = hi[across] + 0.1 * size[across];
    } else {
      a0[across] = b0[across] =
          uniform(rng, lo[across] + 0.2 * size[across], hi[across] - 0.2 * size[across]);
      a0.y() = lo.y() - 0.1 * size.y();
      b0.y() = hi.y() + 0.1 * size.y();
    }
    a0[along] = b0[along] = lo[along] - 2.0 * h;
    Vec3d a1 = a0, b1 = b0;
    a1[along] = b1[along] = hi[along] + 2.0 * h;
    w.placeTool(blade, {a0, b0});
    const int frames = static_cast<int>(std::ceil((a1 - a0).norm() / (4.0 * h)));
    for (int f = 1; f <= frames; ++f) {
      const double t = static_cast<double>(f) / frames;
      w.setToolPose(blade, {a0 + t * (a1 - a0), b0 + t * (b1 - b0)});
      cutLinks += w.step().cutLinks;
    }
    for (int f = 0; f < 5; ++f) (void)w.step();
  }
  for (int f = 0; f < 20; ++f) (void)w.step();
  ASSERT_GT(cutLinks, 1000u);
  ASSERT_GT(w.pieces(w.bodies()[0]), 3);

  const PassWork after = passOver(w, blade);
  std::printf("a pass over the body: %zu voxels positioned, %zu links tested at most in a frame "
              "before the cuts; %zu and %zu after %zu cuts in %d pieces\n",
              before.positioned, before.tested, after.positioned, after.tested, cutLinks,
              w.pieces(w.bodies()[0]));
  EXPECT_EQ(after.cut, 0u);
  // Within a small factor (the pieces lie in other places than the body did), and no more
  // than a few layers of voxels under the blade's path: a few hundred, where a blade whose
  // reach covered the body positioned and tested tens of thousands.
  EXPECT_LE(after.positioned, 3 * before.positioned + 500);
  EXPECT_LE(after.tested, 3 * before.tested + 500);
}

}  // namespace
}  // namespace voxcut
