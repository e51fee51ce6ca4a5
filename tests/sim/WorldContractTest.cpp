// The world API's contract (sim/World.h, "Errors"; docs/architecture.md, "The world API"):
// typed handles that do not mix; every bad argument an InputError naming it that leaves the
// world as if the call had never been made (the next frames bit for bit the same); the haptic
// call's statuses; tools removed in the middle of a run; and the nodes a body reports.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"
#include "voxcut/voxel/VoxelGrid.h"
#include "ContractWorld.h"

namespace voxcut {
namespace {

using namespace contract;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTimeStep = 0.004;

// ---- 1. handles ----

// Handles of different kinds are different types, convertible neither into each other nor
// from or into an index.
static_assert(!std::is_convertible_v<BodyId, ToolId>);
static_assert(!std::is_convertible_v<BodyId, ObstacleId>);
static_assert(!std::is_convertible_v<ToolId, BodyId>);
static_assert(!std::is_convertible_v<ToolId, ObstacleId>);
static_assert(!std::is_convertible_v<ObstacleId, BodyId>);
static_assert(!std::is_convertible_v<ObstacleId, ToolId>);
static_assert(!std::is_constructible_v<ToolId, BodyId>);
static_assert(!std::is_constructible_v<BodyId, ObstacleId>);
static_assert(!std::is_convertible_v<std::size_t, BodyId>);
static_assert(!std::is_convertible_v<int, ToolId>);
static_assert(!std::is_convertible_v<int, ObstacleId>);
static_assert(!std::is_convertible_v<BodyId, std::size_t>);
static_assert(!std::is_convertible_v<ToolId, int>);
static_assert(!BodyId{}.valid() && !ToolId{}.valid() && !ObstacleId{}.valid());
static_assert(BodyId(0, 0).valid());
static_assert(BodyId(0, 0) != BodyId(0, 1) && BodyId(0, 0) != BodyId(1, 0));

// The calls take only their own kind of handle.
template <class Id>
concept PiecesTakes = requires(const World& w, Id id) { w.pieces(id); };
template <class Id>
concept ToolPoseTakes = requires(const World& w, Id id) { w.toolPose(id); };
template <class Id>
concept ObstacleTakes = requires(const World& w, Id id) { w.obstacle(id); };
static_assert(PiecesTakes<BodyId> && !PiecesTakes<ToolId> && !PiecesTakes<ObstacleId>);
static_assert(!PiecesTakes<std::size_t> && !PiecesTakes<int>);
static_assert(ToolPoseTakes<ToolId> && !ToolPoseTakes<BodyId> && !ToolPoseTakes<ObstacleId>);
static_assert(!ToolPoseTakes<std::size_t>);
static_assert(ObstacleTakes<ObstacleId> && !ObstacleTakes<BodyId> && !ObstacleTakes<ToolId>);
static_assert(!ObstacleTakes<std::size_t>);
static_assert(noexcept(std::declval<const World&>().hapticForce(std::declval<ToolId>(),
                                                                std::declval<const BladePose&>())));

// Expects `call` to throw an InputError whose message holds every one of `words`.
void expectInputError(const std::function<void()>& call, const std::vector<std::string>& words,
                      const std::string& what) {
  try {
    call();
    ADD_FAILURE() << what << ": no InputError";
  } catch (const InputError& e) {
    const std::string message = e.what();
    for (const std::string& word : words)
      EXPECT_NE(message.find(word), std::string::npos)
          << what << ": the message does not name '" << word << "': " << message;
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": not an InputError: " << e.what();
  }
}

// A refused call: what it does, and the words its message must hold.
struct BadCall {
  std::string what;
  std::function<void(World&, const Handles&)> call;
  std::vector<std::string> words;
};

BladePose withA(double x) { return segment(Vec3d(x, 0.05, 0), Vec3d(0, 0.05, 0)); }
BladePose withB(double z) { return segment(Vec3d(0, 0.05, 0), Vec3d(0, 0.05, z)); }

SceneMaterial defaultMaterial() {
  SceneMaterial m;
  m.name = "default";
  m.youngModulus = 1e5;
  m.poissonRatio = 0.3;
  m.density = 1000;
  m.massDamping = 2;
  m.stiffnessDamping = 0.01;
  return m;
}

// ---- 2. bad arguments ----

std::vector<BadCall> badPoses() {
  std::vector<BadCall> calls;
  const std::vector<std::pair<std::string, BladePose>> poses = {
      {"NaN a", withA(kNaN)},
      {"NaN b", withB(kNaN)},
      {"infinite a", withA(kInf)},
      {"-infinite b", withB(-kInf)},
      {"out of range a", withA(1e7)}};
  for (const auto& [name, pose] : poses) {
    calls.push_back({"setToolPose(blade, " + name + ")",
                     [pose](World& w, const Handles& h) { w.setToolPose(h.blade, pose); },
                     {"pose"}});
    calls.push_back({"setToolPose(probe, " + name + ")",
                     [pose](World& w, const Handles& h) { w.setToolPose(h.probe, pose); },
                     {"pose"}});
    calls.push_back({"placeTool(blade, " + name + ")",
                     [pose](World& w, const Handles& h) { w.placeTool(h.blade, pose); },
                     {"pose"}});
    calls.push_back({"placeTool(probe, " + name + ")",
                     [pose](World& w, const Handles& h) { w.placeTool(h.probe, pose); },
                     {"pose"}});
    calls.push_back({"addBlade(" + name + ")",
                     [pose](World& w, const Handles&) { (void)w.addBlade(pose); },
                     {"pose"}});
    calls.push_back({"addProbe(" + name + ")",
                     [pose](World& w, const Handles&) { (void)w.addProbe(0.01, pose); },
                     {"pose"}});
    calls.push_back({"setToolTrajectory(probe, " + name + ")",
                     [pose](World& w, const Handles& h) {
                       std::vector<ToolKey> keys = probeKeys();
                       keys.push_back({1.0, pose});
                       w.setToolTrajectory(h.probe, keys);
                     },
                     {"keys[2].pose"}});
  }
  return calls;
}

std::vector<BadCall> badValues() {
  const BladePose fine = sphereAt(Vec3d(0.03, 0.2, 0));
  std::vector<BadCall> calls = {
      {"addProbe(radius -0.01)",
       [fine](World& w, const Handles&) { (void)w.addProbe(-0.01, fine); },
       {"radius"}},
      {"addProbe(radius 0)", [fine](World& w, const Handles&) { (void)w.addProbe(0.0, fine); },
       {"radius"}},
      {"addProbe(radius NaN)",
       [fine](World& w, const Handles&) { (void)w.addProbe(kNaN, fine); },
       {"radius"}},
      {"addProbe(radius inf)",
       [fine](World& w, const Handles&) { (void)w.addProbe(kInf, fine); },
       {"radius"}},
      {"addProbe(friction NaN)",
       [fine](World& w, const Handles&) { (void)w.addProbe(0.01, fine, kNaN); },
       {"friction"}},
      {"setToolTrajectory(no keys)",
       [](World& w, const Handles& h) { w.setToolTrajectory(h.blade, {}); },
       {"keys"}},
      {"setToolTrajectory(keys out of order)",
       [](World& w, const Handles& h) {
         std::vector<ToolKey> keys = bladeKeys();
         std::swap(keys[0].t, keys[1].t);
         w.setToolTrajectory(h.blade, keys);
       },
       {"keys"}},
      {"setToolTrajectory(NaN time)",
       [](World& w, const Handles& h) {
         std::vector<ToolKey> keys = bladeKeys();
         keys[1].t = kNaN;
         w.setToolTrajectory(h.blade, keys);
       },
       {"keys[1].t"}},
      {"setMaterial(NaN Young's modulus)",
       [](World& w, const Handles& h) {
         SceneMaterial m = defaultMaterial();
         m.youngModulus = kNaN;
         w.setMaterial(h.body, m);
       },
       {"material", "youngModulus"}},
      {"setMaterial(Poisson ratio 0.5)",
       [](World& w, const Handles& h) {
         SceneMaterial m = defaultMaterial();
         m.poissonRatio = 0.5;
         w.setMaterial(h.body, m);
       },
       {"material", "poissonRatio"}},
      {"setMaterial(negative density)",
       [](World& w, const Handles& h) {
         SceneMaterial m = defaultMaterial();
         m.density = -1000;
         w.setMaterial(h.body, m);
       },
       {"material", "density"}},
      {"setMaterial(negative damping)",
       [](World& w, const Handles& h) {
         SceneMaterial m = defaultMaterial();
         m.massDamping = -1;
         w.setMaterial(h.body, m);
       },
       {"material", "massDamping"}},
      {"setMaterial(unknown name)",
       [](World& w, const Handles& h) {
         SceneMaterial m = defaultMaterial();
         m.name = "steel";
         w.setMaterial(h.body, m);
       },
       {"material", "steel"}},
      {"setFixed(inverted box)",
       [](World& w, const Handles& h) {
         w.setFixed(h.body, {FixedBox{Vec3d(-1, -1, -1), Vec3d(1, 0.002, 1)},
                             FixedBox{Vec3d(1, 1, 1), Vec3d(-1, -1, -1)}});
       },
       {"fixed[1]"}},
      {"setFixed(NaN box)",
       [](World& w, const Handles& h) {
         w.setFixed(h.body, {FixedBox{Vec3d(kNaN, -1, -1), Vec3d(1, 0.002, 1)}});
       },
       {"fixed[0]"}},
      {"addObstacle(NaN plane normal)",
       [](World& w, const Handles&) {
         Obstacle o;
         o.normal = Vec3d(kNaN, 1, 0);
         (void)w.addObstacle(o);
       },
       {"obstacle", "normal"}},
      {"addObstacle(inverted box)",
       [](World& w, const Handles&) {
         Obstacle o;
         o.type = ObstacleType::Box;
         o.lo = Vec3d(1, 1, 1);
         o.hi = Vec3d(0, 2, 2);
         (void)w.addObstacle(o);
       },
       {"obstacle"}},
      {"addObstacle(mesh without a mesh)",
       [](World& w, const Handles&) {
         Obstacle o;
         o.type = ObstacleType::Mesh;
         (void)w.addObstacle(o);
       },
       {"obstacle", "mesh"}},
      {"World(time step 0) beside it", [](World&, const Handles&) {
         WorldSettings s;
         s.timeStep = 0.0;
         World other(s);
       },
       {"timeStep"}},
  };
  return calls;
}

// Stale handles (of the removed spares), handles of a generation the world never made, of a
// slot it never had, and default ones, to every call that takes a handle.
std::vector<BadCall> badHandles(const Handles& live) {
  struct Named {
    std::string name;
    BodyId body;
    ToolId tool;
    ObstacleId obstacle;
    std::string word;  ///< "stale" or "invalid"
  };
  const std::vector<Named> handles = {
      {"removed", live.spareBody, live.spareTool, live.spareObstacle, "stale"},
      {"next generation", BodyId(live.body.slot(), live.body.generation() + 1),
       ToolId(live.blade.slot(), live.blade.generation() + 1),
       ObstacleId(live.floor.slot(), live.floor.generation() + 1), "stale"},
      {"unknown slot", BodyId(1000, 0), ToolId(1000, 0), ObstacleId(1000, 0), "stale"},
      {"default", BodyId{}, ToolId{}, ObstacleId{}, "invalid"}};
  std::vector<BadCall> calls;
  for (const Named& n : handles) {
    const BodyId b = n.body;
    const ToolId t = n.tool;
    const ObstacleId o = n.obstacle;
    const std::vector<std::string> body{"body", n.word}, tool{"tool", n.word},
        obstacle{"obstacle", n.word};
    auto add = [&](const std::string& call, std::function<void(World&, const Handles&)> f,
                   const std::vector<std::string>& words) {
      calls.push_back({call + " with a " + n.name + " handle", std::move(f), words});
    };
    // Bodies.
    add("removeBody", [b](World& w, const Handles&) { w.removeBody(b); }, body);
    add("setFixed", [b](World& w, const Handles&) { w.setFixed(b, {}); }, body);
    add("setMaterial", [b](World& w, const Handles&) { w.setMaterial(b, defaultMaterial()); },
        body);
    add("bodyInfo", [b](World& w, const Handles&) { (void)w.bodyInfo(b); }, body);
    add("activity", [b](World& w, const Handles&) { (void)w.activity(b); }, body);
    add("pieces", [b](World& w, const Handles&) { (void)w.pieces(b); }, body);
    add("surface", [b](World& w, const Handles&) { (void)w.surface(b); }, body);
    add("surfaceChanges", [b](World& w, const Handles&) { (void)w.surfaceChanges(b, 0); },
        body);
    add("surfaceMesh", [b](World& w, const Handles&) { (void)w.surfaceMesh(b); }, body);
    add("nodes", [b](World& w, const Handles&) { (void)w.nodes(b); }, body);
    add("energy", [b](World& w, const Handles&) { (void)w.energy(b); }, body);
    // Tools.
    const BladePose pose = sphereAt(Vec3d(0.03, 0.2, 0));
    add("removeTool", [t](World& w, const Handles&) { w.removeTool(t); }, tool);
    add("toolKind", [t](World& w, const Handles&) { (void)w.toolKind(t); }, tool);
    add("toolRadius", [t](World& w, const Handles&) { (void)w.toolRadius(t); }, tool);
    add("toolPose", [t](World& w, const Handles&) { (void)w.toolPose(t); }, tool);
    add("setToolPose", [t, pose](World& w, const Handles&) { w.setToolPose(t, pose); }, tool);
    add("placeTool", [t, pose](World& w, const Handles&) { w.placeTool(t, pose); }, tool);
    add("setToolTrajectory",
        [t](World& w, const Handles&) { w.setToolTrajectory(t, probeKeys()); }, tool);
    add("toolReaction", [t](World& w, const Handles&) { (void)w.toolReaction(t); }, tool);
    add("recording", [t](World& w, const Handles&) { (void)w.recording(t); }, tool);
    // Obstacles.
    add("removeObstacle", [o](World& w, const Handles&) { w.removeObstacle(o); }, obstacle);
    add("obstacle", [o](World& w, const Handles&) { (void)w.obstacle(o); }, obstacle);
  }
  return calls;
}

TEST(WorldContract, BadWorldSettingsAreRefusedNamingTheSetting) {
  auto refused = [](const std::function<void(WorldSettings&)>& edit,
                    const std::vector<std::string>& words, const std::string& what) {
    WorldSettings s;
    edit(s);
    expectInputError([&] { World w(s); }, words, what);
  };
  refused([](WorldSettings& s) { s.timeStep = 0.0; }, {"timeStep"}, "time step 0");
  refused([](WorldSettings& s) { s.timeStep = -0.004; }, {"timeStep"}, "time step < 0");
  refused([](WorldSettings& s) { s.timeStep = kNaN; }, {"timeStep"}, "time step NaN");
  refused([](WorldSettings& s) { s.timeStep = 2e3; }, {"timeStep"}, "time step 2e3");
  refused([](WorldSettings& s) { s.gravity.y() = kNaN; }, {"gravity"}, "gravity NaN");
  refused([](WorldSettings& s) { s.gravity.x() = kInf; }, {"gravity"}, "gravity inf");
  refused([](WorldSettings& s) { s.solver.tolerance = 0.0; }, {"tolerance"}, "tolerance 0");
  refused([](WorldSettings& s) { s.solver.tolerance = 2.0; }, {"tolerance"}, "tolerance 2");
  refused([](WorldSettings& s) { s.solver.maxIterations = 0; }, {"maxIterations"},
          "no iterations");
  refused([](WorldSettings& s) { s.solver.projectionHistory = 65; }, {"projectionHistory"},
          "projection history 65");
  refused([](WorldSettings& s) { s.contact.friction = -0.1; }, {"friction"}, "friction < 0");
  refused([](WorldSettings& s) { s.contact.stiffness = kNaN; }, {"stiffness"}, "stiffness NaN");
  refused([](WorldSettings& s) { s.bladeSegments = -1; }, {"bladeSegments"},
          "blade segments < 0");
  // The edges of the ranges are accepted.
  WorldSettings edge;
  edge.timeStep = 1e3;
  edge.solver.tolerance = 1.0;
  EXPECT_NO_THROW(World w(edge));
}

TEST(WorldContract, BadBodySettingsAreRefusedAndAddNothing) {
  Handles h;
  World w = contractWorld(h);
  const Scene scene = sceneOf(kScene);
  const std::vector<VoxelGrid> grids = voxelizeSceneBodies(scene);
  auto refused = [&](const std::function<void(BodySettings&)>& edit,
                     const std::vector<std::string>& words, const std::string& what) {
    BodySettings s;
    edit(s);
    expectInputError([&] { (void)w.addBody(grids[1], s); }, words, what);
    EXPECT_EQ(w.bodies(), std::vector<BodyId>{h.body}) << what;
  };
  refused([](BodySettings& s) { s.elementLevel = 7; }, {"elementLevel"}, "element level 7");
  refused([](BodySettings& s) { s.elementLevel = -1; }, {"elementLevel"}, "element level -1");
  refused([](BodySettings& s) { s.finestLevel = 4; }, {"finestLevel"}, "finest level > element");
  refused([](BodySettings& s) { s.materials = {SceneMaterial{}}; s.materials[0].density = 0; },
          {"materials[0]", "density"}, "density 0");
  refused([](BodySettings& s) { s.fixed = {FixedBox{Vec3d(1, 0, 0), Vec3d(0, 1, 1)}}; },
          {"fixed[0]"}, "inverted fixed box");
  // The world goes on as one that never saw them.
  Handles ho;
  World other = contractWorld(ho);
  for (int f = 0; f < 5; ++f)
    expectSameReport(w.step(), other.step(), "frame " + std::to_string(f));
  expectSameWorld(w, other, "after 5 frames");
}

// Every bad call throws an InputError naming its argument and changes nothing: a world that
// gets one bad call (or a few) before each frame runs every frame bit for bit as one that
// never saw them, its blade cutting and its probe pressing all along.
TEST(WorldContract, BadArgumentsThrowAndLeaveTheWorldAsItWas) {
  Handles h, ho;
  World w = contractWorld(h);
  World other = contractWorld(ho);
  // Handles are the world's own: the twin's name nothing here.
  EXPECT_FALSE(w.contains(ho.body) || w.contains(ho.blade) || w.contains(ho.probe));
  std::vector<BadCall> calls = badPoses();
  for (BadCall& c : badValues()) calls.push_back(std::move(c));
  for (BadCall& c : badHandles(h)) calls.push_back(std::move(c));
  ASSERT_GT(calls.size(), 100u);
  // A few calls before each of 30 frames; then 10 more frames.
  constexpr int kFrames = 40, kFramesWithCalls = 30;
  const std::size_t perFrame = (calls.size() + kFramesWithCalls - 1) / kFramesWithCalls;
  std::size_t next = 0;
  for (int f = 0; f < kFrames; ++f) {
    std::string made;
    for (std::size_t k = 0; k < perFrame && next < calls.size(); ++k, ++next) {
      const BadCall& c = calls[next];
      expectInputError([&] { c.call(w, h); }, c.words, c.what);
      made += (made.empty() ? "" : ", ") + c.what;
      // Nothing added, nothing removed.
      ASSERT_EQ(w.bodies(), (std::vector<BodyId>{h.body})) << c.what;
      ASSERT_EQ(w.tools(), (std::vector<ToolId>{h.blade, h.probe})) << c.what;
      ASSERT_EQ(w.obstacles(), (std::vector<ObstacleId>{h.floor})) << c.what;
    }
    const std::string when = "frame " + std::to_string(f) + (made.empty() ? "" : " after " + made);
    expectSameReport(w.step(), other.step(), when);
    expectSameWorld(w, other, when);
    if (testing::Test::HasFailure()) break;  // one frame's differences say enough
  }
  EXPECT_EQ(next, calls.size());
  // The world did something worth keeping the same: the blade cut, the probe pressed.
  EXPECT_GT(w.bodyInfo(h.body).cutLinks, 50u);
  EXPECT_GT(w.toolReaction(h.probe).force.y(), 0.0);
  EXPECT_FALSE(w.contains(h.spareBody));
  EXPECT_FALSE(w.contains(h.spareTool));
  EXPECT_FALSE(w.contains(h.spareObstacle));
  EXPECT_TRUE(w.contains(h.body) && w.contains(h.blade) && w.contains(h.probe) &&
              w.contains(h.floor));
}

// ---- 3. the haptic call ----

TEST(WorldContract, HapticForceAnswersWhyItGivesNothing) {
  Handles h;
  World w = contractWorld(h, false);
  for (int f = 0; f < 30; ++f) (void)w.step();
  ASSERT_GT(w.toolReaction(h.probe).force.y(), 0.0);
  const BladePose at = w.toolPose(h.probe);
  const HapticAnswer ok = w.hapticForce(h.probe, at);
  EXPECT_EQ(ok.status, HapticAnswer::Status::Ok);
  EXPECT_GT(ok.reaction.force.y(), 0.0);
  auto expectNothing = [](const HapticAnswer& a, HapticAnswer::Status status,
                          const std::string& what) {
    EXPECT_EQ(a.status, status) << what;
    EXPECT_EQ(a.reaction.force, Vec3d::Zero()) << what;
    EXPECT_EQ(a.reaction.torque, Vec3d::Zero()) << what;
    EXPECT_TRUE(a.reaction.force.allFinite()) << what;
  };
  using Status = HapticAnswer::Status;
  const Vec3d c = at.a;
  expectNothing(w.hapticForce(h.probe, {Vec3d(kNaN, c.y(), c.z()), c}), Status::NonFinitePose,
                "NaN a");
  expectNothing(w.hapticForce(h.probe, {c, Vec3d(c.x(), kNaN, c.z())}), Status::NonFinitePose,
                "NaN b");
  expectNothing(w.hapticForce(h.probe, {Vec3d(kInf, 0, 0), c}), Status::NonFinitePose,
                "infinite a");
  expectNothing(w.hapticForce(h.probe, {c, Vec3d(0, 0, 1e7)}), Status::NonFinitePose,
                "out of range b");
  expectNothing(w.hapticForce(h.blade, at), Status::NotAProbe, "a blade");
  expectNothing(w.hapticForce(h.spareTool, at), Status::NotAProbe, "the spare blade");
  expectNothing(w.hapticForce(ToolId{}, at), Status::NotAProbe, "a default handle");
  expectNothing(w.hapticForce(ToolId(h.probe.slot(), h.probe.generation() + 1), at),
                Status::NotAProbe, "the probe's slot, another generation");
  expectNothing(w.hapticForce(ToolId(1000, 0), at), Status::NotAProbe, "an unknown slot");
  // The probe's answer did not change from asking with bad arguments.
  EXPECT_EQ(w.hapticForce(h.probe, at).status, Status::Ok);
  // Removed, the probe is no probe any more, even pressing where it pressed.
  w.removeTool(h.probe);
  expectNothing(w.hapticForce(h.probe, at), Status::NotAProbe, "the removed probe");
  // A probe added after it, perhaps in its slot, answers for itself only.
  const ToolId again = w.addProbe(0.01, at, 0.0);
  EXPECT_NE(again, h.probe);
  expectNothing(w.hapticForce(h.probe, at), Status::NotAProbe, "the removed probe again");
  EXPECT_EQ(w.hapticForce(again, at).status, Status::Ok);
}

// ---- 4. removing tools while running ----

void expectReactionsInToolOrder(const World& w, const FrameReport& r, const std::string& when) {
  const std::vector<ToolId> tools = w.tools();
  ASSERT_EQ(r.toolReactions.size(), tools.size()) << when;
  ASSERT_EQ(tools.size(), w.toolCount()) << when;
  for (std::size_t i = 0; i < tools.size(); ++i) {
    EXPECT_TRUE(sameBits(r.toolReactions[i].force, w.toolReaction(tools[i]).force))
        << when << ", tool " << i;
    EXPECT_TRUE(sameBits(r.toolReactions[i].torque, w.toolReaction(tools[i]).torque))
        << when << ", tool " << i;
  }
  ASSERT_EQ(r.obstacleForces.size(), w.obstacles().size()) << when;
}

// A tool that touches nothing, removed from between two tools at work (a probe pressing and a
// blade half way through its cut): the world runs on exactly as one that never had it, so the
// remaining tools kept their own fronts, models and reactions.
TEST(WorldContract, RemovingAToolBetweenOthersChangesNothingForThem) {
  Handles h, hl;
  World lean = contractWorld(hl, false);
  lean.removeTool(hl.spareTool);  // blade, probe from the start
  World w = contractWorld(h, false);  // blade, spare blade (far away), probe
  ASSERT_EQ(w.tools().size(), 3u);
  ASSERT_EQ(w.tools()[1], h.spareTool);
  for (int f = 0; f < 40; ++f) {
    if (f == 12) {
      ASSERT_GT(w.bodyInfo(h.body).cutLinks, 0u);  // the blade is in its cut
      w.removeTool(h.spareTool);
      EXPECT_EQ(w.tools(), (std::vector<ToolId>{h.blade, h.probe}));
      EXPECT_TRUE(w.contains(h.blade) && w.contains(h.probe));
      EXPECT_FALSE(w.contains(h.spareTool));
    }
    const FrameReport a = w.step(), b = lean.step();
    const std::string when = "frame " + std::to_string(f);
    expectReactionsInToolOrder(w, a, when);
    if (f >= 12) {
      expectSameReport(a, b, when);
      expectSameWorld(w, lean, when);
    } else {
      EXPECT_EQ(a.cutLinks, b.cutLinks) << when;
    }
    if (testing::Test::HasFailure()) break;
  }
  EXPECT_GT(w.bodyInfo(h.body).cutLinks, 50u);
}

// The probe removed while it presses and the blade still cuts: the blade goes on cutting, no
// contact names the probe any more, the reactions follow tools(); a tool added afterwards gets
// a new handle (in the freed slot, under a new generation), and the old one stays refused.
TEST(WorldContract, RemovingAProbeWhileItPresses) {
  Handles h;
  World w = contractWorld(h);  // blade, probe
  FrameReport r;
  for (int f = 0; f < 12; ++f) {
    r = w.step();
    expectReactionsInToolOrder(w, r, "before");
  }
  ASSERT_GT(w.toolReaction(h.probe).force.y(), 0.0);
  const std::size_t cutBefore = w.bodyInfo(h.body).cutLinks;
  ASSERT_GT(cutBefore, 0u);
  bool probeContacts = false;
  for (const Contact& c : w.contacts())
    if (c.with == Contact::With::Probe) {
      probeContacts = true;
      EXPECT_EQ(c.tool, h.probe);
      EXPECT_EQ(c.body, h.body);
    }
  EXPECT_TRUE(probeContacts);

  w.removeTool(h.probe);
  EXPECT_EQ(w.tools(), std::vector<ToolId>{h.blade});
  EXPECT_EQ(w.toolCount(), 1u);
  EXPECT_FALSE(w.contains(h.probe));
  EXPECT_THROW((void)w.toolReaction(h.probe), InputError);
  for (int f = 0; f < 8; ++f) {
    r = w.step();
    expectReactionsInToolOrder(w, r, "after removing the probe");
    for (const Contact& c : w.contacts()) EXPECT_NE(c.with, Contact::With::Probe);
  }
  const std::size_t cutAfter = w.bodyInfo(h.body).cutLinks;
  EXPECT_GT(cutAfter, cutBefore) << "the blade stopped cutting";
  EXPECT_EQ(w.toolKind(h.blade), ToolKind::Blade);

  // A new probe where the old one was: a different handle; the old one still refused.
  const BladePose at = sphereAt(Vec3d(0.03, 0.065, 0));
  const ToolId again = w.addProbe(0.01, at, 0.0);
  EXPECT_NE(again, h.probe);
  if (again.slot() == h.probe.slot()) {
    EXPECT_NE(again.generation(), h.probe.generation());
  }
  EXPECT_FALSE(w.contains(h.probe));
  EXPECT_TRUE(w.contains(again));
  EXPECT_EQ(w.tools(), (std::vector<ToolId>{h.blade, again}));
  expectInputError([&] { (void)w.toolPose(h.probe); }, {"tool", "stale"}, "old probe's pose");
  expectInputError([&] { w.setToolPose(h.probe, at); }, {"tool", "stale"}, "old probe moved");
  expectInputError([&] { w.removeTool(h.probe); }, {"tool", "stale"}, "old probe removed");
  EXPECT_EQ(w.toolRadius(again), 0.01);
  for (int f = 0; f < 15; ++f) {
    r = w.step();
    expectReactionsInToolOrder(w, r, "with the new probe");
  }
  EXPECT_GT(w.toolReaction(again).force.y(), 0.0) << "the new probe does not press";
  EXPECT_EQ(r.toolReactions.back().force, w.toolReaction(again).force);
  EXPECT_EQ(r.toolReactions.front().force, Vec3d::Zero());  // a blade's
  EXPECT_GT(w.bodyInfo(h.body).cutLinks, cutAfter);

  // Removing and adding again several times: each handle new, every old one refused.
  std::vector<ToolId> seen{h.probe, again};
  ToolId last = again;
  for (int k = 0; k < 4; ++k) {
    w.removeTool(last);
    last = w.addBlade(segment(Vec3d(2, 2, 2), Vec3d(2.1, 2, 2)));
    for (const ToolId old : seen) {
      EXPECT_NE(last, old);
      EXPECT_FALSE(w.contains(old));
      EXPECT_THROW((void)w.toolKind(old), InputError);
    }
    seen.push_back(last);
    EXPECT_EQ(w.tools(), (std::vector<ToolId>{h.blade, last}));
    expectReactionsInToolOrder(w, w.step(), "after swap " + std::to_string(k));
  }
}

// Obstacles and bodies removed the same way: the others keep their handles and their order.
TEST(WorldContract, RemovingBodiesAndObstaclesKeepsTheOthersHandles) {
  Handles h;
  World w = contractWorld(h, false);
  for (int f = 0; f < 3; ++f) (void)w.step();
  const NodeState before = w.nodes(h.body);
  w.removeBody(h.spareBody);
  w.removeObstacle(h.floor);  // the first: the spare obstacle moves up to first place
  EXPECT_EQ(w.bodies(), std::vector<BodyId>{h.body});
  EXPECT_EQ(w.obstacles(), std::vector<ObstacleId>{h.spareObstacle});
  EXPECT_TRUE(sameBits(w.nodes(h.body).positions, before.positions));
  EXPECT_EQ(w.obstacle(h.spareObstacle).type, ObstacleType::Box);
  const FrameReport r = w.step();
  EXPECT_EQ(r.obstacleForces.size(), 1u);
  Obstacle floor;
  const ObstacleId again = w.addObstacle(floor);
  EXPECT_NE(again, h.floor);
  EXPECT_FALSE(w.contains(h.floor));
  EXPECT_EQ(w.obstacles(), (std::vector<ObstacleId>{h.spareObstacle, again}));
  EXPECT_EQ(w.step().obstacleForces.size(), 2u);
  const Scene scene = sceneOf(kScene);
  const BodyId cube = w.addBody(voxelizeSceneBodies(scene)[1]);
  EXPECT_NE(cube, h.spareBody);
  EXPECT_FALSE(w.contains(h.spareBody));
  EXPECT_EQ(w.bodies(), (std::vector<BodyId>{h.body, cube}));
  EXPECT_THROW((void)w.nodes(h.spareBody), InputError);
  EXPECT_EQ(w.nodes(cube).positions.size(), w.bodyInfo(cube).nodes);
  (void)w.step();
}

// ---- 5. nodes ----

// A free box (no obstacle, no fixed box, no damping) falling under g: its nodes' masses add up
// to its material's mass, they start at rest, and after k frames they all move at g k dt (a
// free fall is a pure translation, exact for backward Euler: nothing strains).
TEST(WorldContract, NodesOfAFallingBody) {
  const double g = -9.81;
  const Scene scene = sceneOf(R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
      "solver": {"tolerance": 1e-8, "max_iterations": 1000},
      "bodies": [{"model": "box:0.1,0.06,0.08", "resolution": 16, "element_level": 1,
        "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3, "density": 1200,
                                  "damping": [0, 0]}}}]})");
  std::vector<VoxelGrid> grids = voxelizeSceneBodies(scene);
  std::size_t voxels = 0;
  for (std::size_t v = 0; v < grids[0].voxelCount(); ++v) voxels += grids[0].occupied(v);
  const double material = static_cast<double>(voxels) * std::pow(grids[0].voxelSize(), 3) * 1200;
  World w = World::fromScene(scene, std::move(grids));
  const BodyId body = w.bodies().front();
  ASSERT_GT(voxels, 1000u);

  const NodeState start = w.nodes(body);
  const std::size_t n = w.bodyInfo(body).nodes;
  ASSERT_GT(n, 8u);
  EXPECT_EQ(start.positions.size(), n);
  EXPECT_EQ(start.velocities.size(), n);
  EXPECT_EQ(start.masses.size(), n);
  double total = 0.0;
  for (const double m : start.masses) {
    EXPECT_GE(m, 0.0);
    total += m;
  }
  EXPECT_NEAR(total, material, 1e-9 * material);
  for (const Vec3d& v : start.velocities) EXPECT_EQ(v, Vec3d::Zero());
  for (const Vec3d& p : start.positions) EXPECT_TRUE(p.allFinite());

  for (int k = 1; k <= 20; ++k) {
    (void)w.step();
    const NodeState s = w.nodes(body);
    ASSERT_EQ(s.positions.size(), w.bodyInfo(body).nodes);
    ASSERT_EQ(s.velocities.size(), s.positions.size());
    ASSERT_EQ(s.masses.size(), s.positions.size());
    const double expected = g * k * kTimeStep;
    Vec3d momentum = Vec3d::Zero(), drop = Vec3d::Zero();
    double mass = 0.0;
    for (std::size_t i = 0; i < s.masses.size(); ++i) {
      momentum += s.masses[i] * s.velocities[i];
      drop += s.masses[i] * (s.positions[i] - start.positions[i]);
      mass += s.masses[i];
      // Every node: no strain, no spin.
      EXPECT_NEAR(s.velocities[i].y(), expected, 1e-6 * std::abs(expected)) << "node " << i;
      EXPECT_NEAR(s.velocities[i].x(), 0.0, 1e-9) << "node " << i;
      EXPECT_NEAR(s.velocities[i].z(), 0.0, 1e-9) << "node " << i;
    }
    EXPECT_NEAR(mass, material, 1e-9 * material);
    const Vec3d mean = momentum / mass;
    EXPECT_NEAR(mean.y(), expected, 1e-9 * std::abs(expected)) << "frame " << k;
    EXPECT_NEAR(mean.x(), 0.0, 1e-12);
    EXPECT_NEAR(mean.z(), 0.0, 1e-12);
    // Backward Euler's drop after k steps: g dt^2 k (k + 1) / 2.
    const double fallen = g * kTimeStep * kTimeStep * k * (k + 1) / 2.0;
    EXPECT_NEAR(drop.y() / mass, fallen, 1e-9 * std::abs(fallen)) << "frame " << k;
  }
}

}  // namespace
}  // namespace voxcut
