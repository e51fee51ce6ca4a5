#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "TempDir.h"
#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/MeshReader.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/io/SceneWriter.h"
#include "voxcut/io/VolumeWriter.h"
#include "voxcut/sim/Scene.h"
#include "voxcut/voxel/LabelVolume.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

const fs::path kScenes = fs::path(VOXCUT_SOURCE_DIR) / "scenes";

SceneBody bodyOf(const std::string& model) {
  SceneBody b;
  b.model = model;
  return b;
}

SceneMaterial materialOf(const std::string& name) {
  SceneMaterial m;
  m.name = name;
  return m;
}

// ---- comparison, field by field ----------------------------------------------------------

/// Whether two doubles are the same bits (0.0 and -0.0 differ, as the writer keeps them).
bool sameBits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

void expectVec(const Vec3d& a, const Vec3d& b, const std::string& what) {
  for (int i = 0; i < 3; ++i)
    EXPECT_TRUE(sameBits(a[i], b[i])) << what << "[" << i << "]: " << a[i] << " vs " << b[i];
}

void expectSameMaterial(const SceneMaterial& a, const SceneMaterial& b) {
  SCOPED_TRACE("material " + a.name);
  EXPECT_EQ(a.name, b.name);
  EXPECT_TRUE(sameBits(a.youngModulus, b.youngModulus));
  EXPECT_TRUE(sameBits(a.poissonRatio, b.poissonRatio));
  EXPECT_TRUE(sameBits(a.density, b.density));
  EXPECT_TRUE(sameBits(a.massDamping, b.massDamping));
  EXPECT_TRUE(sameBits(a.stiffnessDamping, b.stiffnessDamping));
  EXPECT_EQ(a.maxInternalLevel, b.maxInternalLevel);
  EXPECT_EQ(a.maxBoundaryLevel, b.maxBoundaryLevel);
}

void expectSameBody(const SceneBody& a, const SceneBody& b) {
  EXPECT_EQ(a.model, b.model);
  EXPECT_EQ(a.resolution, b.resolution);
  EXPECT_EQ(a.elementLevel, b.elementLevel);
  EXPECT_EQ(a.finestLevel, b.finestLevel);
  EXPECT_EQ(a.frontLevel, b.frontLevel);
  EXPECT_EQ(a.surfaceLevel, b.surfaceLevel);
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (std::size_t m = 0; m < a.materials.size(); ++m)
    expectSameMaterial(a.materials[m], b.materials[m]);
  ASSERT_EQ(a.fixed.size(), b.fixed.size());
  for (std::size_t f = 0; f < a.fixed.size(); ++f) {
    expectVec(a.fixed[f].lo, b.fixed[f].lo, "fixed lo");
    expectVec(a.fixed[f].hi, b.fixed[f].hi, "fixed hi");
  }
  EXPECT_TRUE(a.offset == b.offset) << a.offset.transpose() << " vs " << b.offset.transpose();
  ASSERT_EQ(a.labels.size(), b.labels.size());
  for (std::size_t l = 0; l < a.labels.size(); ++l) {
    EXPECT_EQ(a.labels[l].value, b.labels[l].value);
    EXPECT_EQ(a.labels[l].name, b.labels[l].name);
  }
  EXPECT_EQ(a.minIsland, b.minIsland);
  EXPECT_EQ(a.labelNames, b.labelNames);
  EXPECT_EQ(a.volume, b.volume);
}

void expectSameTool(const SceneTool& a, const SceneTool& b) {
  EXPECT_EQ(a.kind, b.kind);
  EXPECT_TRUE(sameBits(a.radius, b.radius));
  EXPECT_TRUE(sameBits(a.friction, b.friction));
  ASSERT_EQ(a.keys.size(), b.keys.size());
  for (std::size_t k = 0; k < a.keys.size(); ++k) {
    SCOPED_TRACE("key " + std::to_string(k));
    EXPECT_TRUE(sameBits(a.keys[k].t, b.keys[k].t));
    expectVec(a.keys[k].pose.a, b.keys[k].pose.a, "a");
    expectVec(a.keys[k].pose.b, b.keys[k].pose.b, "b");
    EXPECT_EQ(a.keys[k].jump, b.keys[k].jump);
  }
}

void expectSameObstacle(const Obstacle& a, const Obstacle& b) {
  EXPECT_EQ(a.type, b.type);
  expectVec(a.point, b.point, "point");
  expectVec(a.normal, b.normal, "normal");
  expectVec(a.lo, b.lo, "lo");
  expectVec(a.hi, b.hi, "hi");
  EXPECT_TRUE(sameBits(a.friction, b.friction));
  EXPECT_EQ(a.path, b.path);
  EXPECT_EQ(a.mesh == nullptr, b.mesh == nullptr);
  if (a.mesh && b.mesh) {
    EXPECT_EQ(a.mesh->triangleCount(), b.mesh->triangleCount());
  }
}

/// Every field of two scenes but `source`.
void expectSameScene(const Scene& a, const Scene& b) {
  EXPECT_TRUE(sameBits(a.timeStep, b.timeStep));
  expectVec(a.gravity, b.gravity, "gravity");
  EXPECT_TRUE(sameBits(a.solver.tolerance, b.solver.tolerance));
  EXPECT_EQ(a.solver.maxIterations, b.solver.maxIterations);
  EXPECT_EQ(a.solver.preconditioner, b.solver.preconditioner);
  EXPECT_EQ(a.solver.projectionHistory, b.solver.projectionHistory);
  EXPECT_EQ(a.frames, b.frames);
  ASSERT_EQ(a.view.has_value(), b.view.has_value());
  if (a.view) {
    EXPECT_TRUE(sameBits((*a.view)[0], (*b.view)[0]));
    EXPECT_TRUE(sameBits((*a.view)[1], (*b.view)[1]));
  }
  ASSERT_EQ(a.bodies.size(), b.bodies.size());
  for (std::size_t i = 0; i < a.bodies.size(); ++i) {
    SCOPED_TRACE("bodies[" + std::to_string(i) + "]");
    expectSameBody(a.bodies[i], b.bodies[i]);
  }
  ASSERT_EQ(a.tools.size(), b.tools.size());
  for (std::size_t i = 0; i < a.tools.size(); ++i) {
    SCOPED_TRACE("tools[" + std::to_string(i) + "]");
    expectSameTool(a.tools[i], b.tools[i]);
  }
  ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
  for (std::size_t i = 0; i < a.obstacles.size(); ++i) {
    SCOPED_TRACE("obstacles[" + std::to_string(i) + "]");
    expectSameObstacle(a.obstacles[i], b.obstacles[i]);
  }
  EXPECT_TRUE(sameBits(a.contact.stiffness, b.contact.stiffness));
  EXPECT_EQ(a.contact.selfCollision, b.contact.selfCollision);
  EXPECT_TRUE(sameBits(a.contact.friction, b.contact.friction));
  EXPECT_EQ(a.contact.keepSelfCandidates, b.contact.keepSelfCandidates);
}

/// The scene written for `dir` and read back as if from a file in `dir`.
Scene roundTrip(const Scene& scene, const fs::path& dir) {
  const std::string text = sceneText(scene, dir);
  Scene back = parseScene(text, "written.json", dir);
  EXPECT_EQ(back.source, "written.json");
  return back;
}

/// The message of the InputError sceneText throws; fails the test if none is.
std::string writeError(const Scene& scene) {
  try {
    (void)sceneText(scene);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError";
  return {};
}

/// A label volume of `dims` with `value(i, j, k)` per voxel, placed by `axes` and `origin`.
template <class Fn>
LabelVolume makeVolume(const Index3& dims, const Eigen::Matrix3d& axes, const Vec3d& origin,
                       Fn value) {
  LabelVolume v;
  v.dims = dims;
  v.axes = axes;
  v.origin = origin;
  std::vector<std::int64_t> samples;
  for (int k = 0; k < dims.z; ++k)
    for (int j = 0; j < dims.y; ++j)
      for (int i = 0; i < dims.x; ++i) samples.push_back(value(i, j, k));
  setLabelsFromSamples(v, samples.data(), samples.size(), SampleType::Int64, false, "test");
  return v;
}

/// A 14 x 12 x 10 volume of a ball (label 2) holding a smaller box (label 7), voxels of
/// 2 x 2.5 x 3 mm turned about z, at a non-decimal origin.
LabelVolume ballWithBox() {
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(0.3, Vec3d(0.2, 0.3, 1.0).normalized()).toRotationMatrix();
  const Eigen::Matrix3d axes = turn * Vec3d(2e-3, 2.5e-3, 3e-3).asDiagonal();
  return makeVolume({14, 12, 10}, axes, Vec3d(0.1, -0.2, 1.0 / 3.0), [](int i, int j, int k) {
    if (i >= 5 && i <= 8 && j >= 4 && j <= 6 && k >= 3 && k <= 5) return std::int64_t{7};
    return (Vec3d(i, j, k) - Vec3d(6.5, 5.5, 4.5)).norm() <= 4.4 ? std::int64_t{2}
                                                                  : std::int64_t{0};
  });
}

// ---- shipped scenes ----------------------------------------------------------------------

TEST(SceneWriter, EveryShippedSceneReadsBackEqual) {
  int scenes = 0;
  for (const auto& entry : fs::directory_iterator(kScenes)) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().filename().string());
    if (entry.path().filename() == "atlas-lobe.json" &&
        !fs::exists("/usr/share/mricron/templates/aal.nii.gz"))
      continue;  // mricron-data is not installed
    const Scene scene = readScene(entry.path().string());
    expectSameScene(scene, roundTrip(scene, kScenes));
    // Read from elsewhere, the paths are absolute and still name the same files.
    TempDir elsewhere;
    expectSameScene(scene, roundTrip(scene, elsewhere.path()));
    ++scenes;
  }
  EXPECT_GE(scenes, 11);
}

TEST(SceneWriter, MeshObstacleKeepsItsPath) {
  const Scene scene = readScene((kScenes / "box-down-ramp.json").string());
  ASSERT_EQ(scene.obstacles.size(), 2u);
  const Obstacle& ramp = scene.obstacles[0];
  ASSERT_EQ(ramp.type, ObstacleType::Mesh);
  EXPECT_EQ(ramp.path, (kScenes / "meshes" / "ramp.obj").lexically_normal().string());
  EXPECT_TRUE(scene.obstacles[1].path.empty());  // the plane
  const std::string text = sceneText(scene, kScenes);
  EXPECT_NE(text.find(R"("path": "meshes/ramp.obj")"), std::string::npos) << text;
  EXPECT_EQ(roundTrip(scene, kScenes).obstacles[0].path, ramp.path);
}

TEST(SceneWriter, ScaledMeshObstacleHasNoPathToWrite) {
  const std::string ramp = (kScenes / "meshes" / "ramp.obj").string();
  const Scene scene =
      parseScene(R"({"bodies": [{"model": "bunny"}], "obstacles": [{"type": "mesh", "path": ")" +
                     ramp + R"(", "scale": 2}]})",
                 "scene.json", kScenes);
  EXPECT_TRUE(scene.obstacles[0].path.empty());
  EXPECT_NE(writeError(scene).find("obstacles[0].path"), std::string::npos);
}

// ---- paths ---------------------------------------------------------------------------------

TEST(SceneWriter, PathsUnderTheFolderAreWrittenRelative) {
  TempDir dir;
  fs::create_directories(dir.path() / "meshes");
  fs::copy_file(kScenes / "meshes" / "ramp.obj", dir.path() / "meshes" / "ramp.obj");
  writeNrrd(ballWithBox(), dir.file("ball.nrrd"));
  dir.write("names.txt", "2 ball\n7 box\n");
  dir.write("bunny", "not read: the scene reader checks that a body's file exists");
  dir.write("wedge.obj", "v 0 0 0\n");

  Scene scene;
  SceneBody volume;
  volume.model = dir.file("ball.nrrd");
  volume.labelNames = dir.file("names.txt");
  scene.bodies.push_back(volume);
  SceneBody named;  // a file whose relative name is a built-in model's
  named.model = dir.file("bunny");
  scene.bodies.push_back(named);
  SceneBody mesh;
  mesh.model = dir.file("wedge.obj");
  scene.bodies.push_back(mesh);
  Obstacle ramp = meshObstacle(readMesh(dir.file("meshes/ramp.obj")));
  ramp.path = dir.file("meshes/ramp.obj");
  scene.obstacles.push_back(ramp);

  // With and without a trailing separator, and through a ".." that normalises away.
  for (const fs::path& base : {dir.path(), fs::path(dir.path().string() + "/"),
                               dir.path() / "meshes" / ".."}) {
    SCOPED_TRACE(base.string());
    const std::string text = sceneText(scene, base);
    EXPECT_NE(text.find(R"("model": "ball.nrrd")"), std::string::npos) << text;
    EXPECT_NE(text.find(R"("label_names": "names.txt")"), std::string::npos) << text;
    EXPECT_NE(text.find(R"("model": "wedge.obj")"), std::string::npos) << text;
    EXPECT_NE(text.find(R"("path": "meshes/ramp.obj")"), std::string::npos) << text;
    EXPECT_NE(text.find("\"model\": \"" + dir.file("bunny") + "\""), std::string::npos) << text;
    const Scene back = parseScene(text, "scene.json", dir.path());
    expectSameScene(scene, back);
    EXPECT_NE(back.bodies[1].model, "bunny");
  }
  // Under a sub-folder: the files outside it are written absolute.
  const std::string text = sceneText(scene, dir.path() / "meshes");
  EXPECT_NE(text.find("\"model\": \"" + dir.file("ball.nrrd") + "\""), std::string::npos);
  EXPECT_NE(text.find(R"("path": "ramp.obj")"), std::string::npos) << text;
  expectSameScene(scene, parseScene(text, "scene.json", dir.path() / "meshes"));
  // Without a folder, every path is absolute.
  EXPECT_NE(sceneText(scene).find("\"path\": \"" + dir.file("meshes/ramp.obj") + "\""),
            std::string::npos);
}

// ---- a scene made in code ------------------------------------------------------------------

/// A scene with a setting away from its default wherever the format has one.
Scene everySetting(const TempDir& dir) {
  writeNrrd(ballWithBox(), dir.file("ball.nrrd"));
  dir.write("names.txt", "2 ball\n7 box\n");
  Scene s;
  s.timeStep = 0.1 / 3.0;
  s.gravity = Vec3d(1e-300, -1.0 / 3.0, 0.1);
  s.solver.tolerance = 1.0 / 3.0 * 1e-4;
  s.solver.maxIterations = 77;
  s.solver.preconditioner = SolverChoice::Multigrid;
  s.solver.projectionHistory = 0;
  s.frames = 123;
  s.view = std::array<double, 2>{-1.0 / 3.0, 0.1};

  SceneBody liver;
  liver.model = "liver";
  liver.resolution = 64;
  liver.elementLevel = 4;
  liver.finestLevel = 1;
  liver.frontLevel = 2;
  liver.surfaceLevel = 3;
  SceneMaterial tumor;  // listed first: the order must survive
  tumor.name = "tumor";
  tumor.youngModulus = 3e6 / 7.0;
  tumor.poissonRatio = 0.1;
  tumor.density = 1100.5;
  tumor.massDamping = 0.0;
  tumor.stiffnessDamping = 1e-7;
  tumor.maxInternalLevel = 7;
  tumor.maxBoundaryLevel = 2;
  SceneMaterial parenchyma;
  parenchyma.name = "liver";
  liver.materials = {tumor, parenchyma};
  liver.fixed = {{Vec3d(-0.1, 0.015, -0.2), Vec3d(0.1, 0.1 / 3.0, 0.2)},
                 {Vec3d(0.0, 0.0, 0.0), Vec3d(0.0, 0.0, 0.0)}};
  liver.offset = Vec3d(0.1, -0.2, 1.0 / 3.0);
  s.bodies.push_back(liver);

  SceneBody ball;
  ball.model = dir.file("ball.nrrd");
  ball.labels = {{7, "box \"inner\"\n"}, {2, "ball \xc3\xa9"}};  // quotes, a newline, UTF-8
  ball.minIsland = 0;
  ball.labelNames = dir.file("names.txt");
  ball.materials = {materialOf("box \"inner\"\n")};
  s.bodies.push_back(ball);

  SceneBody bunny;  // every setting at its default
  bunny.model = "bunny";
  s.bodies.push_back(bunny);

  SceneTool blade;
  blade.keys = {{0.0, {Vec3d(-0.1, 0.1, 0.0), Vec3d(0.1, 0.1, 0.0)}, false},
                {0.1, {Vec3d(-0.1, 0.1, -0.1), Vec3d(0.1, 0.1, -0.1)}, false},
                {0.1, {Vec3d(-0.1, 0.2, 0.0), Vec3d(0.1, 0.2, 0.0)}, true},
                {0.3, {Vec3d(-0.1, 0.2, 0.1), Vec3d(0.1, 1.0 / 3.0, 0.1)}, false}};
  s.tools.push_back(blade);
  SceneTool sphere;
  sphere.kind = ToolKind::Probe;
  sphere.radius = 0.01 / 3.0;
  sphere.friction = 0.6;
  sphere.keys = {{-0.5, {Vec3d(0.0, 0.3, 0.0), Vec3d(0.0, 0.3, 0.0)}, false},
                 {0.2, {Vec3d(0.0, 0.1, 0.1), Vec3d(0.0, 0.1, 0.1)}, true}};
  s.tools.push_back(sphere);
  SceneTool capsule;  // one key a sphere: the probe is a capsule throughout
  capsule.kind = ToolKind::Probe;
  capsule.radius = 0.012;
  capsule.keys = {{0.0, {Vec3d(0.0, -0.1, 0.0), Vec3d(0.0, -0.1, 0.0)}, false},
                  {0.25, {Vec3d(-0.03, -0.1, 0.0), Vec3d(0.03, -0.1, 0.0)}, false}};
  s.tools.push_back(capsule);

  Obstacle plane;
  plane.type = ObstacleType::Plane;
  plane.point = Vec3d(0.1, -1.0 / 3.0, 0.0);
  plane.normal = Vec3d(0.3, 0.7, -0.2).normalized();
  plane.friction = 0.0;
  s.obstacles.push_back(plane);
  Obstacle box;
  box.type = ObstacleType::Box;
  box.lo = Vec3d(-0.5, -0.1, -0.5);
  box.hi = Vec3d(0.5, 0.0, 0.1 / 3.0);
  s.obstacles.push_back(box);
  Obstacle ramp = meshObstacle(readMesh((kScenes / "meshes" / "ramp.obj").string()));
  ramp.path = (kScenes / "meshes" / "ramp.obj").string();
  ramp.friction = 0.2;
  s.obstacles.push_back(ramp);

  s.contact.stiffness = 1e5 / 3.0;
  s.contact.selfCollision = true;
  s.contact.friction = 0.45;
  return s;
}

TEST(SceneWriter, EverySettingReadsBackEqual) {
  TempDir dir;
  const Scene scene = everySetting(dir);
  const std::string text = sceneText(scene, dir.path());
  expectSameScene(scene, parseScene(text, "scene.json", dir.path()));
  // The sphere probe is written with "p", the capsule and the blade with "a" and "b".
  const auto tools = text.substr(text.find("\"tools\""));
  EXPECT_NE(tools.find("\"p\": [0.0, 0.3, 0.0]"), std::string::npos) << tools;
  EXPECT_NE(tools.find("\"a\": [0.0, -0.1, 0.0], \"b\": [0.0, -0.1, 0.0]"), std::string::npos)
      << tools;
  EXPECT_NE(tools.find("\"jump\": true"), std::string::npos);
  // Defaults that mean "not set" are left out.
  EXPECT_EQ(text.find("\"finest_level\": -1"), std::string::npos);
  // The text is valid as a file too.
  const std::string file = dir.write("scene.json", text);
  expectSameScene(scene, readScene(file));
}

TEST(SceneWriter, NumbersReadBackExactly) {
  const double numbers[] = {0.1,
                            1e-300,
                            1.0 / 3.0,
                            -2.0 / 3.0,
                            std::numeric_limits<double>::denorm_min(),
                            std::numeric_limits<double>::min(),
                            12.345678901234567,
                            -0.0,
                            std::nextafter(0.1, 1.0)};
  for (const double x : numbers) {
    SCOPED_TRACE(x);
    Scene s;
    s.bodies.push_back(bodyOf("bunny"));
    s.gravity = Vec3d(x, x, x);
    s.view = std::array<double, 2>{x, x};
    s.bodies[0].offset = Vec3d(x, -x, x);
    if (x > 0.0) s.timeStep = x;
    const Scene back = roundTrip(s, fs::current_path());
    expectVec(back.gravity, Vec3d(x, x, x), "gravity");
    EXPECT_TRUE(sameBits((*back.view)[0], x));
    if (x > 0.0) {
      EXPECT_TRUE(sameBits(back.timeStep, x));
    }
    EXPECT_TRUE(back.bodies[0].offset == s.bodies[0].offset);
  }
}

// ---- what cannot be written ----------------------------------------------------------------

TEST(SceneWriter, RefusesWhatTheFormatCannotHold) {
  Scene base;
  base.bodies.push_back(bodyOf("bunny"));

  Scene mesh = base;  // a mesh obstacle made in memory
  mesh.obstacles.push_back(meshObstacle(readMesh((kScenes / "meshes" / "ramp.obj").string())));
  EXPECT_NE(writeError(mesh).find("obstacles[0].path"), std::string::npos);

  Scene memory = base;  // a body of an in-memory volume
  memory.bodies.push_back(bodyOf("segmentation"));
  memory.bodies[1].volume = std::make_shared<const LabelVolume>(ballWithBox());
  EXPECT_NE(writeError(memory).find("bodies[1].model"), std::string::npos);

  Scene nan = base;
  nan.gravity.y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(writeError(nan).find("gravity[1]: must be finite"), std::string::npos);
  Scene inf = base;
  inf.tools.push_back(SceneTool{ToolKind::Probe, 0.01, -1.0,
                                {{std::numeric_limits<double>::infinity(), BladePose{}, false}}});
  EXPECT_NE(writeError(inf).find("tools[0].keys[0].t"), std::string::npos);

  Scene labels = base;  // labels on a model that is no volume
  labels.bodies[0].labels = {{1, "one"}};
  EXPECT_NE(writeError(labels).find("bodies[0].labels"), std::string::npos);

  Scene twice = base;
  twice.bodies[0].materials = {materialOf("default"), materialOf("default")};
  EXPECT_NE(writeError(twice).find("materials.default: is given twice"), std::string::npos);

  Scene candidates = base;
  candidates.contact.keepSelfCandidates = false;
  EXPECT_NE(writeError(candidates).find("contact"), std::string::npos);

  Scene utf8 = base;
  utf8.bodies[0].materials = {materialOf("bad \xff")};
  EXPECT_NE(writeError(utf8).find("UTF-8"), std::string::npos);
}

// ---- a body's volume in memory -------------------------------------------------------------

/// Expects two grids to be the same: placement, material and links per voxel, Hermite data.
void expectSameGrid(const VoxelGrid& a, const VoxelGrid& b) {
  ASSERT_EQ(a.dims(), b.dims());
  EXPECT_TRUE(a.origin() == b.origin());
  EXPECT_EQ(a.voxelSize(), b.voxelSize());
  EXPECT_EQ(a.materialNames(), b.materialNames());
  std::size_t occupied = 0, different = 0;
  for (std::size_t v = 0; v < a.voxelCount(); ++v) {
    occupied += a.occupied(v) ? 1 : 0;
    bool same = a.material(v) == b.material(v);
    for (int axis = 0; axis < 3; ++axis) same = same && a.connected(v, axis) == b.connected(v, axis);
    different += same ? 0 : 1;
  }
  EXPECT_GT(occupied, 100u);
  EXPECT_EQ(different, 0u);
  ASSERT_EQ(a.hermite().size(), b.hermite().size());
  EXPECT_GT(a.hermite().size(), 0u);
  for (const std::uint64_t link : a.hermite().sortedLinks()) {
    const Hermite* ha = a.hermite().find(link);
    const Hermite* hb = b.hermite().find(link);
    ASSERT_NE(hb, nullptr) << "link " << link;
    EXPECT_EQ(ha->t, hb->t) << "link " << link;
    for (int c = 0; c < 3; ++c) EXPECT_EQ(ha->n[c], hb->n[c]) << "link " << link;
  }
}

TEST(SceneWriter, VolumeInMemoryGivesTheGridOfItsFile) {
  TempDir dir;
  const LabelVolume volume = ballWithBox();
  writeNrrd(volume, dir.file("ball.nrrd"));

  // Two bodies: chosen labels in an order of their own, and every label by default names.
  Scene fromFile;
  fromFile.source = "scene.json";
  SceneBody chosen;
  chosen.model = dir.file("ball.nrrd");
  chosen.resolution = 22;
  chosen.labels = {{7, "box"}, {2, "ball"}};
  chosen.minIsland = 3;
  chosen.offset = Vec3d(0.01, -0.02, 1.0 / 30.0);
  fromFile.bodies.push_back(chosen);
  SceneBody all;
  all.model = dir.file("ball.nrrd");
  all.resolution = 18;
  all.materials = {materialOf("label_7")};
  fromFile.bodies.push_back(all);

  Scene inMemory = fromFile;
  for (SceneBody& b : inMemory.bodies) {
    b.model = "segmentation";
    b.volume = std::make_shared<const LabelVolume>(volume);
  }

  for (std::size_t i = 0; i < 2; ++i) {
    const Model a = loadBodyModel(inMemory, i), b = loadBodyModel(fromFile, i);
    EXPECT_EQ(a.defaultResolution, b.defaultResolution);
    EXPECT_EQ(a.materialNames(), b.materialNames());
    EXPECT_EQ(a.minIsland, b.minIsland);
  }
  const std::vector<VoxelGrid> memoryGrids = voxelizeSceneBodies(inMemory, false);
  const std::vector<VoxelGrid> fileGrids = voxelizeSceneBodies(fromFile, false);
  ASSERT_EQ(memoryGrids.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE("bodies[" + std::to_string(i) + "]");
    expectSameGrid(memoryGrids[i], fileGrids[i]);
  }
  EXPECT_EQ(memoryGrids[0].materialNames(), (std::vector<std::string>{"box", "ball"}));
  EXPECT_EQ(memoryGrids[1].materialNames(), (std::vector<std::string>{"label_2", "label_7"}));
}

TEST(SceneWriter, VolumeInMemoryIsCheckedAsAFileIs) {
  Scene scene;
  scene.source = "scene.json";
  SceneBody body = bodyOf("segmentation");
  LabelVolume volume = ballWithBox();
  body.labels = {{5, "missing"}};
  body.volume = std::make_shared<const LabelVolume>(volume);
  scene.bodies.push_back(body);
  try {
    (void)loadBodyModel(scene, 0);
    ADD_FAILURE() << "a label the volume lacks was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scene.json: bodies[0].labels"), std::string::npos)
        << e.what();
  }
  volume.index.pop_back();  // an index that does not match the dims
  scene.bodies[0].labels.clear();
  scene.bodies[0].volume = std::make_shared<const LabelVolume>(volume);
  try {
    (void)loadBodyModel(scene, 0);
    ADD_FAILURE() << "a short index was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scene.json: bodies[0].model"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace voxcut
