// `voxcut info` and `voxcut surface` on a real segmented CT (data/volumes/ct-liver.nrrd): the
// known volumes of its labels, the lesion joined to the liver through interface links, the
// same model at any thread count, and the label options' errors.

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "CliProcess.h"

namespace voxcut::cli {
namespace {

using json = nlohmann::json;

const std::string kCtLiver = std::string(VOXCUT_SOURCE_DIR) + "/data/volumes/ct-liver.nrrd";

json infoOf(const std::vector<std::string>& extra) {
  std::vector<std::string> args{"info", kCtLiver, "--json"};
  args.insert(args.end(), extra.begin(), extra.end());
  const ProcessResult r = runVoxcut(args);
  EXPECT_EQ(r.status, 0) << describe(args, r);
  return json::parse(r.out);
}

// The file's voxel volume (metres^3): 0.617188 x 0.617188 x 1.33333 mm.
constexpr double kVoxel = 0.617188e-3 * 0.617188e-3 * 1.33333e-3;

TEST(LabelVolumeCli, CtLiverVolumesAtResolution100) {
  const json j = infoOf({"--resolution", "100", "--labels", "255=liver,85=tumor"});
  const json& v = j["volume_per_material_m3"];
  EXPECT_NEAR(v["liver"].get<double>() / (3160496 * kVoxel), 1.0, 0.02);
  EXPECT_NEAR(v["tumor"].get<double>() / (17702 * kVoxel), 1.0, 0.05);
  // The lesion sits on the liver: one piece, joined through interface links.
  EXPECT_EQ(j["pieces"].get<int>(), 1);
  EXPECT_GT(j["interface_links"].get<long>(), 0);
  EXPECT_TRUE(j["surface_closed"].get<bool>());
  EXPECT_EQ(j["grid"][0].get<int>(), 100);
  // The volume as read.
  const json& lv = j["label_volume"];
  EXPECT_EQ(lv["dims"], json({438, 353, 165}));
  EXPECT_NEAR(lv["spacing"][2].get<double>(), 1.33333e-3, 1e-9);
  EXPECT_EQ(lv["labels"].size(), 4u);
}

TEST(LabelVolumeCli, SameModelAtOneAndTwoThreads) {
  json a = infoOf({"--resolution", "60", "--threads", "1"});
  json b = infoOf({"--resolution", "60", "--threads", "2"});
  for (json* j : {&a, &b}) {
    j->erase("timings_ms");
    j->erase("threads");
  }
  EXPECT_EQ(a, b);
  // Every label by default, named label_N.
  EXPECT_TRUE(a["voxels_per_material"].contains("label_127"));
}

TEST(LabelVolumeCli, LabelErrorsAreOneLine) {
  for (const std::vector<std::string>& extra :
       {std::vector<std::string>{"--labels", "255=liver,12=x"},
        std::vector<std::string>{"--labels", "255=liver,85=liver"},
        std::vector<std::string>{"--labels", "255"},
        std::vector<std::string>{"--labels", "abc=liver"},
        std::vector<std::string>{"--min-island", "-1"}}) {
    std::vector<std::string> args{"info", kCtLiver, "--resolution", "40"};
    args.insert(args.end(), extra.begin(), extra.end());
    const ProcessResult r = runVoxcut(args);
    EXPECT_EQ(r.status, 2) << describe(args, r);
    EXPECT_EQ(r.err.find("voxcut: error: "), 0u) << describe(args, r);
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << describe(args, r);
  }
}

// `surface` keeps the materials: OBJ groups in one file, or one closed file per material.
TEST(LabelVolumeCli, SurfaceByMaterial) {
  const std::string dir = ::testing::TempDir() + "voxcut_label_surface";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::vector<std::string> base{"surface", kCtLiver, "--resolution", "40", "--labels",
                                      "255=liver,127=kidney"};
  std::vector<std::string> args = base;
  args.insert(args.end(), {"-o", dir + "/all.obj"});
  ProcessResult r = runVoxcut(args);
  ASSERT_EQ(r.status, 0) << describe(args, r);
  const std::string all = readText(dir + "/all.obj");
  EXPECT_NE(all.find("\ng liver\n"), std::string::npos);
  EXPECT_NE(all.find("\ng kidney\n"), std::string::npos);
  args = base;
  args.insert(args.end(), {"-o", dir + "/part.obj", "--per-material"});
  r = runVoxcut(args);
  ASSERT_EQ(r.status, 0) << describe(args, r);
  for (const char* name : {"/part_liver.obj", "/part_kidney.obj"}) {
    const std::string text = readText(dir + name);
    EXPECT_NE(text.find("\nf "), std::string::npos) << name;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/part.obj"));
  std::filesystem::remove_all(dir);
}

TEST(LabelVolumeCli, LabelOptionsNeedAVolume) {
  const std::vector<std::string> args{"info", "bunny", "--labels", "1=a"};
  const ProcessResult r = runVoxcut(args);
  EXPECT_EQ(r.status, 2) << describe(args, r);
  EXPECT_NE(r.err.find("label volume"), std::string::npos) << describe(args, r);
}

}  // namespace
}  // namespace voxcut::cli
