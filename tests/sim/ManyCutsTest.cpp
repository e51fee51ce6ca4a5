// Many cuts on one body, as a user makes them: the deformation mesh stays bounded (refinement
// follows the cuts' fronts and is undone behind them), every piece cut off separates, surfaces
// stay closed, and the cuts are the same with and without the voxel octree and for any thread
// count.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <utility>

#include "voxcut/core/Parallel.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"

namespace voxcut {
namespace {

/// The bunny at resolution 80, element level 3, its base fixed, on a floor, under gravity.
World bunnyWorld(bool octree) {
  const std::string json = R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
    "solver": {"tolerance": 1e-3, "max_iterations": 200},
    "bodies": [{"model": "bunny", "resolution": 80, "element_level": 3,
      "materials": {"default": {"young_modulus": 1e6, "poisson_ratio": 0.4, "density": 1000,
                                "damping": [20, 0.005]}},
      "fixed": [{"box": [[-1, -1, -1], [1, 0.004, 1]]}]}],
    "obstacles": [{"type": "plane", "point": [0, -0.001, 0], "normal": [0, 1, 0]}]})";
  const Scene scene = parseScene(json, "many-cuts.json", std::filesystem::current_path());
  WorldSettings base;
  base.useOctree = octree;
  return World::fromScene(scene, voxelizeSceneBodies(scene), base);
}

/// Uniform in [lo, hi) from a 64-bit generator (the same on every standard library).
double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

/// Whether every edge of the mesh has exactly two triangles, in opposite directions.
bool closed(const SurfaceMesh& m) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)]}];
  for (const auto& [edge, count] : directed) {
    if (count != 1) return false;
    const auto back = directed.find({edge.second, edge.first});
    if (back == directed.end() || back->second != 1) return false;
  }
  return true;
}

struct ManyCutsResult {
  std::uint64_t hash = 0;
  std::size_t nodesStart = 0, nodesEnd = 0, nodesMax = 0, cutLinks = 0;
  int pieces = 0;
  std::string selfCheck;  // World::selfCheck at the end
  bool closedSurface = false;
};

/// 50 cuts by one blade, as a user makes them: mostly scalpel strokes from above (a blade a
/// third of the body's height, tilted, sinking to a random depth and drawn across part of the
/// body), some stopping inside, some crossing earlier ones; every fifth a horizontal slice
/// through the whole body above its base, which cuts a piece off. Each swept over 6 frames,
/// then 40 idle frames.
ManyCutsResult fiftyCuts(bool octree, int threads) {
  ThreadLimit limit(threads);
  World w = bunnyWorld(octree);
  ManyCutsResult r;
  r.nodesStart = w.bodyInfo(w.bodies()[0]).nodes;
  Eigen::AlignedBox3d box;
  for (const Vec3d& x : w.surfaceMesh(w.bodies()[0]).positions) box.extend(x);
  const Vec3d lo = box.min(), hi = box.max(), size = hi - lo;
  const ToolId blade = w.addBlade({lo - size, lo - size + Vec3d(0.01, 0, 0)});
  std::mt19937_64 rng(12345);
  for (int cut = 0; cut < 50; ++cut) {
    Vec3d a0, b0, a1, b1;
    if (cut % 5 == 4) {
      // A slice: a blade longer than the body, level or tilted, swept across it.
      const bool alongX = (rng() & 1) != 0;
      const int a = alongX ? 0 : 2, s = alongX ? 2 : 0;
      const double y = uniform(rng, lo.y() + 0.3 * size.y(), hi.y() - 0.1 * size.y());
      const double tilt = uniform(rng, -0.15, 0.15) * size.y();
      a0 = b0 = Vec3d::Zero();
      a0[a] = lo[a] - 0.1 * size[a];
      b0[a] = hi[a] + 0.1 * size[a];
      a0.y() = y - tilt;
      b0.y() = y + tilt;
      a0[s] = b0[s] = lo[s] - 0.05 * size[s];
      a1 = a0;
      b1 = b0;
      a1[s] = b1[s] = hi[s] + 0.05 * size[s];
    } else {
      // A stroke: the blade's tip at a random depth under the top, drawn in a random
      // horizontal direction from a random point for 30 to 80 % of the body's width.
      const double angle = uniform(rng, 0.0, 6.283185307179586);
      const Vec3d dir(std::cos(angle), 0.0, std::sin(angle));
      const Vec3d start(uniform(rng, lo.x(), hi.x()), 0.0, uniform(rng, lo.z(), hi.z()));
      const double length = uniform(rng, 0.3, 0.8) * std::max(size.x(), size.z());
      const double depth = hi.y() - uniform(rng, 0.2, 0.7) * size.y();
      const Vec3d lean(uniform(rng, -0.2, 0.2), 0.0, uniform(rng, -0.2, 0.2));
      a0 = start + Vec3d(0.0, depth, 0.0);
      b0 = a0 + (Vec3d::UnitY() + lean).normalized() * (0.35 * size.y());
      a1 = a0 + length * dir;
      b1 = b0 + length * dir;
    }
    w.placeTool(blade, {a0, b0});
    for (int f = 1; f <= 6; ++f) {
      const double t = f / 6.0;
      w.setToolPose(blade, {a0 + t * (a1 - a0), b0 + t * (b1 - b0)});
      (void)w.step();
      r.nodesMax = std::max(r.nodesMax, w.bodyInfo(w.bodies()[0]).nodes);
    }
  }
  w.placeTool(blade, {lo - size, lo - size + Vec3d(0.01, 0, 0)});
  for (int f = 0; f < 40; ++f) (void)w.step();
  r.hash = w.cutSetHash();
  r.nodesEnd = w.bodyInfo(w.bodies()[0]).nodes;
  r.cutLinks = w.bodyInfo(w.bodies()[0]).cutLinks;
  r.pieces = w.pieces(w.bodies()[0]);
  r.selfCheck = w.selfCheck(w.bodies()[0]);
  r.closedSurface = closed(w.surfaceMesh(w.bodies()[0]));
  return r;
}

TEST(ManyCuts, FiftyCutsOnTheBunnyKeepTheMeshBoundedAndThePiecesApart) {
  const ManyCutsResult r = fiftyCuts(true, 2);
  std::printf("50 cuts: %zu cut links, nodes %zu at the start, %zu at most, %zu at the end, "
              "%d pieces\n",
              r.cutLinks, r.nodesStart, r.nodesMax, r.nodesEnd, r.pieces);
  EXPECT_GT(r.cutLinks, 2000u);
  EXPECT_GT(r.pieces, 3);
  // Most of the nodes at the end are the pieces' own (every piece needs its elements' nodes);
  // while a blade rests in the body, its front is refined on top of that.
  EXPECT_LT(r.nodesEnd, 3 * r.nodesStart);
  EXPECT_LT(r.nodesMax, 4 * r.nodesStart);
  // The deformation mesh falls apart exactly where the voxels do: into as many parts as the
  // voxel pieces (one of the body's invariants World::selfCheck checks).
  EXPECT_EQ(r.selfCheck, "");
  EXPECT_TRUE(r.closedSurface);
  // The same cuts for one thread and without the octree.
  EXPECT_EQ(fiftyCuts(true, 1).hash, r.hash);
  EXPECT_EQ(fiftyCuts(false, 2).hash, r.hash);
}

}  // namespace
}  // namespace voxcut
