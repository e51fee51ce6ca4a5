// The viewer's logic without a window: the camera's rays and projections, the input layer
// driving the blade and the probe through mouse events, the recording saved as a scene that
// `voxcut run` replays, the octree toggle in what is drawn, and the simulation's thread.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "Camera.h"
#include "Command.h"
#include "DrawData.h"
#include "Input.h"
#include "Session.h"
#include "SimRunner.h"
#include "voxcut/core/Error.h"

namespace voxcut::view {
namespace {

namespace fs = std::filesystem;

TEST(Camera, RaysGoThroughWhatProjectsThere) {
  Camera c;
  c.width = 320;
  c.height = 200;
  c.fit(Eigen::AlignedBox3d(Vec3d(-1, 0, -0.5), Vec3d(1, 0.5, 0.5)));
  for (const Vec3d& x : {Vec3d(0.3, 0.2, 0.1), Vec3d(-0.9, 0.45, 0.4), Vec3d(1, 0, -0.5)}) {
    double px = 0, py = 0;
    ASSERT_TRUE(c.project(x, px, py));
    // The box fits the view.
    EXPECT_GT(px, 0.0);
    EXPECT_LT(px, c.width);
    EXPECT_GT(py, 0.0);
    EXPECT_LT(py, c.height);
    const Ray r = c.ray(px, py);
    const Vec3d to = x - r.origin;
    EXPECT_LT((to - to.dot(r.direction) * r.direction).norm(), 1e-9);
  }
  // The target sits in the middle; panning moves it with the view, orbiting keeps it.
  double px = 0, py = 0;
  ASSERT_TRUE(c.project(c.target, px, py));
  EXPECT_NEAR(px, 159.5, 1e-9);
  EXPECT_NEAR(py, 99.5, 1e-9);
  const Vec3d before = c.target;
  c.orbit(40, 10);
  EXPECT_EQ(c.target, before);
  c.pan(10, 0);
  EXPECT_LT((c.target - before).dot(c.right()), 0.0);
  const double d = c.distance;
  c.zoom(1);
  EXPECT_NEAR(c.distance, 0.9 * d, 1e-12);
}

// Up on screen is the scene's up, opposite its gravity: for a z-up scene a point above the
// target projects above the middle of the picture at any yaw, and a +y scene keeps the angles'
// old meaning (yaw 0, pitch 0 looks along -z).
TEST(Camera, UpOnScreenIsOppositeGravity) {
  Camera y;
  y.yaw = 0.0;
  y.pitch = 0.0;
  EXPECT_EQ(y.forward(), Vec3d(-0.0, -0.0, -1.0));
  for (const Vec3d& gravity : {Vec3d(0, 0, -9.81), Vec3d(0, -9.81, 0), Vec3d(9.81, 0, 0)}) {
    Camera c;
    c.width = 320;
    c.height = 200;
    c.upAgainst(gravity);
    EXPECT_LT((c.worldUp + gravity.normalized()).norm(), 1e-15);
    for (const double yaw : {0.0, 1.0, 2.5, -2.0}) {
      c.yaw = yaw;
      c.fit(Eigen::AlignedBox3d(Vec3d::Constant(-1), Vec3d::Constant(1)));
      EXPECT_NEAR(c.right().dot(c.worldUp), 0.0, 1e-12);
      EXPECT_GT(c.up().dot(c.worldUp), 0.5);
      double px = 0, py = 0;
      ASSERT_TRUE(c.project(c.target + 0.5 * c.worldUp, px, py));
      EXPECT_LT(py, 99.5) << "yaw " << yaw;  // above the middle: pixels count down
    }
  }
  Camera still;
  still.upAgainst(Vec3d::Zero());
  EXPECT_EQ(still.worldUp, Vec3d::UnitY());
}

/// A small bunny to drive, with a camera fitted to it.
struct Driven {
  Session session = Session::open("bunny", OpenOptions{40, true, {}});
  InputController input{drivenTools(session)};
  Driven() {
    input.camera.width = 320;
    input.camera.height = 240;
    input.camera.fit(session.startBounds());
  }
  DrawData draw() { return buildDrawData(session.world(), session.scene().obstacles, {}); }
  void send(const std::vector<ToolCommand>& c) { session.apply(c); }
  /// A left-button drag from (x0, y) to (x1, y) in `steps` moves, a frame after each.
  void drag(ToolMode mode, double x0, double x1, double y, int steps) {
    input.mode = mode;
    send(input.button(MouseButton::Left, true, x0, y, false, draw()));
    ASSERT_TRUE(input.dragging());
    (void)session.step();
    for (int k = 1; k <= steps; ++k) {
      send(input.move(x0 + (x1 - x0) * k / steps, y));
      (void)session.step();
    }
  }
  void release() {
    send(input.button(MouseButton::Left, false, 0, 0, false, draw()));
    (void)session.step();
  }
};

std::string hex(std::uint64_t h) {
  char s[32];
  std::snprintf(s, sizeof s, "%016" PRIx64, h);
  return s;
}

// The mouse, through the input layer: a drag with the blade across the bunny cuts it; a press
// with the probe pushes on it; let go, the tools go back out of the way and push nothing. The
// run, saved as a scene, replays with `voxcut run` to the same cuts.
TEST(Input, MouseDragCutsAndPressesTheBunnyAndReplays) {
  Driven d;
  World& w = d.session.world();
  const double cx = 0.5 * d.input.camera.width, cy = 0.5 * d.input.camera.height;
  // Pressing off the bodies orbits instead of putting a tool down.
  d.input.mode = ToolMode::Blade;
  EXPECT_TRUE(d.input.button(MouseButton::Left, true, 2, 2, false, d.draw()).empty());
  EXPECT_FALSE(d.input.dragging());
  (void)d.input.button(MouseButton::Left, false, 2, 2, false, d.draw());
  for (int f = 0; f < 5; ++f) (void)d.session.step();
  EXPECT_EQ(w.bodyInfo(w.bodies()[0]).cutLinks, 0u);

  d.drag(ToolMode::Blade, cx - 30, cx + 30, cy, 15);
  const std::size_t cut = w.bodyInfo(w.bodies()[0]).cutLinks;
  EXPECT_GT(cut, 0u);
  d.release();
  EXPECT_EQ(w.toolPose(d.session.blade()).a, d.session.bladePark().a);
  // Put back, the blade cuts nothing more.
  for (int f = 0; f < 3; ++f) (void)d.session.step();
  EXPECT_EQ(w.bodyInfo(w.bodies()[0]).cutLinks, cut);

  d.drag(ToolMode::Probe, cx, cx + 10, cy + 20, 8);
  const Vec3d force = w.toolReaction(d.session.probe()).force;
  EXPECT_GT(force.norm(), 0.0);
  // It pushes away from the camera, into the bunny.
  EXPECT_GT(force.dot(-d.input.camera.forward()), 0.0);
  d.release();
  EXPECT_EQ(w.toolReaction(d.session.probe()).force, Vec3d::Zero());

  // Saved and replayed by the command line.
  const fs::path scene = fs::temp_directory_path() /
                         ("voxcut-viewer-recorded-" + std::to_string(::getpid()) + ".json");
  d.session.saveRecordedScene(scene.string());
  std::string out;
  const int status =
      runCommand(std::string(VOXCUT_EXE) + " run " + scene.string() + " --json", out);
  fs::remove(scene);
  ASSERT_EQ(status, 0) << out;
  const auto start = out.find('{');
  ASSERT_NE(start, std::string::npos) << out;
  const nlohmann::json j = nlohmann::json::parse(out.substr(start));
  EXPECT_EQ(j["frames"].get<int>(), w.frame());
  EXPECT_EQ(j["cut_links"].get<std::size_t>(), w.bodyInfo(w.bodies()[0]).cutLinks);
  EXPECT_EQ(j["cut_set_hash"].get<std::string>(), hex(w.cutSetHash()));
}

// Ctrl-Z: a cut undone gives back the world from before it (its cuts and nodes as a twin
// session that was stopped there); with nothing cut since, there is nothing to undo.
TEST(Session, UndoCutGoesBackToBeforeTheCut) {
  Driven d;
  World& w = d.session.world();
  EXPECT_FALSE(d.session.canUndoCut());
  EXPECT_FALSE(d.session.undoCut());
  for (int f = 0; f < 40; ++f) (void)d.session.step();
  const std::uint64_t uncut = w.cutSetHash();
  const double cx = 0.5 * d.input.camera.width, cy = 0.5 * d.input.camera.height;
  d.drag(ToolMode::Blade, cx - 30, cx + 30, cy, 15);
  d.release();
  ASSERT_NE(w.cutSetHash(), uncut);
  ASSERT_TRUE(d.session.canUndoCut());
  const int cutAt = w.frame();
  ASSERT_TRUE(d.session.undoCut());
  EXPECT_EQ(w.cutSetHash(), uncut);
  EXPECT_EQ(w.bodyInfo(w.bodies()[0]).cutLinks, 0u);
  // At most kUndoEvery frames before the frame the cut began in.
  EXPECT_LT(w.frame(), cutAt);
  EXPECT_GE(w.frame(), 40 - Session::kUndoEvery);
  EXPECT_FALSE(d.session.canUndoCut());
  EXPECT_FALSE(d.session.undoCut());
  // The undone world is the one an uncut twin had at that frame, bit for bit.
  Driven twin;
  while (twin.session.world().frame() < w.frame()) (void)twin.session.step();
  const NodeState a = w.nodes(w.bodies()[0]);
  const NodeState b = twin.session.world().nodes(twin.session.world().bodies()[0]);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.velocities, b.velocities);
  // And it runs on: the same drag cuts again.
  d.drag(ToolMode::Blade, cx - 30, cx + 30, cy, 15);
  EXPECT_NE(w.cutSetHash(), uncut);
}

// The wheel pushes a dragged probe deeper along the line of sight, and zooms otherwise.
TEST(Input, WheelPushesTheDraggedToolAndZoomsOtherwise) {
  Driven d;
  const double distance = d.input.camera.distance;
  EXPECT_TRUE(d.input.wheel(2).empty());
  EXPECT_LT(d.input.camera.distance, distance);
  d.input.camera.fit(d.session.startBounds());
  d.input.mode = ToolMode::Probe;
  const std::vector<ToolCommand> down =
      d.input.button(MouseButton::Left, true, 160, 120, false, d.draw());
  ASSERT_EQ(down.size(), 1u);
  EXPECT_TRUE(down[0].place);
  EXPECT_EQ(down[0].tool, d.session.probe());
  const std::vector<ToolCommand> deeper = d.input.wheel(3);
  ASSERT_EQ(deeper.size(), 1u);
  EXPECT_FALSE(deeper[0].place);
  const double along = (deeper[0].pose.a - down[0].pose.a).dot(d.input.camera.forward());
  EXPECT_NEAR(along, 0.06 * d.session.bladeLength(), 1e-12);
  // Put down half its radius in front of the picked surface point.
  const std::optional<Vec3d> hit = pick(d.draw(), d.input.camera.ray(160, 120));
  ASSERT_TRUE(hit);
  const double radius = d.session.world().toolRadius(d.session.probe());
  EXPECT_NEAR((*hit - down[0].pose.a).norm(), 0.5 * radius, 1e-9 * radius);
}

// What is drawn of the pseudo voxel octree: switched off, every link is active and there are
// no cubes; switched on again, the octree's cubes and fewer links are back.
TEST(Draw, OctreeToggleChangesTheDrawnActiveLinks) {
  Session s = Session::open("bunny", OpenOptions{40, true, {}});
  DrawOptions o;
  o.activeLinks = o.octreeCubes = true;
  o.maxLinks = 10000000;
  const DrawData on = buildDrawData(s.world(), s.scene().obstacles, o);
  s.setUseOctree(false);
  const DrawData off = buildDrawData(s.world(), s.scene().obstacles, o);
  s.setUseOctree(true);
  const DrawData again = buildDrawData(s.world(), s.scene().obstacles, o);
  EXPECT_GT(on.cubeCount, 0u);
  EXPECT_EQ(off.cubeCount, 0u);
  EXPECT_GT(off.linkSegments, 2 * on.linkSegments);
  EXPECT_EQ(again.linkSegments, on.linkSegments);
  EXPECT_EQ(on.lines.size(), (on.linkSegments + 12 * on.cubeCount) * 2 * kLineStride);
  // Surfaces: three vertices a triangle, all inside the bounds.
  EXPECT_EQ(on.bodyIndices.size() % 3, 0u);
  EXPECT_GT(on.bodyIndices.size(), 3000u);
  EXPECT_EQ(on.bodyVertices.size() % (2 * kTriangleStride), 0u);
}

// The simulation's thread: it runs frames while the window's thread holds the frame it draws,
// applies tool commands between frames, and pauses, steps and resets on request.
TEST(SimRunner, RunsBesideTheDrawingThread) {
  Session s = Session::open("bunny", OpenOptions{32, true, {}});
  SimRunner runner(s);
  const std::shared_ptr<const DrawData> first = runner.latest();
  ASSERT_TRUE(first);
  EXPECT_EQ(first->figures.frame, 0);
  runner.setRealTime(false);
  runner.setPlaying(true);
  // Waits for `done` (up to a minute: sanitizer builds on a busy machine are slow).
  const auto until = [&](auto done) {
    for (int k = 0; k < 12000 && !done(); ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return done();
  };
  // Held here, the first frame does not stop the thread from running others.
  EXPECT_TRUE(until([&] { return runner.latest()->figures.frame >= 10; }));
  runner.setPlaying(false);
  EXPECT_EQ(first->figures.frame, 0);
  // Between frames (a frame in flight when it paused has been published by then).
  runner.runBetweenFrames([](Session&) {});
  const std::shared_ptr<const DrawData> now = runner.latest();
  EXPECT_EQ(now->fps.size(), static_cast<std::size_t>(now->figures.frame));
  EXPECT_EQ(now->figures.stageMs.size(), frameStageNames().size());
  // A tool put down while paused shows at once; a step runs one frame.
  const BladePose to{s.startBounds().center() + Vec3d(0, 1, 0),
                     s.startBounds().center() + Vec3d(0, 1, 0)};
  runner.send({ToolCommand{s.probe(), to, true}});
  runner.stepOnce();
  const int frame = now->figures.frame;
  EXPECT_TRUE(until([&] { return runner.latest()->figures.frame == frame + 1; }));
  runner.runBetweenFrames([&](Session& in) { EXPECT_EQ(in.world().toolPose(in.probe()).a, to.a); });
  runner.reset();
  EXPECT_TRUE(until([&] { return runner.latest()->figures.frame == 0; }));
  EXPECT_TRUE(runner.error().empty());
}

TEST(Session, OpenErrorsSayWhatIsWrong) {
  auto message = [](const std::string& what) {
    try {
      (void)Session::open(what);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(message("/nonexistent/scene.json").find("/nonexistent/scene.json"), std::string::npos);
  EXPECT_NE(message("no-such-model").find("no-such-model"), std::string::npos);
  EXPECT_EQ(message("").rfind("nothing to open", 0), 0u);
}

}  // namespace
}  // namespace voxcut::view
