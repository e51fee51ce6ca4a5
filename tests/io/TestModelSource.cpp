#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "CubeFiles.h"
#include "TempDir.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

using test::TempDir;

/// The message of the InputError thrown by loadModel(spec); fails the test if none is.
std::string loadError(const std::string& spec) {
  try {
    (void)loadModel(spec);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError for '" << spec << "'";
  return {};
}

std::string materialsError(const std::vector<std::pair<std::string, std::string>>& pairs) {
  try {
    (void)loadMaterials(pairs);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError";
  return {};
}

TEST(ModelSource, Bunny) {
  const Model model = loadModel("bunny");
  EXPECT_EQ(model.name, "bunny");
  EXPECT_EQ(model.defaultResolution, 101);
  ASSERT_EQ(model.materials.size(), 1u);
  EXPECT_EQ(model.materials[0].name, "default");
  EXPECT_EQ(model.materials[0].mesh.faces.size(), 3674u);
}

TEST(ModelSource, LiverAndStarfish) {
  const Model liver = loadModel("liver");
  EXPECT_EQ(liver.defaultResolution, 100);
  ASSERT_EQ(liver.materials.size(), 2u);
  EXPECT_EQ(liver.materials[0].name, "liver");
  EXPECT_EQ(liver.materials[1].name, "tumor");
  const Model starfish = loadModel("starfish");
  EXPECT_EQ(starfish.defaultResolution, 180);
  ASSERT_EQ(starfish.materials.size(), 1u);
  EXPECT_EQ(starfish.materials[0].name, "default");
}

TEST(ModelSource, EveryBuiltinLoads) {
  const std::vector<std::string> expected = {"bunny", "liver", "starfish"};
  EXPECT_EQ(builtinModelNames(), expected);
  for (const auto& name : builtinModelNames()) {
    const Model model = loadModel(name);
    EXPECT_EQ(model.name, name);
    ASSERT_FALSE(model.materials.empty());
    for (const auto& m : model.materials) EXPECT_FALSE(m.mesh.faces.empty()) << name;
  }
}

TEST(ModelSource, Box) {
  for (const std::string spec : {"box:0.1,0.2,0.3", "box: 0.1 , 0.2,0.3 "}) {
    const Model model = loadModel(spec);
    EXPECT_EQ(model.defaultResolution, 101);
    ASSERT_EQ(model.materials.size(), 1u);
    EXPECT_EQ(model.materials[0].name, "default");
    const auto [lo, hi] = model.materials[0].mesh.bounds();
    EXPECT_NEAR(hi.x() - lo.x(), 0.1, 1e-12);
    EXPECT_NEAR(hi.y() - lo.y(), 0.2, 1e-12);
    EXPECT_NEAR(hi.z() - lo.z(), 0.3, 1e-12);
    EXPECT_NEAR(model.materials[0].mesh.signedVolume(), 0.006, 1e-12);
  }
}

TEST(ModelSource, Sphere) {
  const Model model = loadModel("sphere:0.05");
  EXPECT_EQ(model.defaultResolution, 101);
  ASSERT_EQ(model.materials.size(), 1u);
  EXPECT_EQ(model.materials[0].name, "default");
  const TriangleMesh& mesh = model.materials[0].mesh;
  EXPECT_EQ(mesh.faces.size(), 20u * 1024u);  // 5 subdivisions
  for (const Vec3d& v : mesh.vertices) EXPECT_NEAR(v.norm(), 0.05, 1e-9);
}

TEST(ModelSource, MeshFile) {
  const TempDir dir;
  const std::string path = dir.write("kidney.obj", test::cubeObj());
  const Model model = loadModel(path);
  EXPECT_EQ(model.name, "kidney");
  EXPECT_EQ(model.defaultResolution, 101);
  ASSERT_EQ(model.materials.size(), 1u);
  EXPECT_EQ(model.materials[0].name, "kidney");
  test::expectCube(model.materials[0].mesh);
}

TEST(ModelSource, MeshFileWithColonInItsName) {
  const TempDir dir;
  const std::string path = dir.write("scan:2024.stl", test::cubeBinaryStl());
  test::expectCube(loadModel(path).materials.at(0).mesh);
}

TEST(ModelSource, BadFileReportsReadError) {
  const TempDir dir;
  const std::string empty = dir.write("empty.obj", "");
  EXPECT_NE(loadError(empty).find("is empty"), std::string::npos);
  EXPECT_NE(loadError(dir.path().string()).find("is a directory"), std::string::npos);
}

TEST(ModelSource, BadPrimitive) {
  for (const std::string spec :
       {"box:",           "box:1",      "box:1,2",     "box:1,2,3,4", "box:a,1,1",
        "box:1,,1",       "box:0,1,1",  "box:-1,1,1",  "box:inf,1,1", "box:nan,1,1",
        "box:1e400,1,1",  "box:1x,1,1", "sphere:",     "sphere:0",    "sphere:-0.1",
        "sphere:0.1,0.2", "sphere:abc", "sphere:+inf", "box:1,1,2e6", "sphere:1e155",
        "sphere:1.5e6"}) {
    const std::string message = loadError(spec);
    EXPECT_NE(message.find("'" + spec + "'"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  EXPECT_NE(loadError("box").find("box:LX,LY,LZ"), std::string::npos);
  EXPECT_NE(loadError("sphere").find("sphere:R"), std::string::npos);
}

TEST(ModelSource, UnknownModel) {
  EXPECT_EQ(loadError("teapot"),
            "unknown model 'teapot': not a built-in (bunny, liver, starfish, box:LX,LY,LZ, "
            "sphere:R) and no such file");
  EXPECT_NE(loadError("/no/such/dir/mesh.obj").find("unknown model '/no/such/dir/mesh.obj'"),
            std::string::npos);
  EXPECT_NE(loadError("cube:1,1,1").find("unknown model 'cube:1,1,1'"), std::string::npos);
  EXPECT_NE(loadError("").find("unknown model ''"), std::string::npos);
  EXPECT_NE(loadError("Bunny").find("unknown model 'Bunny'"), std::string::npos);
}

TEST(ModelSource, Materials) {
  const TempDir dir;
  const std::string path = dir.write("organ.obj", test::cubeObj());
  const Model model = loadMaterials(
      {{"skin", "sphere:0.1"}, {"bone", "box:0.05,0.05,0.05"}, {"organ", path}, {"fur", "bunny"}});
  EXPECT_EQ(model.name, "skin+bone+organ+fur");
  EXPECT_EQ(model.defaultResolution, 101);
  ASSERT_EQ(model.materials.size(), 4u);
  EXPECT_EQ(model.materials[0].name, "skin");
  EXPECT_EQ(model.materials[1].name, "bone");
  EXPECT_EQ(model.materials[2].name, "organ");
  EXPECT_EQ(model.materials[3].name, "fur");
  EXPECT_EQ(model.materials[1].mesh.faces.size(), 12u);
  test::expectCube(model.materials[2].mesh);
  EXPECT_EQ(model.materials[3].mesh.faces.size(), 3674u);

  EXPECT_EQ(loadMaterials({{"a", "starfish"}, {"b", "box:1,1,1"}}).defaultResolution, 180);
}

TEST(ModelSource, MaterialsErrors) {
  EXPECT_NE(materialsError({}).find("no materials"), std::string::npos);
  EXPECT_NE(materialsError({{"", "sphere:1"}}).find("empty name"), std::string::npos);
  EXPECT_NE(materialsError({{"a", "sphere:1"}, {"a", "box:1,1,1"}}).find("'a' is given twice"),
            std::string::npos);
  EXPECT_NE(materialsError({{"organ", "liver"}}).find("2 materials"), std::string::npos);
  EXPECT_NE(materialsError({{"a", "sphere:0"}}).find("'sphere:0'"), std::string::npos);
  EXPECT_NE(materialsError({{"a", "nosuch"}}).find("unknown model 'nosuch'"), std::string::npos);
}

TEST(ModelSource, PrimitiveSizesUpToTheCoordinateRange) {
  EXPECT_NE(loadError("box:1,1,2e6").find("sizes must be in [1e-6, 1e6] m, got '2e6'"),
            std::string::npos);
  EXPECT_NE(loadError("sphere:1e-7").find("sizes must be in [1e-6, 1e6] m, got '1e-7'"),
            std::string::npos);
  EXPECT_NO_THROW((void)loadModel("box:1e6,1e-6,1"));
}

TEST(ModelSource, ModelWithoutVoxelsIsAnError) {
  VoxelizeParams params;
  params.resolution.resolution = 12;
  params.threaded = false;
  // A flat square encloses no volume; a closed box does.
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  flat.faces = {{0, 1, 2}, {1, 3, 2}};
  const VoxelGrid empty = voxelize({{"default", flat}}, params);
  try {
    requireVoxels(empty, "model 'flat.obj'");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(
        std::string(e.what()).rfind(
            "model 'flat.obj': voxelizes to no voxels at resolution 12 (voxel size 0.1 m): ", 0),
        0u)
        << e.what();
  }
  const Model box = loadModel("box:1,1,1");
  EXPECT_NO_THROW(requireVoxels(voxelize(box.materials, params), "model 'box'"));
}

}  // namespace
}  // namespace voxcut
