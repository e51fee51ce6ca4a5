// Snapshots and the step that finishes or changes nothing (sim/World.h; docs/architecture.md,
// "Snapshots" and "Errors"): a restored world steps on bit for bit as the original did; undoing
// a cut gives the world that never cut; handles and surface revisions after a restore; a
// failed step leaves the world as it was, and the world steps on as if it had never been
// tried, whatever frame the world's rollback point was taken at.
#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>
#include <vector>

#include "ContractWorld.h"
#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"
#include "voxcut/sim/WorldTesting.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {
namespace {

using namespace contract;

// Steps `w` to `frame`, returning the reports.
std::vector<FrameReport> stepTo(World& w, int frame) {
  std::vector<FrameReport> reports;
  while (w.frame() < frame) reports.push_back(w.step());
  return reports;
}

void expectSameReports(const std::vector<FrameReport>& a, const std::vector<FrameReport>& b,
                       const std::string& when) {
  ASSERT_EQ(a.size(), b.size()) << when;
  for (std::size_t k = 0; k < a.size(); ++k)
    expectSameReport(a[k], b[k], when + ", frame " + std::to_string(a[k].frame));
}

// The blade slits the box from about frame 6 to 31 and the probe presses from frame 5 on: a
// snapshot at frame 10, run on to 25 (cutting), restored, gives frames 11-40 bit for bit as a
// world that never took one.
TEST(Snapshot, RestoredWorldStepsOnBitForBit) {
  Handles ha, hb;
  World a = contractWorld(ha);
  World b = contractWorld(hb);
  (void)stepTo(a, 10);
  (void)stepTo(b, 10);
  const WorldSnapshot at10 = b.snapshot();
  EXPECT_EQ(at10.frame(), 10);
  EXPECT_DOUBLE_EQ(at10.time(), b.time());
  const std::vector<FrameReport> first = stepTo(b, 25);
  std::size_t cut = 0;
  for (const FrameReport& r : first) cut += r.cutLinks;
  ASSERT_GT(cut, 0u) << "the blade should cut between frames 10 and 25";
  ASSERT_NE(a.cutSetHash(), b.cutSetHash());
  b.restore(at10);
  EXPECT_EQ(b.frame(), 10);
  expectSameWorld(a, b, "restored at frame 10");
  const std::vector<FrameReport> ra = stepTo(a, 40), rb = stepTo(b, 40);
  expectSameReports(ra, rb, "after the restore");
  expectSameWorld(a, b, "frame 40");
  // The snapshot outlives its use: restored a second time, the same again.
  b.restore(at10);
  expectSameReports(ra, stepTo(b, 40), "restored twice");
  expectSameWorld(a, b, "frame 40, restored twice");
}

// Snapshot, cut, restore, step: the same cuts, surfaces and nodes as a world that never cut.
TEST(Snapshot, UndoingACutGivesTheWorldThatNeverCut) {
  Handles ha, hb;
  World a = contractWorld(ha);
  World b = contractWorld(hb);
  // The blade parked off the box, both worlds: no trajectories from here on.
  const BladePose parked = segment(Vec3d(-0.1, 0.04, -0.1), Vec3d(0.0, 0.04, -0.1));
  for (auto [w, h] : {std::pair{&a, &ha}, std::pair{&b, &hb}}) {
    w->placeTool(h->blade, parked);
    w->setToolPose(h->probe, w->toolPose(h->probe));
    (void)stepTo(*w, 5);
  }
  const std::uint64_t uncut = b.cutSetHash();
  const WorldSnapshot before = b.snapshot();
  for (int f = 0; f < 12; ++f) {  // through the box along z
    const double z = -0.1 + 0.02 * (f + 1);
    b.setToolPose(hb.blade, segment(Vec3d(-0.1, 0.04, z), Vec3d(0.0, 0.04, z)));
    (void)b.step();
  }
  ASSERT_NE(b.cutSetHash(), uncut);
  b.restore(before);
  EXPECT_EQ(b.cutSetHash(), uncut);
  expectSameWorld(a, b, "undone");
  for (World* w : {&a, &b}) (void)stepTo(*w, 30);
  expectSameWorld(a, b, "25 frames after the undo");
}

// Handles after a restore: those of the snapshot's objects are valid again (a body removed
// since comes back), those made since are refused, and new ones never equal an old one.
TEST(Snapshot, HandlesAfterARestore) {
  Handles h;
  World w = contractWorld(h, false);
  const WorldSnapshot s = w.snapshot();
  w.removeBody(h.spareBody);
  w.removeTool(h.spareTool);
  const ToolId added = w.addProbe(0.01, sphereAt(Vec3d(1, 1, 1)));
  Obstacle plane;
  plane.point = Vec3d(2, 0, 0);
  plane.normal = Vec3d(-1, 0, 0);
  const ObstacleId wall = w.addObstacle(plane);
  w.restore(s);
  EXPECT_TRUE(w.contains(h.spareBody));
  EXPECT_TRUE(w.contains(h.spareTool));
  EXPECT_TRUE(w.contains(h.spareObstacle));
  EXPECT_FALSE(w.contains(added));
  EXPECT_FALSE(w.contains(wall));
  EXPECT_THROW((void)w.toolPose(added), InputError);
  EXPECT_EQ(w.bodies().size(), 2u);
  EXPECT_EQ(w.tools().size(), 3u);
  const ToolId again = w.addProbe(0.01, sphereAt(Vec3d(1, 1, 1)));
  EXPECT_NE(again, added);
  EXPECT_TRUE(w.contains(again));
  EXPECT_FALSE(w.contains(added));
  EXPECT_THROW(w.restore(WorldSnapshot{}), InputError);
}

// A handle names an object of the world that made it (or of one that restored its snapshot):
// another world's handles are refused, never taken for its own objects in the same slots.
TEST(Snapshot, HandlesOfAnotherWorldAreRefused) {
  Handles ha, hb;
  World a = contractWorld(ha);
  World b = contractWorld(hb);
  EXPECT_FALSE(b.contains(ha.body));
  EXPECT_FALSE(b.contains(ha.probe));
  EXPECT_FALSE(b.contains(ha.floor));
  EXPECT_THROW((void)b.bodyInfo(ha.body), InputError);
  EXPECT_THROW(b.setToolPose(ha.probe, sphereAt(Vec3d(0, 1, 0))), InputError);
  EXPECT_EQ(b.hapticForce(ha.probe, sphereAt(Vec3d(0, 1, 0))).status,
            HapticAnswer::Status::NotAProbe);
  // b restored from a's snapshot is a's world: a's handles name its objects there.
  b.restore(a.snapshot());
  EXPECT_TRUE(b.contains(ha.body));
  EXPECT_FALSE(b.contains(hb.body));
}

// A body needs material: an empty grid is refused and the world is left without a body.
TEST(Snapshot, AnEmptyGridIsNoBody) {
  World w;
  try {
    (void)w.addBody(VoxelGrid({6, 6, 6}, Vec3d::Zero(), 0.01));
    ADD_FAILURE() << "an empty grid was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("grid"), std::string::npos) << e.what();
  }
  EXPECT_EQ(w.bodyCount(), 0u);
  (void)w.step();
}

// A reader's surface revision from before a restore names no surface after it: it gets the
// whole surface again, not the changes of another history.
TEST(Snapshot, SurfaceReadersStartAfreshAfterARestore) {
  Handles h;
  World w = contractWorld(h);
  const WorldSnapshot s = w.snapshot();
  (void)stepTo(w, 25);  // cuts: the surface's topology changes
  const std::uint64_t later = w.surface(h.body).revision;
  w.restore(s);
  const std::uint64_t restored = w.surface(h.body).revision;
  EXPECT_NE(restored, later);
  EXPECT_TRUE(w.surfaceChanges(h.body, later).full);
  (void)stepTo(w, 25);
  const SurfaceChanges since = w.surfaceChanges(h.body, restored);
  EXPECT_NE(w.surface(h.body).revision, later);
  EXPECT_EQ(since.to, w.surface(h.body).revision);
}

// A failed step (the second body's solve, in a frame where the blade cuts the first body and
// the probe presses it) throws StepError naming the body and the frame, leaves the world as
// it was before the call, and the world then steps on as one that never tried.
void expectFailedStepChangesNothing(int failAt, int snapshotAt) {
  SCOPED_TRACE("failing frame " + std::to_string(failAt) + ", snapshot at " +
               std::to_string(snapshotAt));
  Handles ha, hb;
  World a = contractWorld(ha, false);
  World b = contractWorld(hb, false);
  (void)stepTo(a, failAt);
  (void)stepTo(b, snapshotAt);
  if (snapshotAt >= 0) (void)b.snapshot();
  (void)stepTo(b, failAt);
  WorldTesting::failNextStep(b, hb.spareBody);
  try {
    (void)b.step();
    ADD_FAILURE() << "the step did not fail";
  } catch (const StepError& e) {
    EXPECT_EQ(e.body(), hb.spareBody);
    EXPECT_EQ(e.frame(), failAt);
    EXPECT_NE(std::string(e.what()).find("frame " + std::to_string(failAt)), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(b.frame(), failAt);
  for (const BodyId body : b.bodies()) EXPECT_EQ(b.selfCheck(body), "") << "after the failed step";
  expectSameWorld(a, b, "after the failed step");
  EXPECT_EQ(a.contacts().size(), b.contacts().size());
  for (World* w : {&a, &b}) EXPECT_EQ(w->pieces(w->bodies()[0]), a.pieces(a.bodies()[0]));
  const std::vector<FrameReport> ra = stepTo(a, failAt + 15), rb = stepTo(b, failAt + 15);
  expectSameReports(ra, rb, "after the failed step");
  expectSameWorld(a, b, "15 frames on");
}

TEST(StepFailure, LeavesTheWorldAsItWasAndStepsOn) {
  expectFailedStepChangesNothing(15, -1);  // rollback point: the world's own
  expectFailedStepChangesNothing(15, 15);  // a snapshot taken just before
  expectFailedStepChangesNothing(15, 8);   // a snapshot 7 frames before: those run again
  expectFailedStepChangesNothing(0, -1);   // the very first step
}

// The world's rollback point survives edits that drop it: a step after them fails cleanly too.
TEST(StepFailure, AfterEditsAndToolPoses) {
  Handles ha, hb;
  World a = contractWorld(ha, false);
  World b = contractWorld(hb, false);
  for (World* w : {&a, &b}) (void)stepTo(*w, 5);
  for (auto [w, h] : {std::pair{&a, &ha}, std::pair{&b, &hb}}) {
    SceneMaterial m;
    m.name = "default";
    m.youngModulus = 2e5;
    m.poissonRatio = 0.3;
    m.density = 1000;
    w->setMaterial(h->body, m);
    for (int f = 0; f < 6; ++f) {
      w->setToolPose(h->probe, sphereAt(Vec3d(0.03, 0.065 - 0.001 * f, 0)));
      (void)w->step();
    }
    w->setToolPose(h->probe, sphereAt(Vec3d(0.03, 0.058, 0)));
  }
  WorldTesting::failNextStep(b, hb.body);
  EXPECT_THROW((void)b.step(), StepError);
  expectSameWorld(a, b, "after the failed step");
  expectSameReport(a.step(), b.step(), "the step after");
  expectSameWorld(a, b, "one frame on");
}

// The haptic call may run on another thread while a step fails and the world goes back (the
// frames since its rollback point run again): it keeps answering, never blocks or crashes,
// and its answers stay finite. (Under the tsan preset, this is also the race check.)
TEST(StepFailure, HapticCallsDuringARollBack) {
  Handles h;
  World w = contractWorld(h, false);
  (void)stepTo(w, 8);
  (void)w.snapshot();  // the rollback point: frames 8 to 14 run again
  std::atomic<bool> done{false};
  std::atomic<int> calls{0}, bad{0};
  std::thread device([&] {
    while (!done.load()) {
      const HapticAnswer a = w.hapticForce(h.probe, sphereAt(Vec3d(0.03, 0.066, 0)));
      if (!a.reaction.force.allFinite() || a.status != HapticAnswer::Status::Ok) ++bad;
      ++calls;
    }
  });
  (void)stepTo(w, 15);
  WorldTesting::failNextStep(w, h.spareBody);
  EXPECT_THROW((void)w.step(), StepError);
  (void)stepTo(w, 20);
  done = true;
  device.join();
  EXPECT_GT(calls.load(), 0);
  EXPECT_EQ(bad.load(), 0);
  EXPECT_EQ(w.frame(), 20);
}

// bunny-poke.json: a snapshot after 100 frames, restored, reproduces frames 101-200 bit for
// bit, the probe pressing the bunny's back all along.
TEST(Snapshot, BunnyPokeFrames101To200) {
  const Scene scene = readScene(std::string(VOXCUT_SOURCE_DIR) + "/scenes/bunny-poke.json");
  World w = World::fromScene(scene, voxelizeSceneBodies(scene));
  (void)stepTo(w, 100);
  const WorldSnapshot s = w.snapshot();
  const std::vector<FrameReport> first = stepTo(w, 200);
  const NodeState end = w.nodes(w.bodies()[0]);
  const SurfaceMesh surface = w.surfaceMesh(w.bodies()[0]);
  const ToolReaction push = w.toolReaction(w.tools()[0]);
  ASSERT_GT(push.force.norm(), 0.5);
  w.restore(s);
  expectSameReports(first, stepTo(w, 200), "restored at frame 100");
  const NodeState again = w.nodes(w.bodies()[0]);
  EXPECT_TRUE(sameBits(end.positions, again.positions));
  EXPECT_TRUE(sameBits(end.velocities, again.velocities));
  EXPECT_TRUE(sameBits(surface.positions, w.surfaceMesh(w.bodies()[0]).positions));
  EXPECT_TRUE(sameBits(push.force, w.toolReaction(w.tools()[0]).force));
}

}  // namespace
}  // namespace voxcut
