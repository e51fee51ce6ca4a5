// The simulator on the shipped scenes: cut parts separate, pieces go up by one, surfaces stay
// closed, no gap opens where no link was cut, and results do not depend on the thread count or
// on the voxel octree.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"
#include "voxcut/surface/SurfaceMesh.h"

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

// Deformed centroid of the voxels of each piece.
std::vector<Vec3d> pieceCentroids(const BodyVoxels& voxels) {
  std::vector<Vec3d> sum(voxels.pieceVoxels.size(), Vec3d::Zero());
  for (std::size_t v = 0; v < voxels.pieces.size(); ++v)
    sum[static_cast<std::size_t>(voxels.pieces[v])] += voxels.positions[v];
  for (std::size_t k = 0; k < sum.size(); ++k)
    sum[k] /= static_cast<double>(voxels.pieceVoxels[k]);
  return sum;
}

// The body's invariants hold (World::selfCheck): among them, for every connected link between
// voxels of two different elements, the two elements agree on the 4 corners of the face
// between the voxels (the material is continuous there). There are such links to check: the
// body has more than one element.
void expectNoGap(const World& sim) {
  EXPECT_EQ(sim.selfCheck(sim.bodies()[0]), "");
  EXPECT_GT(sim.bodyInfo(sim.bodies()[0]).elements, 1u);
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
      const BodyVoxels voxels = sim.voxels(sim.bodies()[0]);
      if (static_cast<int>(voxels.pieceVoxels.size()) > before) {
        separatedAt = f;
        const auto c = pieceCentroids(voxels);
        distanceAtSeparation = (c.front() - c.back()).norm();
      }
    }
  }
  const BodyVoxels voxels = sim.voxels(sim.bodies()[0]);
  const int pieces = static_cast<int>(voxels.pieceVoxels.size());
  ASSERT_GE(separatedAt, 0) << "the blade never cut a part off";
  EXPECT_EQ(pieces, before + 1);
  // The part cut off moves away from the rest (it falls or springs back).
  const auto c = pieceCentroids(voxels);
  const double distanceNow = (c.front() - c.back()).norm();
  EXPECT_GT(distanceNow, distanceAtSeparation + 2.0 * sim.bodyInfo(sim.bodies()[0]).voxelSize)
      << "separated at frame " << separatedAt;
  const SurfaceTopology topo = surfaceTopology(sim.surfaceMesh(sim.bodies()[0]));
  EXPECT_TRUE(topo.closed);
  EXPECT_TRUE(topo.manifold);
  // Each voxel piece has its own surface; a blade crossing material that moved across its plane
  // may also leave closed internal slits (cut links that separate nothing).
  EXPECT_GE(topo.pieces, pieces);
  expectNoGap(sim);
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
    return std::make_pair(cut, sim.nodes(sim.bodies()[0]).positions);
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
  expectNoGap(sim);
  EXPECT_TRUE(surfaceTopology(sim.surfaceMesh(sim.bodies()[0])).closed);
}

}  // namespace
}  // namespace voxcut
