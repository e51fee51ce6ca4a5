// The world API: tools driven live or by trajectories, probes and their reaction, surface reads
// with their changes, materials and fixed regions changed while it runs, recordings.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <tuple>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/Recording.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"
#include "voxcut/surface/SurfaceMesh.h"

namespace voxcut {
namespace {

Scene sceneOf(const std::string& json) {
  return parseScene(json, "test.json", std::filesystem::current_path());
}

World worldOf(const std::string& json, const WorldSettings& base = {}) {
  const Scene scene = sceneOf(json);
  return World::fromScene(scene, voxelizeSceneBodies(scene), base);
}

// A soft box 0.1 x 0.06 x 0.08 m with its bottom at y = 0, centred on the y axis; `extra` adds
// top-level members (after a comma), `body` members of the body.
std::string box(const std::string& extra, const std::string& body = "", double gravity = 0.0) {
  return R"({"time_step": 0.004, "gravity": [0, )" + std::to_string(gravity) + R"(, 0],
    "solver": {"tolerance": 1e-6, "max_iterations": 1000},
    "bodies": [{"model": "box:0.1,0.06,0.08", "resolution": 32, "element_level": 2,
      "offset": [0, 0.03, 0],
      "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000,
                                "damping": [2, 0.01]}})" +
         (body.empty() ? "" : ", " + body) + "}]" + (extra.empty() ? "" : ", " + extra) + "}";
}

const std::string kBaseFixed = R"("fixed": [{"box": [[-1, -1, -1], [1, 0.002, 1]]}])";
const std::string kBlade = R"("tools": [{"type": "blade", "keys": [
    {"t": 0.0, "a": [-0.1, 0.04, -0.06], "b": [0.1, 0.04, -0.06]},
    {"t": 0.12, "a": [-0.1, 0.04, 0.06], "b": [0.1, 0.04, 0.06]}]}])";

TEST(World, ToolsSetEveryFrameCutAsTheirTrajectory) {
  World byKeys = worldOf(box(kBlade, kBaseFixed));
  const Scene scene = sceneOf(box(kBlade, kBaseFixed));
  Scene bare = scene;
  bare.tools.clear();
  World live = World::fromScene(bare, voxelizeSceneBodies(bare));
  const ToolId blade = live.addBlade(scene.tools[0].keys.front().pose);
  for (int f = 0; f < 40; ++f) {
    live.setToolPose(blade, bladePoseAt(scene.tools[0], (f + 1) * scene.timeStep));
    const FrameReport a = byKeys.step(), b = live.step();
    ASSERT_EQ(a.cutLinks, b.cutLinks) << "frame " << f;
  }
  EXPECT_GT(live.bodyInfo(live.bodies()[0]).cutLinks, 0u);
  EXPECT_EQ(live.cutSetHash(), byKeys.cutSetHash());
  EXPECT_EQ(live.pieces(live.bodies()[0]), 2);
  EXPECT_EQ(live.nodes(live.bodies()[0]).positions, byKeys.nodes(byKeys.bodies()[0]).positions);
}

TEST(World, SurfaceChangesReplayTheView) {
  World w = worldOf(box(kBlade, kBaseFixed));
  SurfaceView v = w.surface(w.bodies()[0]);
  std::vector<std::array<int, 3>> mirror(v.triangles.begin(), v.triangles.end());
  std::uint64_t revision = v.revision;
  int updates = 0;
  for (int f = 0; f < 40; ++f) {
    (void)w.step();
    v = w.surface(w.bodies()[0]);
    const SurfaceChanges c = w.surfaceChanges(w.bodies()[0], revision);
    EXPECT_EQ(c.to, v.revision);
    ASSERT_FALSE(c.full);
    mirror.resize(v.triangles.size(), {-1, -1, -1});
    for (auto* list : {&c.removedTriangles, &c.addedTriangles})
      for (std::int32_t t : *list) mirror[static_cast<std::size_t>(t)] = v.triangles[t];
    if (c.to != revision) ++updates;
    revision = c.to;
    ASSERT_TRUE(std::equal(mirror.begin(), mirror.end(), v.triangles.begin())) << "frame " << f;
  }
  EXPECT_GT(updates, 0);
  // Every live triangle's corners are live vertices with unit normals.
  for (const auto& t : v.triangles) {
    if (t[0] < 0) continue;
    for (int c : t) EXPECT_NEAR(v.normals[static_cast<std::size_t>(c)].norm(), 1.0, 1e-9);
  }
  // A reader at revision 0 gets every change since the start, or is told to read everything.
  const SurfaceChanges all = w.surfaceChanges(w.bodies()[0], 0);
  EXPECT_TRUE(all.full || !all.addedTriangles.empty());
  EXPECT_TRUE(w.surfaceChanges(w.bodies()[0], revision + 1).full);  // a revision from the future
}

// A probe pressed 5 mm into the top of a box fixed at its base, without gravity, then lifted:
// the bodies push it up through its centre (without friction), and the box springs back.
// After every frame of a cut that refines and copies elements, each surface vertex is embedded
// where a fresh lookup puts it: the element that owns its voxel, at the same trilinear
// coordinates (renumbering keeps the kept elements' vertices, looks the others up again).
TEST(World, SurfaceVerticesStayEmbeddedThroughTopologyChanges) {
  World w = worldOf(box(kBlade, kBaseFixed));
  std::size_t checked = 0;
  for (int f = 0; f < 35; ++f) {
    w.step();
    // World::selfCheck compares every live vertex's embedding with a fresh lookup (among the
    // body's other invariants).
    ASSERT_EQ(w.selfCheck(w.bodies()[0]), "") << "frame " << f;
    checked += w.bodyInfo(w.bodies()[0]).surfaceVertices;
  }
  EXPECT_GT(w.bodyInfo(w.bodies()[0]).cutLinks, 100u);
  EXPECT_GT(checked, 1000u);
}

TEST(World, ProbePushesAndTheBodySpringsBack) {
  const std::string probe = R"("tools": [{"type": "probe", "radius": 0.01, "friction": 0,
      "keys": [{"t": 0.0, "p": [0, 0.075, 0]}, {"t": 0.2, "p": [0, 0.065, 0]},
      {"t": 0.5, "p": [0, 0.065, 0]}, {"t": 0.6, "p": [0, 0.09, 0]}]}])";
  World w = worldOf(box(probe, kBaseFixed));
  double pressed = 0.0;
  for (int f = 0; f < 125; ++f) {
    const FrameReport r = w.step();
    ASSERT_TRUE(r.converged);
  }
  const ToolReaction held = w.toolReaction(w.tools()[0]);
  pressed = w.maxDisplacement();
  EXPECT_GT(held.force.y(), 0.0);
  // Mostly up (the surface vertices under the sphere are not placed symmetrically about its
  // axis), and through the centre: each contact pushes along the sphere's radius.
  EXPECT_GT(held.force.y(), 0.9 * held.force.norm());
  EXPECT_LT(held.torque.norm(), 1e-9 * held.force.norm() * 0.01);
  EXPECT_GT(pressed, 0.003);  // most of the 5 mm; the rest is the contact's give
  for (int f = 0; f < 250; ++f) (void)w.step();
  EXPECT_EQ(w.toolReaction(w.tools()[0]).force, Vec3d::Zero());
  EXPECT_LT(w.maxDisplacement(), 0.02 * pressed);
}

// A box resting on a plane with a probe pressing on its top: the plane carries the weight and
// the probe's push (within 1 %).
TEST(World, PlaneCarriesWeightAndProbe) {
  const std::string extra =
      R"("obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}],
      "tools": [{"type": "probe", "radius": 0.01, "keys": [
      {"t": 0.0, "p": [0.02, 0.075, 0]}, {"t": 0.2, "p": [0.02, 0.067, 0]}]}])";
  World w = worldOf(box(extra, "", -9.81));
  FrameReport r;
  for (int f = 0; f < 300; ++f) r = w.step();
  double mass = 0.0;
  for (const double m : w.nodes(w.bodies()[0]).masses) mass += m;
  const double weight = mass * 9.81;
  const Vec3d probe = w.toolReaction(w.tools()[0]).force;
  EXPECT_GT(probe.y(), 0.1 * weight);
  EXPECT_NEAR(-r.obstacleForces[0].y(), weight + probe.y(), 0.01 * (weight + probe.y()));
}

TEST(World, MaterialsAndFixedRegionsChangeWhileRunning) {
  // A box fixed at one end (x <= -0.048) sags under gravity; ten times stiffer it sags about a
  // tenth as much; let go, it falls freely.
  const std::string fixedEnd = R"("fixed": [{"box": [[-1, -1, -1], [-0.048, 1, 1]]}])";
  World w = worldOf(box("", fixedEnd, -9.81));
  for (int f = 0; f < 200; ++f) (void)w.step();
  const double soft = w.maxDisplacement();
  SceneMaterial stiff;
  stiff.name = "default";
  stiff.youngModulus = 1e6;
  stiff.poissonRatio = 0.3;
  stiff.massDamping = 2;
  stiff.stiffnessDamping = 0.01;
  w.setMaterial(w.bodies()[0], stiff);
  for (int f = 0; f < 200; ++f) (void)w.step();
  const double hard = w.maxDisplacement();
  EXPECT_GT(soft, 1e-4);
  EXPECT_NEAR(hard / soft, 0.1, 0.03);
  stiff.name = "steel";
  EXPECT_THROW(w.setMaterial(w.bodies()[0], stiff), InputError);
  w.setFixed(w.bodies()[0], {});
  const double before = w.maxDisplacement();
  for (int f = 0; f < 25; ++f) (void)w.step();  // 0.1 s: about g t^2 / 2 = 4.9 cm
  EXPECT_NEAR(w.maxDisplacement() - before, 0.049, 0.01);
}

TEST(World, RecordedPosesReplayToTheSameCuts) {
  World w = worldOf(box(kBlade, kBaseFixed));
  w.setRecording(true);
  for (int f = 0; f < 40; ++f) (void)w.step();
  const std::vector<ToolKey>& keys = w.recording(w.tools()[0]);
  ASSERT_EQ(keys.size(), 41u);
  for (std::size_t k = 0; k < keys.size(); ++k)
    EXPECT_EQ(keys[k].t, static_cast<double>(static_cast<int>(k)) * 0.004);
  Scene replay = sceneOf(box(kBlade, kBaseFixed));
  replay.tools[0].keys = keys;
  World again = World::fromScene(replay, voxelizeSceneBodies(replay));
  for (int f = 0; f < 40; ++f) (void)again.step();
  EXPECT_GT(w.bodyInfo(w.bodies()[0]).cutLinks, 0u);
  EXPECT_EQ(again.cutSetHash(), w.cutSetHash());
}

// A blade put down inside the box (placeTool) cuts nothing until it moves, where one moved
// there from far away cuts along the way; the recording keeps the jump, and its text replays
// to the same cuts.
TEST(World, PlacedToolsMoveWithoutCuttingAndReplay) {
  const BladePose far{Vec3d(0.3, 0.2, 0), Vec3d(0.3, 0.1, 0)};
  const BladePose inside{Vec3d(0, 0.08, -0.02), Vec3d(0, 0.03, -0.02)};
  const BladePose across{Vec3d(0, 0.08, 0.02), Vec3d(0, 0.03, 0.02)};
  auto run = [&](bool place) {
    World w = worldOf(box("", kBaseFixed));
    const ToolId blade = w.addBlade(far);
    w.setRecording(true);
    for (int f = 0; f < 3; ++f) (void)w.step();
    if (place)
      w.placeTool(blade, inside);
    else
      w.setToolPose(blade, inside);
    (void)w.step();
    const std::size_t afterPlacing = w.bodyInfo(w.bodies()[0]).cutLinks;
    for (int f = 1; f <= 10; ++f) {
      const double s = f / 10.0;
      w.setToolPose(blade, {(1 - s) * inside.a + s * across.a, (1 - s) * inside.b + s * across.b});
      (void)w.step();
    }
    w.placeTool(blade, far);
    for (int f = 0; f < 3; ++f) (void)w.step();
    return std::make_tuple(std::move(w), afterPlacing);
  };
  auto [placed, placedFirst] = run(true);
  auto [swept, sweptFirst] = run(false);
  EXPECT_EQ(placedFirst, 0u);
  EXPECT_GT(sweptFirst, 0u);
  EXPECT_GT(placed.bodyInfo(placed.bodies()[0]).cutLinks, 0u);
  EXPECT_LT(placed.bodyInfo(placed.bodies()[0]).cutLinks,
            swept.bodyInfo(swept.bodies()[0]).cutLinks);
  const std::vector<ToolKey>& keys = placed.recording(placed.tools()[0]);
  EXPECT_EQ(std::count_if(keys.begin(), keys.end(), [](const ToolKey& k) { return k.jump; }), 2);
  // The recording as a file, played back as the scene's blade.
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / "voxcut-world-placed-recording.json";
  {
    std::ofstream out(file);
    out << recordingText(placed);
  }
  World replay = worldOf(
      box(R"("tools": [{"type": "blade", "trajectory": ")" + file.string() + R"("}])", kBaseFixed));
  for (int f = 0; f < placed.frame(); ++f) (void)replay.step();
  std::filesystem::remove(file);
  EXPECT_EQ(replay.cutSetHash(), placed.cutSetHash());
  EXPECT_EQ(replay.bodyInfo(replay.bodies()[0]).cutLinks,
            placed.bodyInfo(placed.bodies()[0]).cutLinks);
}

// The voxel octree switched off and on while a blade cuts: the same cuts as with it on
// throughout; off, every link is active, on again, the octree is back with fewer.
TEST(World, OctreeSwitchedWhileCuttingGivesTheSameCuts) {
  World on = worldOf(box(kBlade, kBaseFixed));
  World toggled = worldOf(box(kBlade, kBaseFixed));
  for (const TriangleTag& tag : on.surface(on.bodies()[0]).triangleTags) EXPECT_EQ(tag.cut, 0);
  const ActivityView start = toggled.activity(toggled.bodies()[0]);
  EXPECT_GT(start.cubes.size(), 0u);
  EXPECT_EQ(start.links.size(), start.activeLinks);
  EXPECT_EQ(start.cubes.size(), start.cubeLevels.size());
  std::size_t allLinks = 0;
  for (int f = 0; f < 40; ++f) {
    if (f == 10) toggled.setUseOctree(false);
    if (f == 25) toggled.setUseOctree(true);
    if (f == 15) {
      const ActivityView all = toggled.activity(toggled.bodies()[0], 1000);
      EXPECT_TRUE(all.cubes.empty());
      EXPECT_GT(all.activeLinks, 2 * start.activeLinks);
      EXPECT_LE(all.links.size(), 1000u);
      EXPECT_GE(all.links.size(), 500u);
      allLinks = all.activeLinks;
    }
    (void)on.step();
    (void)toggled.step();
  }
  EXPECT_GT(on.bodyInfo(on.bodies()[0]).cutLinks, 0u);
  EXPECT_EQ(toggled.cutSetHash(), on.cutSetHash());
  // The cut shows on the surface as triangles tagged as cut, of the box's one material.
  const SurfaceView surface = on.surface(on.bodies()[0]);
  std::size_t cutTriangles = 0, live = 0;
  for (std::size_t t = 0; t < surface.triangles.size(); ++t) {
    if (surface.triangles[t][0] < 0) continue;
    ++live;
    EXPECT_EQ(surface.triangleTags[t].material, 1);
    cutTriangles += surface.triangleTags[t].cut;
  }
  EXPECT_GT(cutTriangles, 0u);
  EXPECT_LT(cutTriangles, live / 2);
  EXPECT_EQ(on.bodyInfo(on.bodies()[0]).materialNames.size(), 1u);
  // Built afresh after the cut, the octree may keep larger cubes than the one subdivided
  // along the cut did.
  EXPECT_LE(toggled.activity(toggled.bodies()[0]).activeLinks,
            on.activity(on.bodies()[0]).activeLinks);
  EXPECT_LT(2 * toggled.activity(toggled.bodies()[0]).activeLinks, allLinks);
  EXPECT_FALSE(toggled.activity(toggled.bodies()[0]).cubes.empty());
  // The cubes' corners are where the material is: inside the box, which barely moves.
  for (const auto& cube : start.cubes)
    for (const Vec3d& c : cube) EXPECT_TRUE(c.y() > -0.001 && c.y() < 0.061);
}

// Poses along keys with jumps: held towards a jump, the jump's pose from its time on, the pose
// before it when reached from below.
TEST(World, JumpKeysHoldThenJump) {
  const BladePose p0{Vec3d(0, 0, 0), Vec3d(1, 0, 0)}, p1{Vec3d(0, 1, 0), Vec3d(1, 1, 0)},
      p2{Vec3d(5, 5, 5), Vec3d(6, 5, 5)}, p3{Vec3d(5, 6, 5), Vec3d(6, 6, 5)};
  const std::vector<ToolKey> keys{{0.0, p0}, {1.0, p1}, {1.0, p2, true}, {2.0, p3}};
  EXPECT_TRUE(keysInOrder(keys));
  EXPECT_EQ(bladePoseAt(keys, 0.5).a, Vec3d(0, 0.5, 0));
  EXPECT_EQ(bladePoseAt(keys, 1.0).a, p2.a);
  EXPECT_EQ(bladePoseBefore(keys, 1.0).a, p1.a);
  EXPECT_EQ(bladePoseBefore(keys, 0.5).a, Vec3d(0, 0.5, 0));
  EXPECT_EQ(bladePoseAt(keys, 1.5).a, Vec3d(5, 5.5, 5));
  EXPECT_EQ(jumpIn(keys, 0.996, 1.0), nullptr);
  EXPECT_EQ(jumpIn(keys, 1.0, 1.004), &keys[2]);
  // A jump from a held pose: towards it the pose stays.
  const std::vector<ToolKey> held{{0.0, p0}, {1.0, p2, true}};
  EXPECT_EQ(bladePoseAt(held, 0.999).a, p0.a);
  EXPECT_EQ(bladePoseBefore(held, 1.0).a, p0.a);
  EXPECT_EQ(bladePoseAt(held, 1.0).a, p2.a);
  // A jump sharing the first key's time: from that time on, the jump's pose.
  const std::vector<ToolKey> first{{0.0, p0}, {0.0, p2, true}, {1.0, p3}};
  EXPECT_EQ(bladePoseAt(first, 0.0).a, p2.a);
  EXPECT_EQ(bladePoseBefore(first, 0.0).a, p0.a);
  EXPECT_FALSE(keysInOrder({{1.0, p0}, {1.0, p1}}));
  EXPECT_FALSE(keysInOrder({{1.0, p0}, {0.5, p1, true}}));
}

TEST(World, ProbeResultsSameForAnyThreadCount) {
  const std::string probe = R"("tools": [{"type": "probe", "radius": 0.01, "keys": [
      {"t": 0.0, "a": [-0.02, 0.075, 0], "b": [0.02, 0.07, 0]},
      {"t": 0.2, "a": [-0.02, 0.062, 0], "b": [0.02, 0.065, 0]}]}])";
  auto run = [&](int threads) {
    ThreadLimit limit(threads);
    World w = worldOf(box(probe, kBaseFixed));
    for (int f = 0; f < 60; ++f) (void)w.step();
    return std::make_pair(w.nodes(w.bodies()[0]).positions, w.toolReaction(w.tools()[0]).torque);
  };
  const auto one = run(1), two = run(2);
  EXPECT_EQ(one.first, two.first);
  EXPECT_EQ(one.second, two.second);
  EXPECT_GT(one.second.norm(), 0.0);  // the tilted capsule presses off its centre
}

// The haptic call: at the last frame's pose it gives that frame's reaction; between frames it
// follows the probe's motion continuously, and never pulls; a thread calling it all the time
// beside the frames sees only whole snapshots (the tsan preset checks the locking).
TEST(World, HapticForceFollowsTheProbeBetweenFrames) {
  const std::string probe = R"("tools": [{"type": "probe", "radius": 0.01, "keys": [
      {"t": 0.0, "p": [0, 0.075, 0]}]}])";
  World w = worldOf(box(probe, kBaseFixed));
  std::atomic<bool> done{false};
  std::atomic<int> calls{0};
  std::thread device([&] {
    while (!done.load()) {
      const ToolReaction r =
          w.hapticForce(w.tools()[0], {Vec3d(0, 0.066, 0), Vec3d(0, 0.066, 0)}).reaction;
      EXPECT_GE(r.force.y(), 0.0);
      calls.fetch_add(1);
    }
  });
  // Pressed in 0.1 mm per frame, from 1 mm above the top.
  auto at = [](int f) {
    const Vec3d c(0, 0.071 - 1e-4 * f, 0);
    return BladePose{c, c};
  };
  int f = 0;
  for (; f < 40; ++f) {
    w.setToolPose(w.tools()[0], at(f + 1));
    (void)w.step();
  }
  done = true;
  device.join();
  EXPECT_GT(calls.load(), 0);
  // Past the longest period the call blends a new frame's model in over, it is that model's.
  const auto blended = std::chrono::milliseconds(60);
  std::this_thread::sleep_for(blended);
  const Vec3d now = w.toolReaction(w.tools()[0]).force;
  ASSERT_GT(now.y(), 0.0);
  EXPECT_EQ(w.hapticForce(w.tools()[0], at(f)).reaction.force, now);
  // Half way to the next frame's pose, the force lies between the two frames' forces.
  const Vec3d half =
      w.hapticForce(w.tools()[0], {0.5 * (at(f).a + at(f + 1).a), 0.5 * (at(f).a + at(f + 1).a)})
          .reaction.force;
  w.setToolPose(w.tools()[0], at(f + 1));
  (void)w.step();
  const Vec3d next = w.toolReaction(w.tools()[0]).force;
  std::this_thread::sleep_for(blended);
  EXPECT_EQ(w.hapticForce(w.tools()[0], at(f + 1)).reaction.force, next);
  EXPECT_GT(half.y(), now.y());
  EXPECT_LT(half.y(), next.y());
  EXPECT_NEAR(half.y(), 0.5 * (now.y() + next.y()), 0.1 * (next.y() - now.y()));
  // Pulled well away, it does not pull.
  const Vec3d away(0, 0.2, 0);
  EXPECT_EQ(w.hapticForce(w.tools()[0], {away, away}).reaction.force, Vec3d::Zero());
}

// bunny-poke.json: the probe presses the bunny's back and lets go; the bunny springs back to
// where gravity alone holds it.
TEST(World, BunnyPokeSpringsBack) {
  const Scene scene = readScene(std::string(VOXCUT_SOURCE_DIR) + "/scenes/bunny-poke.json");
  Scene still = scene;
  still.tools.clear();
  World poked = World::fromScene(scene, voxelizeSceneBodies(scene));
  World alone = World::fromScene(still, voxelizeSceneBodies(still));
  double pressed = 0.0, force = 0.0;
  for (int f = 0; f < *scene.frames; ++f) {
    const FrameReport r = poked.step();
    (void)alone.step();
    ASSERT_TRUE(r.converged);
    if (f == 199) {  // the end of the hold
      pressed = poked.maxDisplacement();
      force = r.toolReactions[0].force.norm();
    }
  }
  EXPECT_GT(pressed, 0.005);  // most of the 1 cm the probe goes down
  EXPECT_GT(force, 1.0);
  EXPECT_EQ(poked.toolReaction(poked.tools()[0]).force, Vec3d::Zero());
  const std::vector<Vec3d> a = poked.nodes(poked.bodies()[0]).positions;
  const std::vector<Vec3d> b = alone.nodes(alone.bodies()[0]).positions;
  double apart = 0.0;
  for (std::size_t n = 0; n < a.size(); ++n) apart = std::max(apart, (a[n] - b[n]).norm());
  EXPECT_LT(apart, 0.05 * pressed);
}

// The deepest any surface vertex of body a lies inside body b (a == b: itself, away from its
// own neighbourhood), measured in b's rest frame, where they are now.
double deepestInside(const World& w, std::size_t a, std::size_t b) {
  return w.penetration(w.bodies()[a], w.bodies()[b]);
}

// A box fixed at its base, slit from the top by a blade (not cut through), then its left flap
// pushed by a probe against the right one; self collision on or off.
std::string slitBoxPressed(bool self) {
  return box(R"("contact": {"self_collision": )" + std::string(self ? "true" : "false") + R"(},
        "tools": [{"type": "blade", "keys": [
          {"t": 0.0, "a": [0.0005, 0.07, -0.06], "b": [0.0005, 0.07, 0.06]},
          {"t": 0.06, "a": [0.0005, 0.02, -0.06], "b": [0.0005, 0.02, 0.06]}]},
          {"type": "probe", "radius": 0.01, "friction": 0, "keys": [
          {"t": 0.08, "p": [-0.062, 0.045, 0]}, {"t": 0.3, "p": [-0.05, 0.045, 0]}]}])",
             kBaseFixed);
}

// The slit box: the two sides of the cut meet and stay apart with self collision, and pass
// into each other without it.
TEST(World, SelfCollisionKeepsTheSidesOfACutApart) {
  auto run = [](bool self) {
    World w = worldOf(slitBoxPressed(self));
    for (int f = 0; f < 100; ++f) EXPECT_TRUE(w.step().converged);
    EXPECT_EQ(w.pieces(w.bodies()[0]), 1);  // a slit, not a cut through
    return std::make_pair(deepestInside(w, 0, 0), w.bodyInfo(w.bodies()[0]).voxelSize);
  };
  const auto [with, voxel] = run(true);
  const auto without = run(false).first;
  EXPECT_LT(with, 0.5 * voxel);
  EXPECT_GT(without, 0.5 * voxel);
}

// Self collision's candidates kept between frames (a Verlet list) find the same contacts as a
// fresh query every frame, while the slit box's flap is pushed against its other side: a world
// that keeps them and one that queries afresh every frame run bit for bit the same; and they
// are reused, not queried every frame.
TEST(World, SelfCandidatesKeptBetweenFramesFindTheSameContacts) {
  const Scene keptScene = sceneOf(slitBoxPressed(true));
  Scene freshScene = keptScene;
  freshScene.contact.keepSelfCandidates = false;
  World kept = World::fromScene(keptScene, voxelizeSceneBodies(keptScene));
  World fresh = World::fromScene(freshScene, voxelizeSceneBodies(freshScene));
  std::size_t found = 0;
  for (int f = 0; f < 100; ++f) {
    const FrameReport a = kept.step(), b = fresh.step();
    ASSERT_EQ(a.contacts, b.contacts) << "frame " << f;
    ASSERT_EQ(kept.contacts().size(), fresh.contacts().size()) << "frame " << f;
    for (std::size_t k = 0; k < kept.contacts().size(); ++k) {
      const Contact& ck = kept.contacts()[k];
      const Contact& cf = fresh.contacts()[k];
      EXPECT_EQ(ck.with, cf.with);
      EXPECT_EQ(ck.point, cf.point);
      EXPECT_EQ(ck.depth, cf.depth);
      EXPECT_EQ(ck.force, cf.force);
      found += ck.with == Contact::With::Self ? 1 : 0;
    }
    ASSERT_EQ(kept.nodes(kept.bodies()[0]).positions, fresh.nodes(fresh.bodies()[0]).positions)
        << "frame " << f;
  }
  EXPECT_GT(found, 0u);
  EXPECT_EQ(fresh.bodyInfo(fresh.bodies()[0]).selfCandidateQueries, 100u);
  EXPECT_LT(kept.bodyInfo(kept.bodies()[0]).selfCandidateQueries, 50u);
}

// A small soft box dropped onto a larger one fixed at its base comes to rest on it, no vertex
// deeper than half a voxel in the other, carrying its weight; from 0.3 m it does not pass
// through.
TEST(World, BodyDroppedOnAnotherComesToRest) {
  auto scene = [](double height) {
    return R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
      "solver": {"tolerance": 1e-6, "max_iterations": 1000},
      "bodies": [
        {"model": "box:0.1,0.06,0.08", "resolution": 32, "element_level": 2, "offset": [0, 0.03, 0],
         "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000,
                                   "damping": [2, 0.01]}},
         "fixed": [{"box": [[-1, -1, -1], [1, 0.002, 1]]}]},
        {"model": "box:0.06,0.04,0.05", "resolution": 20, "element_level": 2,
         "offset": [0.01, )" +
           std::to_string(0.08 + height) + R"(, 0.005],
         "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000,
                                   "damping": [2, 0.01]}}}]})";
  };
  {
    World w = worldOf(scene(0.01));
    double deepest = 0.0;
    for (int f = 0; f < 300; ++f) deepest = std::max(deepest, w.step().maxPenetration);
    const double voxel = w.bodyInfo(w.bodies()[1]).voxelSize;
    EXPECT_LT(deepest, 0.5 * voxel);
    EXPECT_LT(w.energy(w.bodies()[1]).kinetic, 1e-7);
    EXPECT_LT(deepestInside(w, 1, 0), 0.5 * voxel);
    // It rests on the lower box's top (y = 0.06), not beside or in it.
    double lowest = 1e9;
    for (const Vec3d& x : w.nodes(w.bodies()[1]).positions) lowest = std::min(lowest, x.y());
    EXPECT_GT(lowest, 0.055);
  }
  {
    World w = worldOf(scene(0.3));
    for (int f = 0; f < 200; ++f) (void)w.step();
    double lowest = 1e9;
    for (const Vec3d& x : w.nodes(w.bodies()[1]).positions) lowest = std::min(lowest, x.y());
    EXPECT_GT(lowest, 0.055);
  }
}

// Coulomb friction, with gravity tilted 20 degrees off the plane's normal: a box holds still
// where mu > tan 20 (0.36) and slides with acceleration g (sin 20 - mu cos 20) where not (no
// mass damping, which would slow the sliding box as a drag).
TEST(World, FrictionHoldsOrSlidesAsCoulombSays) {
  const double theta = 20.0 * 3.14159265358979 / 180.0;
  auto slide = [&](double mu) {
    const std::string scene = R"({"time_step": 0.004, "gravity": [)" +
                              std::to_string(9.81 * std::sin(theta)) + ", " +
                              std::to_string(-9.81 * std::cos(theta)) + R"(, 0],
      "solver": {"tolerance": 1e-6, "max_iterations": 1000},
      "bodies": [{"model": "box:0.1,0.06,0.08", "resolution": 32, "element_level": 2,
        "offset": [0, 0.0301, 0],
        "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000,
                                  "damping": [0, 0.01]}}}],
      "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": )" +
                              std::to_string(mu) + "}]}";
    World w = worldOf(scene);
    auto centreX = [&] {
      double x = 0.0;
      const std::vector<Vec3d> p = w.nodes(w.bodies()[0]).positions;
      for (const Vec3d& q : p) x += q.x();
      return x / static_cast<double>(p.size());
    };
    std::vector<double> xs;
    for (int f = 0; f <= 150; ++f) {
      (void)w.step();
      if (f % 50 == 0) xs.push_back(centreX());
    }
    // Acceleration from the positions at frames 50, 100 and 150 (0.2 s apart).
    const double t = 0.2;
    return std::make_pair(xs[3] - xs[1], (xs[3] - 2.0 * xs[2] + xs[1]) / (t * t));
  };
  const auto [held, heldAcceleration] = slide(0.5);
  EXPECT_LT(std::abs(held), 1e-3);
  const auto [slid, acceleration] = slide(0.2);
  const double expected = 9.81 * (std::sin(theta) - 0.2 * std::cos(theta));
  EXPECT_GT(slid, 0.02);
  EXPECT_NEAR(acceleration, expected, 0.1 * expected);
}

// ear-on-table.json: the ear comes off and comes to rest on the flat stump it was cut from
// (its centre of mass is over the cut face), at the cut's height, outside the bunny; the bunny
// stays standing on the table.
TEST(World, EarOnTableComesToRestOnItsStump) {
  const Scene scene = readScene(std::string(VOXCUT_SOURCE_DIR) + "/scenes/ear-on-table.json");
  World w = World::fromScene(scene, voxelizeSceneBodies(scene));
  const BodyId b = w.bodies()[0];
  auto earCentre = [&](const BodyVoxels& voxels, int ear) {
    Vec3d c = Vec3d::Zero();
    for (std::size_t v = 0; v < voxels.pieces.size(); ++v)
      if (voxels.pieces[v] == ear) c += voxels.positions[v];
    return Vec3d(c / static_cast<double>(voxels.pieceVoxels[static_cast<std::size_t>(ear)]));
  };
  double deepest = 0.0;
  Vec3d before = Vec3d::Zero();
  for (int f = 0; f < *scene.frames; ++f) {
    const FrameReport r = w.step();
    ASSERT_TRUE(r.converged) << "frame " << f;
    deepest = std::max(deepest, r.maxPenetration);
    if (f == *scene.frames - 51) {
      const BodyVoxels voxels = w.voxels(b);
      ASSERT_EQ(voxels.pieceVoxels.size(), 2u);
      before = earCentre(voxels, voxels.pieceVoxels[0] < voxels.pieceVoxels[1] ? 0 : 1);
    }
  }
  const BodyVoxels voxels = w.voxels(b);
  ASSERT_EQ(voxels.pieceVoxels.size(), 2u);
  const int ear = voxels.pieceVoxels[0] < voxels.pieceVoxels[1] ? 0 : 1;
  const Vec3d now = earCentre(voxels, ear);
  const double voxel = w.bodyInfo(b).voxelSize;
  EXPECT_LT((now - before).norm(), 0.1 * voxel) << "the ear still moves";
  // The ear's lowest voxel at the cut's height (the blade's), the bunny's on the table (y = 0).
  const double cutHeight = scene.tools.at(0).keys.at(0).pose.a.y();
  double earLowest = 1e9, bunnyLowest = 1e9;
  for (std::size_t v = 0; v < voxels.pieces.size(); ++v) {
    double& lowest = voxels.pieces[v] == ear ? earLowest : bunnyLowest;
    lowest = std::min(lowest, voxels.positions[v].y());
  }
  EXPECT_NEAR(earLowest, cutHeight, 1.5 * voxel);
  EXPECT_GT(bunnyLowest, -0.5 * voxel);
  EXPECT_LT(bunnyLowest, 1.5 * voxel);
  // Through neither the table nor the bunny: at rest less than half a voxel inside, and never
  // a voxel deep on the way.
  EXPECT_LT(deepest, voxel);
  EXPECT_LT(deepestInside(w, 0, 0), 0.5 * voxel);
}

// starfish-stack.json: both arms come off; the upper one ends leaning on the lower one, both at
// rest, neither inside the other nor the table.
TEST(World, StarfishStackArmsRestOnEachOther) {
  const Scene scene = readScene(std::string(VOXCUT_SOURCE_DIR) + "/scenes/starfish-stack.json");
  World w = World::fromScene(scene, voxelizeSceneBodies(scene));
  // Per body, the cut-off arm's voxels where they are now (the smaller piece).
  auto armVoxels = [&](std::size_t body) {
    const BodyVoxels voxels = w.voxels(w.bodies()[body]);
    EXPECT_EQ(voxels.pieceVoxels.size(), 2u);
    const int arm = voxels.pieceVoxels[0] < voxels.pieceVoxels[1] ? 0 : 1;
    std::vector<Vec3d> out;
    for (std::size_t v = 0; v < voxels.pieces.size(); ++v)
      if (voxels.pieces[v] == arm) out.push_back(voxels.positions[v]);
    return out;
  };
  auto centre = [](const std::vector<Vec3d>& xs) {
    Vec3d c = Vec3d::Zero();
    for (const Vec3d& x : xs) c += x;
    return Vec3d(c / static_cast<double>(xs.size()));
  };
  Vec3d lowerBefore = Vec3d::Zero(), upperBefore = Vec3d::Zero();
  for (int f = 0; f < *scene.frames; ++f) {
    ASSERT_TRUE(w.step().converged) << "frame " << f;
    if (f == *scene.frames - 26) {
      lowerBefore = centre(armVoxels(0));
      upperBefore = centre(armVoxels(1));
    }
  }
  const std::vector<Vec3d> lower = armVoxels(0), upper = armVoxels(1);
  const double voxel = w.bodyInfo(w.bodies()[0]).voxelSize;
  EXPECT_LT((centre(lower) - lowerBefore).norm(), 0.5 * voxel) << "the lower arm still moves";
  EXPECT_LT((centre(upper) - upperBefore).norm(), 0.5 * voxel) << "the upper arm still moves";
  // Touching: some voxel of each within two voxels of the other's; and the upper arm lies on the
  // lower one, its centre higher.
  double nearest = 1e9;
  for (const Vec3d& a : upper)
    for (const Vec3d& b : lower) nearest = std::min(nearest, (a - b).squaredNorm());
  EXPECT_LT(std::sqrt(nearest), 2.0 * voxel);
  EXPECT_GT(centre(upper).z(), centre(lower).z() + 2.0 * voxel);
  // Neither in the other nor in the table.
  EXPECT_LT(deepestInside(w, 1, 0), 0.5 * voxel);
  EXPECT_LT(deepestInside(w, 0, 1), 0.5 * voxel);
  double lowest = 1e9;
  for (const auto* arm : {&lower, &upper})
    for (const Vec3d& x : *arm) lowest = std::min(lowest, x.z());
  EXPECT_GT(lowest, -0.5 * voxel);
}

// liver-probe-cut.json, the paper's complex scenario: a probe presses the lobe from below while
// the blade cuts around the tumor; the column comes off, rests on the probe (which carries its
// weight) and is lifted; every surface stays closed.
TEST(World, LiverProbeCutLiftsTheColumn) {
  const Scene scene = readScene(std::string(VOXCUT_SOURCE_DIR) + "/scenes/liver-probe-cut.json");
  World w = World::fromScene(scene, voxelizeSceneBodies(scene));
  for (int f = 0; f < *scene.frames; ++f) ASSERT_TRUE(w.step().converged) << "frame " << f;
  const BodyVoxels voxels = w.voxels(w.bodies()[0]);
  ASSERT_EQ(voxels.pieceVoxels.size(), 2u);
  // The column is the piece that no fixed box holds: the smaller one.
  const int column = voxels.pieceVoxels[0] < voxels.pieceVoxels[1] ? 0 : 1;
  Vec3d rest = Vec3d::Zero(), now = Vec3d::Zero();
  for (std::size_t v = 0; v < voxels.pieces.size(); ++v)
    if (voxels.pieces[v] == column) {
      rest += voxels.restPositions[v];
      now += voxels.positions[v];
    }
  const double n = static_cast<double>(voxels.pieceVoxels[static_cast<std::size_t>(column)]);
  EXPECT_GT((now - rest).z() / n, 0.015) << "the column was not lifted";
  // The probe carries the column's weight (it is at rest on it, within a fifth).
  const double weight = 1060.0 * n * std::pow(w.bodyInfo(w.bodies()[0]).voxelSize, 3) * 9.81;
  EXPECT_NEAR(-w.toolReaction(w.tools()[1]).force.z(), weight, 0.2 * weight);
  EXPECT_TRUE(surfaceTopology(w.surfaceMesh(w.bodies()[0])).closed);
}

// Contacts between bodies and of a body with itself, with friction: the same at 1 and 2
// threads, bit for bit.
TEST(World, BodyContactsSameForAnyThreadCount) {
  const std::string scene = R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
    "contact": {"self_collision": true, "friction": 0.4},
    "bodies": [
      {"model": "box:0.1,0.06,0.08", "resolution": 24, "element_level": 2, "offset": [0, 0.03, 0],
       "fixed": [{"box": [[-1, -1, -1], [1, 0.002, 1]]}]},
      {"model": "box:0.06,0.04,0.05", "resolution": 16, "element_level": 2,
       "offset": [0.01, 0.081, 0.005]}]})";
  auto run = [&](int threads) {
    ThreadLimit limit(threads);
    World w = worldOf(scene);
    std::size_t contacts = 0;
    for (int f = 0; f < 40; ++f) contacts += w.step().contacts;
    EXPECT_GT(contacts, 0u);
    return w.nodes(w.bodies()[1]).positions;
  };
  EXPECT_EQ(run(1), run(2));
}

}  // namespace
}  // namespace voxcut
