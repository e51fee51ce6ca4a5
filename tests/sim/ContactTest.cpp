#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"
#include "voxcut/voxel/BuiltinModels.h"

namespace voxcut {
namespace {

World simulationOf(const std::string& json) {
  const Scene scene = parseScene(json, "test.json", std::filesystem::current_path());
  return World::fromScene(scene, voxelizeSceneBodies(scene));
}

// Body 0's mass (kg): its nodes' lumped masses summed.
double totalMass(const World& sim) {
  double sum = 0.0;
  for (const double m : sim.nodes(sim.bodies()[0]).masses) sum += m;
  return sum;
}

// A soft box (0.1 x 0.06 x 0.08 m, 0.48 kg, level-2 elements: docs/algorithms.md, "Contact",
// says what level 3 does at impact) released with its bottom `height` metres above an obstacle
// whose top is at y = 0.
std::string droppedBox(double height, const std::string& obstacle) {
  const double y = 0.03 + height;  // the box's centre
  return R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
    "solver": {"tolerance": 1e-6, "max_iterations": 1000},
    "bodies": [{"model": "box:0.1,0.06,0.08", "resolution": 32, "element_level": 2,
      "offset": [0, )" +
         std::to_string(y) + R"(, 0],
      "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000,
                                "damping": [2, 0.01]}}}],
    "obstacles": [)" +
         obstacle + "]}";
}

const std::string kFloor = R"({"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]})";
const std::string kTable = R"({"type": "box", "lo": [-0.2, -0.03, -0.2], "hi": [0.2, 0, 0.2]})";

struct Landing {
  double deepest = 0.0;         // over all frames (m)
  double kinetic = 0.0;         // at the end (J)
  double lowest = 1e9;          // lowest surface vertex at the end (m)
  Vec3d force = Vec3d::Zero();  // on the obstacle, last frame (N)
  double weight = 0.0;          // m g (N)
  double voxel = 0.0;           // voxel size (m)
};

// The box dropped onto `obstacle` (JSON; may be empty) and then onto `extra`, if given.
Landing land(double height, const std::string& obstacle, int frames,
             const std::optional<Obstacle>& extra = std::nullopt) {
  World sim = simulationOf(droppedBox(height, obstacle));
  if (extra) sim.addObstacle(*extra);
  Landing l;
  for (int f = 0; f < frames; ++f) {
    const FrameReport r = sim.step();
    EXPECT_TRUE(r.converged) << "frame " << f;
    l.deepest = std::max(l.deepest, r.maxPenetration);
    l.force = r.obstacleForces.at(0);
  }
  l.kinetic = sim.energy(sim.bodies()[0]).kinetic;
  l.weight = totalMass(sim) * 9.81;
  l.voxel = sim.bodyInfo(sim.bodies()[0]).voxelSize;
  for (const Vec3d& p : sim.surfaceMesh(sim.bodies()[0]).positions)
    l.lowest = std::min(l.lowest, p.y());
  return l;
}

// Dropped from up to 0.3 m at dt 4 ms, the box never sinks half a voxel into the floor, comes
// to rest on it, and then presses on it with its weight.
TEST(Contact, BoxDroppedOnAPlaneComesToRestOnIt) {
  for (double height : {0.0, 0.05, 0.3}) {
    SCOPED_TRACE("drop height " + std::to_string(height));
    const Landing l = land(height, kFloor, 500);
    EXPECT_LT(l.deepest, 0.5 * l.voxel);
    EXPECT_LT(l.kinetic, 1e-6 * l.weight * 0.06);  // of the energy of a drop of its own height
    EXPECT_GT(l.lowest, -0.5 * l.voxel);
    EXPECT_LT(l.lowest, 0.5 * l.voxel);
    EXPECT_NEAR(l.force.y(), -l.weight, 0.01 * l.weight);
    EXPECT_LT(std::hypot(l.force.x(), l.force.z()), 0.01 * l.weight);
  }
}

// A frame solves its body's step once while nothing is near, and again (up to three times)
// where the contact set the step ends with differs from the one it started with: the landing.
TEST(Contact, FramesCountTheStepsSolvedAgainForANewContactSet) {
  World sim = simulationOf(droppedBox(0.3, kFloor));
  int resolved = 0;
  for (int f = 0; f < 150; ++f) {
    const FrameReport r = sim.step();
    EXPECT_GE(r.solverSolves, 1) << "frame " << f;
    EXPECT_LE(r.solverSolves, 3) << "frame " << f;
    if (f < 10) {
      EXPECT_EQ(r.solverSolves, 1) << "frame " << f;  // 0.3 m up, falling
    }
    if (r.solverSolves > 1) ++resolved;
  }
  EXPECT_GT(resolved, 0);
}

TEST(Contact, BoxDroppedOnATableComesToRestOnTop) {
  const Landing l = land(0.3, kTable, 500);
  EXPECT_LT(l.deepest, 0.5 * l.voxel);
  EXPECT_GT(l.lowest, -0.5 * l.voxel);
  EXPECT_NEAR(l.force.y(), -l.weight, 0.01 * l.weight);
}

// The table of kTable as a mesh obstacle: a box of 12 triangles, rotated by `degrees` about
// the z axis through the origin (the middle of its top face).
Obstacle meshTable(double degrees) {
  TriangleMesh table = makeBox(Vec3d(0.4, 0.03, 0.4));
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(degrees * 3.14159265358979323846 / 180.0, Vec3d::UnitZ()).matrix();
  for (Vec3d& v : table.vertices) v = turn * (v - Vec3d(0, 0.015, 0));
  return meshObstacle(table);
}

// On the same table as a mesh, the same landing as on the Box obstacle.
TEST(Contact, BoxDroppedOnAMeshTableComesToRestOnTop) {
  const Landing l = land(0.3, "", 500, meshTable(0.0));
  EXPECT_LT(l.deepest, 0.5 * l.voxel);
  EXPECT_LT(l.kinetic, 1e-6 * l.weight * 0.06);
  EXPECT_GT(l.lowest, -0.5 * l.voxel);
  EXPECT_NEAR(l.force.y(), -l.weight, 0.01 * l.weight);
  EXPECT_LT(std::hypot(l.force.x(), l.force.z()), 0.01 * l.weight);
}

// A slab tilted by 10 degrees, friction 0.5 (tan 10 = 0.18): the box lands on its lower edge,
// settles flat on the slope and stays; the slab carries its weight, straight down.
TEST(Contact, BoxDroppedOnATiltedMeshSlabComesToRestOnIt) {
  Obstacle slab = meshTable(10.0);
  slab.friction = 0.5;
  const Landing l = land(0.01, "", 400, slab);
  EXPECT_LT(l.deepest, 0.5 * l.voxel);
  EXPECT_LT(l.kinetic, 1e-6 * l.weight * 0.06);
  EXPECT_NEAR(l.force.y(), -l.weight, 0.01 * l.weight);
  EXPECT_LT(std::hypot(l.force.x(), l.force.z()), 0.01 * l.weight);
}

// box-down-ramp.json: the box slides down the ramp (a mesh), never half a voxel into it or the
// floor, and comes to rest on the floor past the ramp's foot (x = 0.1), the two carrying its
// weight.
TEST(Contact, BoxSlidesDownTheRampSceneAndRestsOnTheFloor) {
  const Scene scene = readScene(std::string(VOXCUT_SOURCE_DIR) + "/scenes/box-down-ramp.json");
  ASSERT_EQ(scene.obstacles.at(0).type, ObstacleType::Mesh);
  World sim = World::fromScene(scene, voxelizeSceneBodies(scene));
  double deepest = 0.0;
  FrameReport last;
  for (int f = 0; f < scene.frames.value_or(0); ++f) {
    last = sim.step();
    ASSERT_TRUE(last.converged) << "frame " << f;
    deepest = std::max(deepest, last.maxPenetration);
  }
  const double weight = totalMass(sim) * 9.81;
  EXPECT_LT(deepest, 0.5 * sim.bodyInfo(sim.bodies()[0]).voxelSize);
  EXPECT_LT(sim.energy(sim.bodies()[0]).kinetic, 1e-6 * weight * 0.06);
  Vec3d centre = Vec3d::Zero();
  const std::vector<Vec3d>& positions = sim.surfaceMesh(sim.bodies()[0]).positions;
  for (const Vec3d& p : positions) centre += p;
  centre /= static_cast<double>(positions.size());
  EXPECT_GT(centre.x(), 0.1);
  EXPECT_NEAR(centre.y(), 0.03, 0.005);
  EXPECT_NEAR((last.obstacleForces[0] + last.obstacleForces[1]).y(), -weight, 0.01 * weight);
}

// The bunny set on a floor, with the default contact stiffness and solver settings, comes to
// rest on it and carries its weight.
TEST(Contact, BunnyOnAFloorComesToRest) {
  World sim = simulationOf(R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
    "bodies": [{"model": "bunny", "offset": [0, 0.002, 0],
      "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000,
                                "damping": [2, 0.01]}}}],
    "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}]})");
  double deepest = 0.0;
  FrameReport last;
  for (int f = 0; f < 150; ++f) {
    last = sim.step();
    deepest = std::max(deepest, last.maxPenetration);
  }
  const double weight = totalMass(sim) * 9.81;
  EXPECT_LT(deepest, 0.5 * sim.bodyInfo(sim.bodies()[0]).voxelSize);
  EXPECT_LT(sim.energy(sim.bodies()[0]).kinetic, 1e-6 * weight * 0.01);
  EXPECT_LT(last.contacts, 1000u);
  EXPECT_NEAR(last.obstacleForces[0].y(), -weight, 0.01 * weight);
  EXPECT_LT(sim.maxDisplacement(), 0.01);
}

// Contacts are found in parallel and joined in vertex order: the same run at 1 and 2 threads
// ends with the same node positions, bit for bit.
TEST(Contact, SameForAnyThreadCount) {
  auto run = [](int threads) {
    ThreadLimit limit(threads);
    World sim = simulationOf(droppedBox(0.01, kTable));
    for (int f = 0; f < 40; ++f) (void)sim.step();
    return sim.nodes(sim.bodies()[0]).positions;
  };
  EXPECT_EQ(run(1), run(2));
}

// A fixed box cut in two far above an obstacle around the origin: the vertices the cut adds
// are tested where they are, not where they were before they had a position.
TEST(Contact, VerticesACutAddsAreTestedWhereTheyAre) {
  World sim = simulationOf(R"({"time_step": 0.004, "gravity": [0, 0, 0],
    "bodies": [{"model": "box:0.1,0.06,0.08", "resolution": 24, "offset": [0, 0.5, 0],
      "fixed": [{"box": [[-0.06, 0.4, -0.06], [-0.04, 0.6, 0.06]]},
                {"box": [[0.04, 0.4, -0.06], [0.06, 0.6, 0.06]]}]}],
    "tools": [{"type": "blade", "keys": [{"t": 0, "a": [0, 0.6, -0.1], "b": [0, 0.6, 0.1]},
                                         {"t": 0.02, "a": [0, 0.4, -0.1], "b": [0, 0.4, 0.1]}]}],
    "obstacles": [{"type": "box", "lo": [-0.05, -0.05, -0.05], "hi": [0.05, 0.05, 0.05]}]})");
  std::size_t cut = 0;
  for (int f = 0; f < 8; ++f) {
    const FrameReport r = sim.step();
    cut += r.cutLinks;
    EXPECT_EQ(r.contacts, 0u) << "frame " << f;
  }
  EXPECT_GT(cut, 100u);
}

// Without an obstacle the same box falls freely: the test above can fail.
TEST(Contact, WithoutObstaclesNothingHoldsTheBox) {
  World sim = simulationOf(droppedBox(0.0, ""));
  for (int f = 0; f < 100; ++f) EXPECT_EQ(sim.step().contacts, 0u);
  double lowest = 1e9;
  for (const Vec3d& p : sim.surfaceMesh(sim.bodies()[0]).positions) lowest = std::min(lowest, p.y());
  EXPECT_LT(lowest, -0.5);
}

}  // namespace
}  // namespace voxcut
