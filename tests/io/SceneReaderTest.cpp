#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "CubeFiles.h"
#include "SceneText.h"
#include "TempDir.h"
#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/Error.h"
#include "voxcut/cutting/CutStep.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/Scene.h"
#include "voxcut/voxel/Pieces.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

namespace fs = std::filesystem;
using test::expectError;
using test::parse;
using test::parseError;
using test::TempDir;
using test::withBody;
using test::withTop;

std::string shippedScene(const std::string& name) {
  return std::string(VOXCUT_SOURCE_DIR) + "/scenes/" + name;
}

// ---- shipped scenes -------------------------------------------------------------------------

TEST(SceneReader, ShippedScenesParseAndMatchTheirModels) {
  for (const char* name :
       {"bunny-ear.json", "liver-tumor.json", "starfish-arm.json", "cantilever.json"}) {
    SCOPED_TRACE(name);
    const Scene scene = readScene(shippedScene(name));
    ASSERT_EQ(scene.bodies.size(), 1u);
    const SceneBody& body = scene.bodies[0];
    EXPECT_FALSE(body.fixed.empty());
    EXPECT_TRUE(scene.frames.has_value());
    EXPECT_FALSE(body.materials.empty());
    const Model model = loadBodyModel(scene, 0);  // also checks the material names
    EXPECT_FALSE(model.materials.empty());
    for (const SceneTool& tool : scene.tools) {
      ASSERT_GE(tool.keys.size(), 2u);
      // The blade moves for about `frames` frames at most and stops inside the run.
      EXPECT_LE(tool.keys.back().t, *scene.frames * scene.timeStep + 1e-12);
    }
  }
  EXPECT_EQ(readScene(shippedScene("cantilever.json")).tools.size(), 0u);
  for (const char* name : {"bunny-ear.json", "liver-tumor.json", "starfish-arm.json"})
    EXPECT_EQ(readScene(shippedScene(name)).tools.size(), 1u) << name;
  const Scene liver = readScene(shippedScene("liver-tumor.json"));
  ASSERT_EQ(liver.bodies[0].materials.size(), 2u);
  EXPECT_EQ(liver.bodies[0].materials[0].name, "liver");
  EXPECT_EQ(liver.bodies[0].materials[1].name, "tumor");
  EXPECT_GT(liver.bodies[0].materials[1].youngModulus, liver.bodies[0].materials[0].youngModulus);
}

/// Voxelizes body 0 of a shipped scene, drives its blade through it frame by frame at rest (no
/// deformation) and returns the pieces afterwards, with the voxel counts of the pieces that
/// hold a node of a fixed box. What the scene promises: exactly one piece comes off, and it is
/// not held by a fixed node.
struct RestCut {
  int piecesBefore = 0, piecesAfter = 0;
  std::vector<bool> pieceFixed;
};

RestCut cutAtRest(const Scene& scene) {
  const SceneBody& body = scene.bodies.at(0);
  const Model model = loadBodyModel(scene, 0);
  VoxelizeParams vp;
  vp.resolution.resolution = body.resolution.value_or(model.defaultResolution);
  CutBodyParams cp;
  cp.deformation.startLevel = body.elementLevel;
  cp.deformation.maxLevel = body.elementLevel;
  CutBody cut = makeCutBody(voxelize(model.materials, vp), cp);
  RestCut out;
  out.piecesBefore = findPieces(cut.grid).count;
  std::uint64_t frame = 0;
  for (const SceneTool& tool : scene.tools) {
    const double t0 = tool.keys.front().t;
    const int frames = static_cast<int>(std::lround((tool.keys.back().t - t0) / scene.timeStep));
    for (int f = 0; f < frames; ++f) {
      const BladePose from = bladePoseAt(tool, t0 + f * scene.timeStep);
      const BladePose to = bladePoseAt(tool, t0 + (f + 1) * scene.timeStep);
      (void)cutStep(cut, makeSweep(from, to, frame++));
    }
  }
  const PieceLabels pieces = findPieces(cut.grid);
  out.piecesAfter = pieces.count;
  // A piece is held when an element owning one of its voxels has a fixed node (a corner
  // inside a fixed box).
  out.pieceFixed.assign(static_cast<std::size_t>(pieces.count), false);
  const DeformationOctree& octree = cut.deformation;
  for (std::size_t v = 0; v < cut.grid.voxelCount(); ++v) {
    if (pieces.label[v] < 0) continue;
    const OctreeElement& e = octree.element(octree.owner(v));
    for (std::uint32_t n : e.nodes) {
      const Vec3d& x = octree.restPositions()[n];
      for (const FixedBox& box : body.fixed)
        if ((x.array() >= box.lo.array()).all() && (x.array() <= box.hi.array()).all())
          out.pieceFixed[static_cast<std::size_t>(pieces.label[v])] = true;
    }
  }
  return out;
}

void expectOnePieceComesOff(const char* name) {
  const RestCut cut = cutAtRest(readScene(shippedScene(name)));
  EXPECT_EQ(cut.piecesBefore, 1);
  ASSERT_EQ(cut.piecesAfter, 2);
  EXPECT_TRUE(cut.pieceFixed[0] != cut.pieceFixed[1]) << "exactly one piece must be held";
}

TEST(SceneReader, BunnyEarComesOffAtRest) {
  expectOnePieceComesOff("bunny-ear.json");
}
TEST(SceneReader, LiverTumorPartComesOffAtRest) {
  expectOnePieceComesOff("liver-tumor.json");
}
TEST(SceneReader, StarfishArmComesOffAtRest) {
  expectOnePieceComesOff("starfish-arm.json");
}

TEST(SceneReader, CantileverHasFourElementsThroughTheThickness) {
  const Scene scene = readScene(shippedScene("cantilever.json"));
  const SceneBody& body = scene.bodies[0];
  ASSERT_TRUE(body.resolution.has_value());
  const std::string prefix = "box:";
  ASSERT_EQ(body.model.rfind(prefix, 0), 0u);
  // box:L,H,W with L the longest side: the model spans resolution - 2 voxels along L.
  double size[3] = {0, 0, 0};
  ASSERT_EQ(
      std::sscanf(body.model.c_str() + prefix.size(), "%lf,%lf,%lf", &size[0], &size[1], &size[2]),
      3);
  const double voxel = size[0] / (*body.resolution - 2);
  const double element = voxel * (1 << body.elementLevel);
  EXPECT_GE(std::min(size[1], size[2]) / element, 4.0 - 1e-9);
  EXPECT_GE(size[0], std::max(size[1], size[2]));
}

// ---- defaults and values --------------------------------------------------------------------

TEST(SceneReader, DefaultsForAMinimalScene) {
  const Scene scene = parse(R"({"bodies": [{"model": "bunny"}]})");
  EXPECT_EQ(scene.source, "scene.json");
  EXPECT_EQ(scene.timeStep, 0.004);
  EXPECT_EQ(scene.gravity, Vec3d(0, -9.81, 0));
  EXPECT_EQ(scene.solver.tolerance, 1e-3);
  EXPECT_EQ(scene.solver.maxIterations, 100);
  EXPECT_FALSE(scene.frames.has_value());
  EXPECT_TRUE(scene.tools.empty());
  ASSERT_EQ(scene.bodies.size(), 1u);
  const SceneBody& b = scene.bodies[0];
  EXPECT_EQ(b.model, "bunny");
  EXPECT_FALSE(b.resolution.has_value());
  EXPECT_EQ(b.elementLevel, 3);
  EXPECT_EQ(b.finestLevel, -1);
  EXPECT_TRUE(b.materials.empty());
  EXPECT_TRUE(b.fixed.empty());
  EXPECT_EQ(b.offset, Vec3d::Zero());
  const SceneMaterial m = sceneMaterial(b, "default");
  const SceneMaterial defaults;
  EXPECT_EQ(m.name, "default");
  EXPECT_EQ(m.youngModulus, defaults.youngModulus);
  EXPECT_EQ(m.poissonRatio, defaults.poissonRatio);
  EXPECT_EQ(m.maxInternalLevel, 4);
  EXPECT_EQ(m.maxBoundaryLevel, 0);
}

TEST(SceneReader, ReadsEveryKey) {
  const Scene scene = parse(R"({
    "description": "every key",
    "time_step": 0.002, "gravity": [0, 0, -9.8], "frames": 50,
    "solver": {"tolerance": 1e-5, "max_iterations": 250, "projection_history": 3},
    "bodies": [{
      "model": "liver", "resolution": 64, "element_level": 2, "finest_level": 1,
      "materials": {
        "tumor": {"young_modulus": 3e5, "poisson_ratio": 0.45, "density": 1100,
                  "damping": [0.5, 0.02], "max_internal_level": 3, "max_boundary_level": 1},
        "liver": {"young_modulus": 6e4}
      },
      "fixed": [{"box": [[-1, -1, -1], [1, -0.05, 1]]}],
      "offset": [0.1, 0.2, 0.3]
    }],
    "tools": [{"type": "blade", "keys": [
      {"t": 0, "a": [0, 1, 0], "b": [0, -1, 0]},
      {"t": 0.5, "a": [1, 1, 0], "b": [1, -1, 0]}]}]
  })");
  EXPECT_EQ(scene.timeStep, 0.002);
  EXPECT_EQ(scene.gravity, Vec3d(0, 0, -9.8));
  EXPECT_EQ(scene.frames, 50);
  EXPECT_EQ(scene.solver.tolerance, 1e-5);
  EXPECT_EQ(scene.solver.projectionHistory, 3);
  EXPECT_EQ(scene.solver.maxIterations, 250);
  const SceneBody& b = scene.bodies[0];
  EXPECT_EQ(b.resolution, 64);
  EXPECT_EQ(b.elementLevel, 2);
  EXPECT_EQ(b.finestLevel, 1);
  ASSERT_EQ(b.materials.size(), 2u);
  EXPECT_EQ(b.materials[0].name, "tumor");  // file order
  EXPECT_EQ(b.materials[0].youngModulus, 3e5);
  EXPECT_EQ(b.materials[0].poissonRatio, 0.45);
  EXPECT_EQ(b.materials[0].density, 1100);
  EXPECT_EQ(b.materials[0].massDamping, 0.5);
  EXPECT_EQ(b.materials[0].stiffnessDamping, 0.02);
  EXPECT_EQ(b.materials[0].maxInternalLevel, 3);
  EXPECT_EQ(b.materials[0].maxBoundaryLevel, 1);
  EXPECT_EQ(b.materials[1].name, "liver");
  EXPECT_EQ(b.materials[1].youngModulus, 6e4);
  EXPECT_EQ(b.materials[1].poissonRatio, SceneMaterial().poissonRatio);
  EXPECT_EQ(sceneMaterial(b, "liver").youngModulus, 6e4);
  ASSERT_EQ(b.fixed.size(), 1u);
  EXPECT_EQ(b.fixed[0].lo, Vec3d(-1, -1, -1));
  EXPECT_EQ(b.fixed[0].hi, Vec3d(1, -0.05, 1));
  EXPECT_EQ(b.offset, Vec3d(0.1, 0.2, 0.3));
  ASSERT_EQ(scene.tools.size(), 1u);
  ASSERT_EQ(scene.tools[0].keys.size(), 2u);
  EXPECT_EQ(scene.tools[0].kind, ToolKind::Blade);
  EXPECT_EQ(scene.tools[0].keys[1].t, 0.5);
  EXPECT_EQ(scene.tools[0].keys[1].pose.a, Vec3d(1, 1, 0));
  EXPECT_EQ(scene.tools[0].keys[1].pose.b, Vec3d(1, -1, 0));
  // Integral numbers written as floats are integers.
  EXPECT_EQ(parse(withBody(R"("resolution": 64.0)")).bodies[0].resolution, 64);
}

// ---- blade interpolation --------------------------------------------------------------------

TEST(SceneReader, BladePoseInterpolatesAndClamps) {
  SceneTool tool;
  tool.keys.push_back({1.0, {Vec3d(0, 0, 0), Vec3d(0, 1, 0)}});
  tool.keys.push_back({2.0, {Vec3d(1, 0, 0), Vec3d(1, 1, 0)}});
  tool.keys.push_back({4.0, {Vec3d(1, 0, 2), Vec3d(1, 3, 2)}});
  auto expectPose = [&](double t, const Vec3d& a, const Vec3d& b) {
    const BladePose p = bladePoseAt(tool, t);
    EXPECT_TRUE(p.a.isApprox(a, 1e-15) || (p.a - a).norm() < 1e-15)
        << "t=" << t << " a=" << p.a.transpose();
    EXPECT_TRUE(p.b.isApprox(b, 1e-15) || (p.b - b).norm() < 1e-15)
        << "t=" << t << " b=" << p.b.transpose();
  };
  expectPose(-5.0, Vec3d(0, 0, 0), Vec3d(0, 1, 0));  // before the first key
  expectPose(1.0, Vec3d(0, 0, 0), Vec3d(0, 1, 0));
  expectPose(1.25, Vec3d(0.25, 0, 0), Vec3d(0.25, 1, 0));
  expectPose(2.0, Vec3d(1, 0, 0), Vec3d(1, 1, 0));
  expectPose(3.0, Vec3d(1, 0, 1), Vec3d(1, 2, 1));
  expectPose(3.5, Vec3d(1, 0, 1.5), Vec3d(1, 2.5, 1.5));
  expectPose(4.0, Vec3d(1, 0, 2), Vec3d(1, 3, 2));
  expectPose(9.0, Vec3d(1, 0, 2), Vec3d(1, 3, 2));  // after the last key
  // Keys are hit exactly (bit for bit), so consecutive segments meet without a gap.
  for (const ToolKey& k : tool.keys) {
    EXPECT_EQ(bladePoseAt(tool, k.t).a, k.pose.a);
    EXPECT_EQ(bladePoseAt(tool, k.t).b, k.pose.b);
  }
  SceneTool still;
  still.keys.push_back({0.5, {Vec3d(1, 2, 3), Vec3d(4, 5, 6)}});
  EXPECT_EQ(bladePoseAt(still, 0.0).a, Vec3d(1, 2, 3));
  EXPECT_EQ(bladePoseAt(still, 7.0).b, Vec3d(4, 5, 6));
}

TEST(SceneReader, ObstaclesAndContact) {
  const Scene scene = parse(R"({"bodies": [{"model": "liver"}],
    "obstacles": [{"type": "plane", "point": [0, -0.1, 0], "normal": [0, 2, 0]},
                  {"type": "box", "lo": [-1, -2, -1], "hi": [1, -0.1, 1]}],
    "contact": {"stiffness": 500}})");
  ASSERT_EQ(scene.obstacles.size(), 2u);
  EXPECT_EQ(scene.obstacles[0].type, ObstacleType::Plane);
  EXPECT_EQ(scene.obstacles[0].normal, Vec3d(0, 1, 0));  // normalised
  EXPECT_EQ(scene.obstacles[0].point, Vec3d(0, -0.1, 0));
  EXPECT_EQ(scene.obstacles[1].type, ObstacleType::Box);
  EXPECT_EQ(scene.obstacles[1].hi, Vec3d(1, -0.1, 1));
  EXPECT_EQ(scene.contact.stiffness, 500.0);
  EXPECT_EQ(parse(R"({"bodies": [{"model": "liver"}]})").contact.stiffness, 0.0);
}

TEST(SceneReaderErrors, BadObstaclesNameTheKey) {
  const std::string body = R"({"bodies": [{"model": "liver"}], )";
  EXPECT_EQ(parseError(body + R"("obstacles": [{"type": "cone"}]})"),
            "scene.json: obstacles[0].type: unknown obstacle type \"cone\" (expected one of: "
            "\"plane\", \"box\", \"mesh\")");
  EXPECT_EQ(parseError(body + R"("obstacles": [{"type": "plane", "point": [0, 0, 0],
                                                 "normal": [0, 0, 0]}]})"),
            "scene.json: obstacles[0].normal: must be a non-zero direction, got [0,0,0]");
  EXPECT_EQ(parseError(body + R"("obstacles": [{"type": "box", "lo": [0, 0, 0],
                                                 "hi": [1, 0, 1]}]})"),
            "scene.json: obstacles[0]: must have lo < hi on every axis, got y 0.0 >= 0.0");
  EXPECT_EQ(parseError(body + R"("obstacles": [{"type": "plane", "point": [0, 0, 0]}]})"),
            "scene.json: obstacles[0].normal: missing (required)");
  EXPECT_EQ(parseError(body + R"("obstacles": [{"type": "box", "lo": [0, 0, 0],
                                                 "hi": [1, 1, 1], "normal": [0, 1, 0]}]})"),
            "scene.json: obstacles[0].normal: unknown key (expected one of: type, lo, hi, "
            "friction)");
  EXPECT_EQ(parseError(body + R"("contact": {"stiffness": -1}})"),
            "scene.json: contact.stiffness: must be >= 0, got -1");
  EXPECT_EQ(parseError(body + R"("contact": {"damping": 0.3}})"),
            "scene.json: contact.damping: unknown key (expected one of: stiffness, self_collision, "
            "friction)");
  EXPECT_EQ(parseError(body + R"("contact": {"friction": -0.3}})"),
            "scene.json: contact.friction: must be >= 0, got -0.3");
  EXPECT_EQ(parseError(body + R"("contact": {"self_collision": 1}})"),
            "scene.json: contact.self_collision: must be true or false, got 1");
  EXPECT_EQ(parseError(body + R"("obstacles": [{"type": "plane", "point": [0, 0, 0],
                                                 "normal": [0, 1, 0], "friction": -1}]})"),
            "scene.json: obstacles[0].friction: must be >= 0, got -1");
  const Scene s = parse(body + R"("contact": {"self_collision": true, "friction": 0.5},
      "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.8}]})");
  EXPECT_TRUE(s.contact.selfCollision);
  EXPECT_EQ(s.contact.friction, 0.5);
  EXPECT_EQ(s.obstacles[0].friction, 0.8);
  EXPECT_FALSE(parse(R"({"bodies": [{"model": "liver"}]})").contact.selfCollision);  // opt-in
}

// ---- mesh obstacles --------------------------------------------------------------------------

// A scene in `dir` whose obstacles are `obstacles` (JSON list text).
Scene withObstacles(const TempDir& dir, const std::string& obstacles) {
  return parseScene(withTop(R"("obstacles": )" + obstacles), "scene.json", dir.path());
}

TEST(SceneReader, MeshObstaclesReadTheirFileFromTheScenesFolder) {
  const TempDir dir;
  fs::create_directories(dir.path() / "meshes");
  dir.write("meshes/cube.obj", test::cubeObj());  // [0.25, 0.75]^3
  const Scene s = withObstacles(dir, R"([
      {"type": "mesh", "path": "meshes/cube.obj", "friction": 0.4},
      {"type": "mesh", "path": "meshes/../meshes/cube.obj", "scale": 2, "translate": [0, -1, 0]}])");
  ASSERT_EQ(s.obstacles.size(), 2u);
  const Obstacle& cube = s.obstacles[0];
  EXPECT_EQ(cube.type, ObstacleType::Mesh);
  EXPECT_EQ(cube.friction, 0.4);
  ASSERT_NE(cube.mesh, nullptr);
  EXPECT_EQ(cube.mesh->triangleCount(), 12u);
  Vec3d n;
  EXPECT_NEAR(signedDistance(cube, Vec3d(0.5, 1.0, 0.5), n), 0.25, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3d::UnitY()));
  EXPECT_NEAR(signedDistance(cube, Vec3d(0.5, 0.5, 0.55), n), -0.2, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3d::UnitZ()));
  // Scaled about the origin, then moved.
  EXPECT_EQ(s.obstacles[1].friction, -1.0);  // the world's
  EXPECT_TRUE(s.obstacles[1].mesh->bounds()[0].isApprox(Vec3d(0.5, -0.5, 0.5)));
  EXPECT_TRUE(s.obstacles[1].mesh->bounds()[1].isApprox(Vec3d(1.5, 0.5, 1.5)));
}

TEST(SceneReaderErrors, BadMeshObstaclesNameTheKey) {
  const TempDir dir;
  dir.write("cube.obj", test::cubeObj());
  dir.write("empty.obj", "");
  dir.write("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
  const auto error = [&](const std::string& obstacle) {
    try {
      (void)withObstacles(dir, "[" + obstacle + "]");
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
      return msg;
    }
    return std::string("no error");
  };
  EXPECT_EQ(error(R"({"type": "mesh", "path": "none.obj"})"),
            "scene.json: obstacles[0].path: cannot read: mesh file '" + dir.file("none.obj") +
                "' does not exist (relative paths start at the scene's folder)");
  EXPECT_EQ(error(R"({"type": "mesh", "path": "empty.obj"})"),
            "scene.json: obstacles[0].path: cannot read: mesh file '" + dir.file("empty.obj") +
                "' is empty");
  EXPECT_EQ(error(R"({"type": "mesh", "path": "flat.obj"})"),
            "scene.json: obstacles[0].path: mesh file '" + dir.file("flat.obj") +
                "' has no non-degenerate triangles");
  fs::create_directories(dir.path() / "sub");
  EXPECT_EQ(error(R"({"type": "mesh", "path": "sub"})"),
            "scene.json: obstacles[0].path: cannot read: mesh file '" + dir.file("sub") +
                "' is a directory");
  EXPECT_EQ(error(R"({"type": "mesh"})"), "scene.json: obstacles[0].path: missing (required)");
  EXPECT_EQ(error(R"({"type": "mesh", "path": 3})"),
            "scene.json: obstacles[0].path: must be the path of a mesh file (a non-empty "
            "string), got 3");
  EXPECT_EQ(error(R"({"type": "mesh", "path": "cube.obj", "normal": [0, 1, 0]})"),
            "scene.json: obstacles[0].normal: unknown key (expected one of: type, path, scale, "
            "translate, friction)");
  EXPECT_EQ(error(R"({"type": "mesh", "path": "cube.obj", "scale": 0})"),
            "scene.json: obstacles[0].scale: must be > 0, got 0");
  EXPECT_EQ(error(R"({"type": "mesh", "path": "cube.obj", "translate": [0, 1]})"),
            "scene.json: obstacles[0].translate: must be a list of 3 numbers [x, y, z], got [0,1]");
  EXPECT_EQ(error(R"({"type": "mesh", "path": "cube.obj", "scale": 1e6, "translate": [5e5, 0, 0]})")
                .rfind("scene.json: obstacles[0]: the mesh, scaled and translated, reaches outside "
                       "the coordinate range [-1e6, 1e6] m (a vertex at ",
                       0),
            0u);
  EXPECT_EQ(error(R"({"type": "mesh", "path": "cube.obj", "friction": -1})"),
            "scene.json: obstacles[0].friction: must be >= 0, got -1");
}

// ---- errors: each kind names the file and the key path --------------------------------------

TEST(SceneReaderErrors, OutOfRangeNamesTheKeyPathAndTheValue) {
  EXPECT_EQ(parseError(R"({"bodies": [{"model": "liver",
                           "materials": {"tumor": {"poisson_ratio": 0.7}}}]})"),
            "scene.json: bodies[0].materials.tumor.poisson_ratio: must be in [0, 0.5), got 0.7");
  expectError(withBody(R"("materials": {"default": {"poisson_ratio": 0.5}})"),
              "bodies[0].materials.default.poisson_ratio: must be in [0, 0.5), got 0.5");
  expectError(withBody(R"("materials": {"default": {"young_modulus": -1}})"),
              "bodies[0].materials.default.young_modulus: must be > 0, got -1");
  expectError(withBody(R"("materials": {"default": {"density": 0}})"),
              "bodies[0].materials.default.density: must be > 0, got 0");
  expectError(withBody(R"("materials": {"default": {"damping": [0.1, -0.5]}})"),
              "bodies[0].materials.default.damping[1]: must be >= 0, got -0.5");
  expectError(withBody(R"("materials": {"default": {"max_internal_level": 8}})"),
              "bodies[0].materials.default.max_internal_level: must be an integer in 0..7, got 8");
  expectError(withBody(R"("materials": {"default": {"max_boundary_level": -1}})"),
              "bodies[0].materials.default.max_boundary_level: must be an integer in 0..7");
  expectError(withBody(R"("element_level": 7)"),
              "bodies[0].element_level: must be an integer in 0..6, got 7");
  expectError(withBody(R"("element_level": 2, "finest_level": 3)"),
              "bodies[0].finest_level: must be <= element_level (2), got 3");
  expectError(withBody(R"("element_level": 4, "surface_level": 5)"),
              "bodies[0].surface_level: must be <= element_level (4), got 5");
  expectError(withBody(R"("surface_level": -1)"), "bodies[0].surface_level");
  expectError(withBody(R"("resolution": 2)"), "bodies[0].resolution: must be an integer in 3..");
  expectError(withBody(R"("resolution": 1e12)"), "bodies[0].resolution: must be an integer in");
  expectError(withTop(R"("time_step": 0)"), "time_step: must be > 0, got 0");
  expectError(withTop(R"("frames": 0)"), "frames: must be an integer in 1..");
  expectError(withTop(R"("solver": {"tolerance": -1e-3})"), "solver.tolerance: must be > 0");
  expectError(withTop(R"("solver": {"max_iterations": 0})"),
              "solver.max_iterations: must be an integer in 1..");
  expectError(withTop(R"("solver": {"projection_history": -1})"),
              "solver.projection_history: must be an integer in 0..64");
  expectError(withTop(R"("solver": {"projection_history": 2.5})"),
              "solver.projection_history: must be an integer in 0..64");
  expectError(
      withTop(R"("solver": {"preconditioner": "amg"})"),
      R"(solver.preconditioner: unknown preconditioner "amg" (expected one of: "auto", "cholesky", "multigrid", "jacobi", "block_jacobi", "symmetric_gauss_seidel", "incomplete_cholesky", "two_level"))");
  expectError(withTop(R"("solver": {"preconditioner": 3})"),
              "solver.preconditioner: unknown preconditioner 3");
}

TEST(SceneReader, PreconditionerByName) {
  for (SolverChoice kind : kSolverChoices) {
    const Scene scene = parse(withTop(std::string(R"("solver": {"preconditioner": ")") +
                                      solverChoiceName(kind) + "\"}"));
    EXPECT_EQ(scene.solver.preconditioner, kind) << solverChoiceName(kind);
  }
  EXPECT_EQ(parse(withTop(R"("frames": 3)")).solver.preconditioner, SolverChoice::Automatic);
}

TEST(SceneReaderErrors, NotAnIntegerIsAnError) {
  expectError(withBody(R"("resolution": 64.5)"),
              "bodies[0].resolution: must be an integer in 3..4096, got 64.5");
  expectError(withTop(R"("frames": "100")"),
              R"(frames: must be an integer in 1..100000000, got "100")");
}

TEST(SceneReaderErrors, WrongTypeIsAnError) {
  expectError(withTop(R"("time_step": "fast")"), R"(time_step: must be a number, got "fast")");
  expectError(withTop(R"("solver": [1, 2])"), "solver: must be an object, got a list");
  expectError(withTop(R"("gravity": [0, -9.81])"),
              "gravity: must be a list of 3 numbers [x, y, z], got [0,-9.81]");
  expectError(withTop(R"("gravity": [0, null, 0])"), "gravity[1]: must be a number, got null");
  expectError(withBody(R"("materials": [])"), "bodies[0].materials: must be an object, got a list");
  expectError(withBody(R"("materials": {"default": 5})"),
              "bodies[0].materials.default: must be an object, got a number");
  expectError(withBody(R"("materials": {"default": {"damping": 0.1}})"),
              "bodies[0].materials.default.damping: must be a list of 2 numbers [alpha, beta]");
  expectError(withBody(R"("fixed": {"box": []})"),
              "bodies[0].fixed: must be a list, got an object");
  expectError(withBody(R"("offset": [1, 2, 3, 4])"),
              "bodies[0].offset: must be a list of 3 numbers");
  expectError(R"({"bodies": [{"model": 42}]})", "bodies[0].model: must be a string, got a number");
  expectError(R"({"bodies": [{"model": ""}]})", "bodies[0].model: must not be empty");
  expectError(R"([1, 2])", "top level: must be an object, got a list");
  expectError(withTop(R"("description": 3)"), "description: must be a string");
}

TEST(SceneReaderErrors, UnknownKeysAnywhere) {
  expectError(withTop(R"("timestep": 0.01)"), "timestep: unknown key (expected one of: ");
  expectError(withTop(R"("solver": {"tol": 1})"), "solver.tol: unknown key");
  expectError(withBody(R"("elements": 3)"), "bodies[0].elements: unknown key");
  expectError(R"({"bodies": [{"model": "liver",
                 "materials": {"tumor": {"youngs_modulus": 1e5}}}]})",
              "bodies[0].materials.tumor.youngs_modulus: unknown key");
  expectError(withBody(R"("fixed": [{"box": [[0,0,0],[1,1,1]], "sphere": 1}])"),
              "bodies[0].fixed[0].sphere: unknown key");
  expectError(withTop(R"("tools": [{"type": "blade", "speed": 1,
                                     "keys": [{"t": 0, "a": [0,0,0], "b": [1,0,0]}]}])"),
              "tools[0].speed: unknown key");
  expectError(withTop(R"("tools": [{"type": "blade",
                                     "keys": [{"t": 0, "a": [0,0,0], "b": [1,0,0], "c": 1}]}])"),
              "tools[0].keys[0].c: unknown key");
}

TEST(SceneReaderErrors, MissingRequiredKeys) {
  expectError(R"({"time_step": 0.01})", "bodies: missing (required)");
  expectError(R"({"bodies": []})", "bodies: must be a non-empty list");
  expectError(R"({"bodies": [{"resolution": 50}]})", "bodies[0].model: missing (required)");
  expectError(withBody(R"("fixed": [{}])"), "bodies[0].fixed[0].box: missing (required)");
  expectError(withTop(R"("tools": [{"keys": []}])"), "tools[0].type: missing (required)");
  expectError(withTop(R"("tools": [{"type": "blade"}])"),
              R"(tools[0]: needs exactly one of "keys" and "trajectory")");
  expectError(withTop(R"("tools": [{"type": "blade", "keys": [{"t": 0, "a": [0,0,0]}]}])"),
              "tools[0].keys[0].b: missing (required)");
}

TEST(SceneReaderErrors, BadFixedBox) {
  expectError(withBody(R"("fixed": [{"box": [[0, 0.2, 0], [1, 0.1, 1]]}])"),
              "bodies[0].fixed[0].box: must have y0 <= y1, got 0.2 > 0.1");
  expectError(withBody(R"("fixed": [{"box": [[0, 0, 0]]}])"),
              "bodies[0].fixed[0].box: must be [[x0, y0, z0], [x1, y1, z1]]");
  expectError(withBody(R"("fixed": [{"box": [[0, 0, 0], [1, 1]]}])"),
              "bodies[0].fixed[0].box[1]: must be a list of 3 numbers");
  // A flat box (x0 == x1) is allowed: it fixes the nodes on a plane.
  EXPECT_EQ(parse(withBody(R"("fixed": [{"box": [[0, 0, 0], [0, 1, 1]]}])")).bodies[0].fixed.size(),
            1u);
}

TEST(SceneReaderErrors, BadTools) {
  expectError(withTop(R"("tools": [{"type": "saw", "keys": []}])"),
              R"(tools[0].type: unknown tool type "saw" (expected one of: "blade", "probe"))");
  expectError(withTop(R"("tools": [{"type": "blade", "keys": []}])"),
              "tools[0].keys: must be a non-empty list");
  expectError(withTop(R"("tools": [{"type": "blade", "keys": [
                {"t": 0, "a": [0,0,0], "b": [1,0,0]},
                {"t": 0.1, "a": [0,0,0], "b": [1,0,0]},
                {"t": 0.1, "a": [0,0,0], "b": [1,0,0]}]}])"),
              "tools[0].keys[2].t: key times must increase strictly (a jump key may repeat "
              "the previous key's time): must be > 0.1");
  expectError(withTop(R"("tools": [{"type": "blade", "keys": [
                {"t": 0.1, "a": [0,0,0], "b": [1,0,0]},
                {"t": 0.05, "a": [0,0,0], "b": [1,0,0], "jump": true}]}])"),
              "tools[0].keys[1].t: key times must increase strictly (a jump key may repeat "
              "the previous key's time): must be >= 0.1");
  expectError(withTop(R"("tools": [{"type": "blade", "keys": [
                {"t": 0.1, "a": [0,0,0], "b": [1,0,0], "jump": 1}]}])"),
              "tools[0].keys[0].jump: must be true or false, got 1");
  expectError(
      withTop(R"("tools": [{"type": "blade", "keys": [{"t": 0, "a": [1,2,3], "b": [1,2,3]}]}])"),
      "tools[0].keys[0]: the blade's ends a and b must differ");
  expectError(withTop(R"("tools": {"type": "blade"})"), "tools: must be a list, got an object");
}

TEST(SceneReaderErrors, BadProbes) {
  expectError(withTop(R"("tools": [{"type": "probe", "keys": [{"t": 0, "p": [0,0,0]}]}])"),
              "tools[0].radius: missing (required)");
  expectError(
      withTop(R"("tools": [{"type": "probe", "radius": 0, "keys": [{"t": 0, "p": [0,0,0]}]}])"),
      "tools[0].radius: must be");
  expectError(withTop(R"("tools": [{"type": "probe", "radius": 0.01, "keys": [
                {"t": 0, "p": [0,0,0]}, {"t": 1, "a": [0,0,0], "b": [1,0,0]}]}])"),
              "tools[0].keys[1]: a probe's keys all give \"p\"");
  expectError(withTop(R"("tools": [{"type": "probe", "radius": 0.01, "keys": [
                {"t": 0, "p": [0,0,0], "a": [1,1,1]}]}])"),
              "tools[0].keys[0].a: unknown key");
  expectError(
      withTop(R"("tools": [{"type": "blade", "radius": 0.01, "keys": [{"t": 0, "p": [0,0,0]}]}])"),
      "tools[0].radius: unknown key");
  expectError(withTop(R"("tools": [{"type": "blade", "keys": [{"t": 0, "p": [0,0,0]}]}])"),
              "tools[0].keys[0].p: unknown key");
}

TEST(SceneReader, Probes) {
  const Scene s = parse(withTop(R"("tools": [
      {"type": "probe", "radius": 0.01, "keys": [{"t": 0, "p": [0, 1, 0]}, {"t": 1, "p": [0, 0, 0]}]},
      {"type": "probe", "radius": 0.02, "keys": [{"t": 0, "a": [0, 1, 0], "b": [0, 2, 0]}]}])"));
  ASSERT_EQ(s.tools.size(), 2u);
  EXPECT_EQ(s.tools[0].kind, ToolKind::Probe);
  EXPECT_EQ(s.tools[0].radius, 0.01);
  EXPECT_EQ(s.tools[0].keys[0].pose.a, Vec3d(0, 1, 0));
  EXPECT_EQ(s.tools[0].keys[0].pose.b, Vec3d(0, 1, 0));
  EXPECT_EQ(s.tools[1].keys[0].pose.b, Vec3d(0, 2, 0));
}

TEST(SceneReader, TrajectoriesPlayARecordingsTool) {
  const TempDir dir;
  dir.write("rec.json", R"({"time_step": 0.01, "tools": [
      {"type": "blade", "keys": [{"t": 0, "a": [0, 1, 0], "b": [1, 1, 0]},
                                 {"t": 0.25, "a": [0, 0.5, 0], "b": [1, 0.5, 0]}]},
      {"type": "probe", "radius": 0.5, "keys": [{"t": 0, "p": [3, 2, 1]}]}]})");
  const auto scene = [&](const std::string& tools) {
    return parseScene(withTop(R"("tools": )" + tools), "scene.json", dir.path());
  };
  const Scene s = scene(R"([{"type": "blade", "trajectory": "rec.json"},
      {"type": "probe", "radius": 0.01, "trajectory": "rec.json", "trajectory_tool": 1}])");
  ASSERT_EQ(s.tools.size(), 2u);
  ASSERT_EQ(s.tools[0].keys.size(), 2u);
  EXPECT_EQ(s.tools[0].keys[1].t, 0.25);
  EXPECT_EQ(s.tools[0].keys[1].pose.a, Vec3d(0, 0.5, 0));
  EXPECT_EQ(s.tools[1].radius, 0.01);  // the scene's, not the recording's
  EXPECT_EQ(s.tools[1].keys[0].pose.a, Vec3d(3, 2, 1));
  const auto error = [&](const std::string& tools) {
    try {
      (void)scene(tools);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error(R"([{"type": "blade", "trajectory": "rec.json", "trajectory_tool": 2}])"),
            "scene.json: tools[0].trajectory: the recording has 2 tool(s); no tool 2");
  EXPECT_EQ(error(R"([{"type": "blade", "trajectory": "rec.json", "trajectory_tool": 1}])"),
            "scene.json: tools[0].trajectory: tool 1 of the recording is a probe, not a blade");
  EXPECT_EQ(
      error(R"([{"type": "blade", "trajectory": "missing.json"}])")
          .rfind("scene.json: tools[0].trajectory: " + dir.file("missing.json") + ": no such file",
                 0),
      0u);
  EXPECT_EQ(error(R"([{"type": "blade", "trajectory": "rec.json", "keys": []}])"),
            R"(scene.json: tools[0]: needs exactly one of "keys" and "trajectory")");
  EXPECT_EQ(error(R"([{"type": "blade", "keys": [{"t": 0, "a": [0,0,0], "b": [1,0,0]}],
                       "trajectory_tool": 0}])"),
            R"(scene.json: tools[0].trajectory_tool: only goes with "trajectory")");
  dir.write("bad.json", R"({"tools": [{"type": "blade", "keys": [{"t": 0, "a": [0,0,0]}]}]})");
  EXPECT_EQ(error(R"([{"type": "blade", "trajectory": "bad.json"}])"),
            dir.file("bad.json") + ": tools[0].keys[0].b: missing (required)");
}

TEST(SceneReaderErrors, BadModels) {
  expectError(R"({"bodies": [{"model": "box:0.1,0.2"}]})",
              "bodies[0].model: bad model 'box:0.1,0.2'");
  expectError(R"({"bodies": [{"model": "sphere:-1"}]})", "bodies[0].model: bad model 'sphere:-1'");
  expectError(R"({"bodies": [{"model": "box"}]})", "bodies[0].model: model 'box' needs its size");
  expectError(R"({"bodies": [{"model": "bunny"}, {"model": "no-such-mesh.obj"}]})",
              "bodies[1].model: no built-in model and no such mesh file '" +
                  (fs::current_path() / "no-such-mesh.obj").lexically_normal().string() + "'");
}

TEST(SceneReaderErrors, UnknownMaterialNameOnceTheModelIsLoaded) {
  const Scene scene = parse(R"({"bodies": [{"model": "bunny"},
      {"model": "liver", "materials": {"liver": {}, "tumour": {"young_modulus": 1e5}}}]})");
  EXPECT_NO_THROW(checkMaterialNames(scene, 0, {"default"}));
  try {
    checkMaterialNames(scene, 1, {"liver", "tumor"});
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "scene.json: bodies[1].materials.tumour: model 'liver' has no material "
                 "'tumour' (it has: liver, tumor)");
  }
  try {
    (void)loadBodyModel(scene, 1);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("scene.json: bodies[1].materials.tumour: ", 0), 0u)
        << e.what();
  }
}

TEST(SceneReaderErrors, JsonSyntaxErrorHasLineAndColumn) {
  const std::string msg = parseError("{\n  \"time_step\": 0.004,\n  \"bodies\": [}\n}\n");
  EXPECT_EQ(msg.rfind("scene.json: JSON syntax error at line 3, column 14: ", 0), 0u) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  EXPECT_EQ(msg.find("json.exception"), std::string::npos) << msg;
  const std::string empty = parseError("");
  EXPECT_EQ(empty.rfind("scene.json: JSON syntax error at line 1, column 1: ", 0), 0u) << empty;
  const std::string trailing = parseError(withTop(R"("time_step": 0.004,)"));
  EXPECT_EQ(trailing.rfind("scene.json: JSON syntax error at line 1, column ", 0), 0u) << trailing;
}

TEST(SceneReaderErrors, NumberTooLarge) {
  expectError(withTop(R"("time_step": 1e999)"),
              "JSON error at line 1, column 47: number overflow parsing '1e999'");
}

TEST(SceneReaderErrors, DuplicateKey) {
  expectError(withTop(R"("time_step": 0.004, "time_step": 0.01)"),
              R"(key "time_step" appears twice in one object)");
}

TEST(SceneReaderErrors, MissingOrUnreadableFile) {
  const TempDir dir;
  const std::string missing = dir.file("nothing.json");
  try {
    (void)readScene(missing);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), missing + ": no such file");
  }
  try {
    (void)readScene(dir.path().string());
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), dir.path().string() + ": is a directory, not a scene file");
  }
  const std::string bad = dir.write("bad.json", "{\"bodies\": [}");
  try {
    (void)readScene(bad);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(bad + ": JSON syntax error at line 1, column 13", 0), 0u)
        << e.what();
  }
}

// ---- model paths ----------------------------------------------------------------------------

TEST(SceneReader, RelativeModelPathsStartAtTheScenesFolder) {
  const TempDir dir;
  fs::create_directories(dir.path() / "scenes" / "sub");
  fs::create_directories(dir.path() / "meshes");
  const std::string mesh = dir.write("meshes/cube.obj", test::cubeObj());
  const std::string scenePath =
      dir.write("scenes/sub/cube.json",
                R"({"bodies": [{"model": "../../meshes/./cube.obj", "offset": [1, 0, 0],
                      "materials": {"default": {"young_modulus": 2e5}}},
                     {"model": ")" +
                    mesh + R"("}]})");
  const Scene scene = readScene(scenePath);
  const std::string expected = fs::absolute(mesh).lexically_normal().string();
  EXPECT_EQ(scene.bodies[0].model, expected);
  EXPECT_TRUE(fs::path(scene.bodies[0].model).is_absolute());
  EXPECT_EQ(scene.bodies[1].model, expected);  // absolute paths are kept
  EXPECT_FALSE(isBuiltinModelSpec(scene.bodies[0].model));

  // A mesh's single material is "default" in a scene, and the offset moves it.
  const Model model = loadBodyModel(scene, 0);
  ASSERT_EQ(model.materials.size(), 1u);
  EXPECT_EQ(model.materials[0].name, "default");
  const auto bounds = model.materials[0].mesh.bounds();
  EXPECT_DOUBLE_EQ(bounds[0].x(), 1.25);
  EXPECT_DOUBLE_EQ(bounds[1].x(), 1.75);
  EXPECT_DOUBLE_EQ(bounds[0].y(), 0.25);

  // The same relative path from another folder does not exist.
  const std::string moved =
      dir.write("cube.json", R"({"bodies": [{"model": "../meshes/cube.obj"}]})");
  try {
    (void)readScene(moved);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(moved + ": bodies[0].model: no built-in model and no such mesh file", 0),
              0u)
        << msg;
    EXPECT_NE(msg.find("relative"), std::string::npos) << msg;
  }
}

TEST(SceneReader, BuiltinNamesAreNotPaths) {
  for (const char* spec : {"bunny", "liver", "starfish", "box:0.1,0.02,0.02", "sphere:0.05"}) {
    EXPECT_TRUE(isBuiltinModelSpec(spec)) << spec;
    EXPECT_EQ(parse(R"({"bodies": [{"model": ")" + std::string(spec) + R"("}]})").bodies[0].model,
              spec);
  }
  EXPECT_FALSE(isBuiltinModelSpec("bunny.obj"));
}

}  // namespace
}  // namespace voxcut

namespace voxcut {
namespace {

using test::expectError;
using test::withBody;
using test::withTop;

TEST(SceneReader, ViewAndLabelKeys) {
  const Scene s = parseScene(withTop(R"("view": [90, -35])"), "scene.json", ".");
  ASSERT_TRUE(s.view.has_value());
  EXPECT_EQ((*s.view)[1], -35.0);
  expectError(withTop(R"("view": [90])"), "view: must be [yaw, pitch]");
  expectError(withTop(R"("view": [0, 90])"), "view[1]: must be in (-90, 90)");
  // Label keys belong to label volumes.
  expectError(withBody(R"("labels": "all")"), "bodies[0].labels: applies to a label volume");
  expectError(withBody(R"("min_island": 3)"), "bodies[0].min_island: applies to a label volume");
}

}  // namespace
}  // namespace voxcut
