// A body built from a label volume, through the world API and through a scene: its labels are
// its materials (with the file's colours), a blade cuts it apart like any body, and the result
// is the same at one and two threads.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/io/VolumeReader.h"
#include "voxcut/sim/World.h"
#include "voxcut/voxel/LabelResample.h"

namespace voxcut {
namespace {

namespace fs = std::filesystem;

// A 30 x 20 x 20 raw NRRD of 2 mm voxels: a slab of label 1 (6 cm x 4 cm x 4 cm, less its
// padding) holding a sphere of label 2 near its +x end; two segments named and coloured as
// 3D Slicer writes them.
fs::path writeSlab(const fs::path& dir) {
  const int nx = 30, ny = 20, nz = 20;
  std::string data(static_cast<std::size_t>(nx * ny * nz), '\0');
  for (int k = 2; k < nz - 2; ++k)
    for (int j = 2; j < ny - 2; ++j)
      for (int i = 2; i < nx - 2; ++i) {
        const double dx = i - 21.5, dy = j - 9.5, dz = k - 9.5;
        data[static_cast<std::size_t>(i + nx * (j + ny * k))] =
            dx * dx + dy * dy + dz * dz < 16 ? '\2' : '\1';
      }
  const fs::path path = dir / "slab.seg.nrrd";
  std::ofstream out(path, std::ios::binary);
  out << "NRRD0004\ntype: uint8\ndimension: 3\nspace: right-anterior-superior\nsizes: " << nx
      << " " << ny << " " << nz
      << "\nspace directions: (2,0,0) (0,2,0) (0,0,2)\nspace origin: (0,0,0)\nencoding: raw\n"
         "Segment0_ID:=organ\nSegment0_Name:=organ\nSegment0_Color:=0.8 0.3 0.2\n"
         "Segment0_LabelValue:=1\nSegment0_Layer:=0\n"
         "Segment1_ID:=lesion\nSegment1_Name:=lesion\nSegment1_Color:=0.9 0.9 0.2\n"
         "Segment1_LabelValue:=2\nSegment1_Layer:=0\n\n";
  out << data;
  return path;
}

class LabelVolumeWorld : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("voxcut_labelworld_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    volume_ = writeSlab(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_, volume_;
};

TEST_F(LabelVolumeWorld, ApiBodyCarriesNamesAndColours) {
  const LabelVolume vol = readLabelVolume(volume_.string());
  LabelResampleParams params;
  params.resolution.resolution = 32;
  World world;
  const BodyId body = world.addBody(resampleLabels(vol, params));
  const BodyInfo info = world.bodyInfo(body);
  EXPECT_EQ(info.materialNames, (std::vector<std::string>{"organ", "lesion"}));
  ASSERT_EQ(info.materialColours.size(), 2u);
  ASSERT_TRUE(info.materialColours[1].has_value());
  EXPECT_FLOAT_EQ((*info.materialColours[1])[2], 0.2f);
  EXPECT_EQ(world.pieces(body), 1);
  EXPECT_EQ(world.selfCheck(body), "");
}

// A scene body from the volume, only the organ's label chosen, its -x end fixed; a blade
// crosses the whole slab at x = 4 cm and the free end falls away as its own piece.
std::string sceneText(const fs::path& volume) {
  return R"({"time_step": 0.004, "gravity": [0, 0, -9.81], "frames": 40,
    "bodies": [{"model": ")" +
         volume.string() + R"(", "resolution": 32, "element_level": 2,
       "labels": {"1": "organ", "2": "lesion"},
       "materials": {"organ": {"young_modulus": 2e5, "poisson_ratio": 0.3, "density": 1000},
                     "lesion": {"young_modulus": 6e5, "poisson_ratio": 0.3, "density": 1000}},
       "fixed": [{"box": [[-1, -1, -1], [0.012, 1, 1]]}]}],
    "tools": [{"type": "blade", "keys": [
       {"t": 0.0, "a": [0.04, -0.01, 0.05], "b": [0.04, 0.05, 0.05]},
       {"t": 0.08, "a": [0.04, -0.01, -0.01], "b": [0.04, 0.05, -0.01]}]}]})";
}

std::vector<Vec3d> runScene(const std::string& text, const fs::path& dir, int& pieces,
                            std::string& check) {
  const Scene scene = parseScene(text, "slab.json", dir);
  World world = World::fromScene(scene, voxelizeSceneBodies(scene));
  for (int f = 0; f < 40; ++f) world.step();
  const BodyId body = world.bodies().at(0);
  pieces = world.pieces(body);
  check = world.selfCheck(body);
  const SurfaceView s = world.surface(body);
  return {s.positions.begin(), s.positions.end()};
}

TEST_F(LabelVolumeWorld, SceneBodyIsCutApartTheSameAtAnyThreadCount) {
  const std::string text = sceneText(volume_);
  int pieces2 = 0, pieces1 = 0;
  std::string check2, check1;
  const std::vector<Vec3d> two = runScene(text, dir_, pieces2, check2);
  std::vector<Vec3d> one;
  {
    const ThreadLimit limit(1);
    one = runScene(text, dir_, pieces1, check1);
  }
  EXPECT_GE(pieces2, 2);
  EXPECT_EQ(check2, "");
  EXPECT_EQ(pieces1, pieces2);
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t v = 0; v < one.size(); ++v) ASSERT_EQ(one[v], two[v]) << v;
}

TEST_F(LabelVolumeWorld, SceneLabelsAreChecked) {
  std::string text = sceneText(volume_);
  text.replace(text.find(R"("1": "organ")"), 12, R"("7": "organ")");
  try {
    (void)voxelizeSceneBodies(parseScene(text, "slab.json", dir_));
    ADD_FAILURE() << "accepted label 7";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("label 7 is not in the volume"), std::string::npos)
        << e.what();
  }
}

// The shipped resection scene on the real CT: the box around the lesion comes off as its own
// piece, every surface stays closed, and one and two threads give the same cut and positions.
struct ResectionResult {
  std::uint64_t hash = 0;
  int pieces = 0;
  std::string check;
  std::vector<Vec3d> positions;
};

ResectionResult runScene(const std::string& name) {
  const Scene scene = readScene(std::string(VOXCUT_SOURCE_DIR) + "/scenes/" + name);
  World world = World::fromScene(scene, voxelizeSceneBodies(scene));
  for (int f = 0; f < scene.frames.value_or(100); ++f) world.step();
  const BodyId body = world.bodies().at(0);
  const SurfaceView s = world.surface(body);
  return {world.cutSetHash(), world.pieces(body), world.selfCheck(body),
          {s.positions.begin(), s.positions.end()}};
}

// Runs the scene at two threads and at one, expects the same cut and positions, and returns
// the two-thread run.
ResectionResult runAtOneAndTwoThreads(const std::string& name) {
  const ResectionResult two = runScene(name);
  ResectionResult one;
  {
    const ThreadLimit limit(1);
    one = runScene(name);
  }
  EXPECT_EQ(one.hash, two.hash);
  EXPECT_EQ(one.positions, two.positions);
  return two;
}

TEST(LabelVolumeScene, CtLiverResectionSeparatesTheLesion) {
  const ResectionResult r = runAtOneAndTwoThreads("ct-liver-resection.json");
  EXPECT_GE(r.pieces, 2);
  EXPECT_EQ(r.check, "");
}

// The atlas scene (Debian's mricron-data): the sulcus is cut, the brain stays one piece with
// closed surfaces, the same at one and two threads.
TEST(LabelVolumeScene, AtlasLobeCutsAlongTheSulcus) {
  if (!fs::exists("/usr/share/mricron/templates/aal.nii.gz"))
    GTEST_SKIP() << "the AAL atlas (Debian package mricron-data) is not installed";
  const ResectionResult r = runAtOneAndTwoThreads("atlas-lobe.json");
  EXPECT_EQ(r.pieces, 1);
  EXPECT_EQ(r.check, "");
}

}  // namespace
}  // namespace voxcut
