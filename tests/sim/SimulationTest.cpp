// The simulator on the shipped scenes: cut parts separate, pieces go up by one, surfaces stay
// closed, no gap opens where no link was cut, and results do not depend on the thread count or
// on the voxel octree.

#include <gtest/gtest.h>

#include <string>

#include "voxcut/core/Parallel.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"
#include "voxcut/sim/WorldInternals.h"
#include "voxcut/voxel/Pieces.h"

namespace voxcut {
namespace {

std::string scenePath(const std::string& name) {
  return std::string(VOXCUT_SOURCE_DIR) + "/scenes/" + name;
}

World loadSimulation(const std::string& name, bool octree = true) {
  const Scene scene = readScene(scenePath(name));
  WorldSettings p;
  p.useOctree = octree;
  return World::fromScene(scene, voxelizeSceneBodies(scene), p);
}

// Current position of node-grid point c as seen from element e (trilinear, extrapolating).
Vec3d pointAt(const DeformationOctree& d, std::uint32_t e, const Index3& c) {
  const OctreeElement& el = d.element(e);
  const Index3 f = el.firstVoxel();
  const double s = el.size();
  return d.pointInElement(e, Vec3d((c.x - f.x) / s, (c.y - f.y) / s, (c.z - f.z) / s));
}

// For every connected link between voxels of two different elements, the two elements agree on
// the 4 corners of the face between the voxels: the material is continuous there.
void expectNoGap(const SimBody& b) {
  const VoxelGrid& g = b.cut.grid;
  const DeformationOctree& d = b.cut.deformation;
  const double tol = 1e-9 * (1.0 + d.restVoxelBounds().diagonal().norm());
  std::size_t checked = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    if (!g.occupied(v)) continue;
    const Index3 p = g.coord(v);
    for (int a = 0; a < 3; ++a) {
      if (p[a] + 1 >= g.dims()[a] || !g.connected(v, a)) continue;
      const std::size_t w = v + g.stride(a);
      const std::uint32_t ev = d.owner(v), ew = d.owner(w);
      if (ev == ew) continue;
      const int u = (a + 1) % 3, t = (a + 2) % 3;
      for (int k = 0; k < 4; ++k) {
        Index3 c = p;
        c[a] += 1;
        c[u] += k & 1;
        c[t] += k >> 1;
        const double gap = (pointAt(d, ev, c) - pointAt(d, ew, c)).norm();
        ASSERT_LE(gap, tol) << "gap at connected link " << v << "," << a;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 0u);
}

// Deformed centroid of the voxels of each piece.
std::vector<Vec3d> pieceCentroids(const SimBody& b, const PieceLabels& labels) {
  std::vector<Vec3d> sum(static_cast<std::size_t>(labels.count), Vec3d::Zero());
  for (std::size_t v = 0; v < labels.label.size(); ++v)
    if (labels.label[v] >= 0)
      sum[static_cast<std::size_t>(labels.label[v])] += b.cut.deformation.voxelPosition(v);
  for (int k = 0; k < labels.count; ++k)
    sum[static_cast<std::size_t>(k)] /=
        static_cast<double>(labels.voxels[static_cast<std::size_t>(k)]);
  return sum;
}

struct CutScene {
  const char* file;
  int frames;
};

class ShippedCutScene : public ::testing::TestWithParam<CutScene> {};

TEST_P(ShippedCutScene, CutPartSeparatesAndSurfacesStayClosed) {
  World sim = loadSimulation(GetParam().file);
  const int before = sim.pieces(sim.bodies()[0]);
  int separatedAt = -1;
  double distanceAtSeparation = 0.0;
  const int frames = GetParam().frames > 0
                         ? GetParam().frames
                         : readScene(scenePath(GetParam().file)).frames.value_or(100);
  for (int f = 0; f < frames; ++f) {
    const FrameReport r = sim.step();
    if (separatedAt < 0 && r.cutLinks > 0) {
      const PieceLabels labels = findPieces(WorldInternals::body(sim, sim.bodies()[0]).cut.grid);
      if (labels.count > before) {
        separatedAt = f;
        const auto c = pieceCentroids(WorldInternals::body(sim, sim.bodies()[0]), labels);
        distanceAtSeparation = (c.front() - c.back()).norm();
      }
    }
  }
  const SimBody& body = WorldInternals::body(sim, sim.bodies()[0]);
  const PieceLabels labels = findPieces(body.cut.grid);
  ASSERT_GE(separatedAt, 0) << "the blade never cut a part off";
  EXPECT_EQ(labels.count, before + 1);
  // The part cut off moves away from the rest (it falls or springs back).
  const auto c = pieceCentroids(body, labels);
  const double distanceNow = (c.front() - c.back()).norm();
  EXPECT_GT(distanceNow, distanceAtSeparation + 2.0 * body.cut.grid.voxelSize())
      << "separated at frame " << separatedAt;
  const SurfaceTopology topo = surfaceTopology(sim.surfaceMesh(sim.bodies()[0]));
  EXPECT_TRUE(topo.closed);
  EXPECT_TRUE(topo.manifold);
  // Each voxel piece has its own surface; a blade crossing material that moved across its plane
  // may also leave closed internal slits (cut links that separate nothing).
  EXPECT_GE(topo.pieces, labels.count);
  expectNoGap(body);
}

INSTANTIATE_TEST_SUITE_P(Scenes, ShippedCutScene,
                         ::testing::Values(CutScene{"bunny-ear.json", 0},
                                           CutScene{"liver-tumor.json", 0},
                                           CutScene{"starfish-arm.json", 0}),
                         [](const auto& param) {
                           std::string n = param.param.file;
                           return n.substr(0, n.find('-'));
                         });

TEST(Simulation, SameResultsAtOneAndTwoThreadsAndWithoutOctree) {
  auto run = [](int threads, bool octree) {
    ThreadLimit limit(threads);
    World sim = loadSimulation("bunny-ear.json", octree);
    std::size_t cut = 0;
    // The blade reaches the bunny at frame 110 and cuts until frame 161 (at frame 153 its
    // edge ends inside a level-1 cube whose mid-planes show no cut on their borders).
    for (int f = 0; f < 165; ++f) cut += sim.step().cutLinks;
    return std::make_pair(cut,
                          WorldInternals::body(sim, sim.bodies()[0]).cut.deformation.positions());
  };
  const auto one = run(1, true), two = run(2, true), baseline = run(2, false);
  EXPECT_GT(one.first, 0u);
  EXPECT_EQ(one.first, two.first);
  EXPECT_EQ(one.first, baseline.first);
  ASSERT_EQ(one.second.size(), two.second.size());
  ASSERT_EQ(one.second.size(), baseline.second.size());
  for (std::size_t n = 0; n < one.second.size(); ++n) {
    ASSERT_EQ(one.second[n], two.second[n]) << "node " << n;
    ASSERT_EQ(one.second[n], baseline.second[n]) << "node " << n;
  }
}

TEST(Simulation, CantileverSagsAndStaysContinuous) {
  World sim = loadSimulation("cantilever.json");
  double last = 0.0;
  for (int f = 0; f < 50; ++f) {
    const FrameReport r = sim.step();
    EXPECT_EQ(r.cutLinks, 0u);
    last = sim.maxDisplacement();
  }
  EXPECT_GT(last, 0.0);
  EXPECT_EQ(sim.pieces(sim.bodies()[0]), 1);
  expectNoGap(WorldInternals::body(sim, sim.bodies()[0]));
  EXPECT_TRUE(surfaceTopology(sim.surfaceMesh(sim.bodies()[0])).closed);
}

}  // namespace
}  // namespace voxcut
