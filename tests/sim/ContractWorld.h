#pragma once
// The world of the world API's contract tests (WorldContractTest.cpp, WorldSnapshotTest.cpp): a
// soft box on a floor with a blade that slits it and a probe that presses it, and the checks
// that two worlds, or two frames, are the same bit for bit.

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"

namespace voxcut::contract {

inline Scene sceneOf(const std::string& json) {
  return parseScene(json, "contract.json", std::filesystem::current_path());
}

// A soft box 0.1 x 0.06 x 0.08 m on a floor (y = 0), its base fixed, and a small loose cube
// beside it on the floor; a far box obstacle that the tests remove.
inline const std::string kScene = R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
    "solver": {"tolerance": 1e-6, "max_iterations": 1000},
    "bodies": [
      {"model": "box:0.1,0.06,0.08", "resolution": 16, "element_level": 1,
       "offset": [0, 0.03, 0],
       "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000,
                                 "damping": [2, 0.01]}},
       "fixed": [{"box": [[-1, -1, -1], [1, 0.002, 1]]}]},
      {"model": "box:0.03,0.03,0.03", "resolution": 6, "element_level": 1,
       "offset": [0.3, 0.015, 0]}],
    "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]},
                  {"type": "box", "lo": [1, 0, 1], "hi": [1.1, 0.1, 1.1]}]})";

inline BladePose segment(const Vec3d& a, const Vec3d& b) { return BladePose{a, b}; }
inline BladePose sphereAt(const Vec3d& p) { return BladePose{p, p}; }

// A blade that slits the left half of the box at y = 0.04 (from z = -0.06 to 0.06 over
// 0.15 s: in the box from about frame 6 to frame 31) and a probe that presses 5 mm into its top
// at x = 0.03 (touching from about frame 5 on).
inline std::vector<ToolKey> bladeKeys() {
  return {{0.0, segment(Vec3d(-0.1, 0.04, -0.06), Vec3d(0.0, 0.04, -0.06))},
          {0.15, segment(Vec3d(-0.1, 0.04, 0.06), Vec3d(0.0, 0.04, 0.06))}};
}
inline std::vector<ToolKey> probeKeys() {
  return {{0.0, sphereAt(Vec3d(0.03, 0.075, 0))}, {0.04, sphereAt(Vec3d(0.03, 0.065, 0))}};
}

// The handles of a contract world; the spare ones removed.
struct Handles {
  BodyId body, spareBody;
  ToolId blade, probe, spareTool;
  ObstacleId floor, spareObstacle;
};

// The contract world: the scene's two bodies, the blade and the probe on their trajectories
// and a spare blade far away; with `removeSpares`, the spare blade, the small cube and the far
// obstacle removed again.
inline World contractWorld(Handles& h, bool removeSpares = true) {
  const Scene scene = sceneOf(kScene);
  World w = World::fromScene(scene, voxelizeSceneBodies(scene));
  h.body = w.bodies().at(0);
  h.spareBody = w.bodies().at(1);
  h.floor = w.obstacles().at(0);
  h.spareObstacle = w.obstacles().at(1);
  h.blade = w.addBlade(bladeKeys().front().pose);
  w.setToolTrajectory(h.blade, bladeKeys());
  h.spareTool = w.addBlade(segment(Vec3d(2, 2, 2), Vec3d(2.1, 2, 2)));
  h.probe = w.addProbe(0.01, probeKeys().front().pose, 0.0);
  w.setToolTrajectory(h.probe, probeKeys());
  if (removeSpares) {
    w.removeTool(h.spareTool);
    w.removeBody(h.spareBody);
    w.removeObstacle(h.spareObstacle);
  }
  return w;
}

inline bool sameBits(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3d)) == 0);
}

inline bool sameBits(const Vec3d& a, const Vec3d& b) {
  return std::memcmp(a.data(), b.data(), sizeof(Vec3d)) == 0;
}

// Two worlds at the same point bit for bit: their cuts, every body's nodes and surface, every
// tool's pose and reaction, in the order of their handles.
inline void expectSameWorld(const World& a, const World& b, const std::string& when) {
  SCOPED_TRACE(when);
  EXPECT_EQ(a.frame(), b.frame());
  EXPECT_EQ(a.cutSetHash(), b.cutSetHash());
  ASSERT_EQ(a.bodies().size(), b.bodies().size());
  ASSERT_EQ(a.tools().size(), b.tools().size());
  ASSERT_EQ(a.obstacles().size(), b.obstacles().size());
  for (std::size_t i = 0; i < a.bodies().size(); ++i) {
    const BodyId ba = a.bodies()[i], bb = b.bodies()[i];
    const NodeState na = a.nodes(ba), nb = b.nodes(bb);
    EXPECT_TRUE(sameBits(na.positions, nb.positions)) << "body " << i << " node positions";
    EXPECT_TRUE(sameBits(na.velocities, nb.velocities)) << "body " << i << " node velocities";
    EXPECT_EQ(na.masses, nb.masses) << "body " << i;
    const SurfaceMesh sa = a.surfaceMesh(ba), sb = b.surfaceMesh(bb);
    EXPECT_TRUE(sameBits(sa.positions, sb.positions)) << "body " << i << " surface positions";
    EXPECT_EQ(sa.triangles, sb.triangles) << "body " << i;
    EXPECT_EQ(a.bodyInfo(ba).cutLinks, b.bodyInfo(bb).cutLinks) << "body " << i;
  }
  for (std::size_t i = 0; i < a.tools().size(); ++i) {
    const ToolId ta = a.tools()[i], tb = b.tools()[i];
    EXPECT_TRUE(sameBits(a.toolPose(ta).a, b.toolPose(tb).a)) << "tool " << i;
    EXPECT_TRUE(sameBits(a.toolPose(ta).b, b.toolPose(tb).b)) << "tool " << i;
    EXPECT_TRUE(sameBits(a.toolReaction(ta).force, b.toolReaction(tb).force)) << "tool " << i;
    EXPECT_TRUE(sameBits(a.toolReaction(ta).torque, b.toolReaction(tb).torque)) << "tool " << i;
  }
}

inline void expectSameReport(const FrameReport& a, const FrameReport& b,
                             const std::string& when) {
  SCOPED_TRACE(when);
  EXPECT_EQ(a.frame, b.frame);
  EXPECT_EQ(a.cutLinks, b.cutLinks);
  EXPECT_EQ(a.contacts, b.contacts);
  EXPECT_EQ(a.solverIterations, b.solverIterations);
  EXPECT_EQ(a.maxPenetration, b.maxPenetration);
  ASSERT_EQ(a.toolReactions.size(), b.toolReactions.size());
  for (std::size_t i = 0; i < a.toolReactions.size(); ++i)
    EXPECT_TRUE(sameBits(a.toolReactions[i].force, b.toolReactions[i].force)) << "tool " << i;
  EXPECT_TRUE(sameBits(a.obstacleForces, b.obstacleForces));
}

}  // namespace voxcut::contract
