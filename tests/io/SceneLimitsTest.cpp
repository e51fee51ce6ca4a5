// Scene input with limits: regular files of bounded size, bounded nesting, linear parse time,
// coordinates and parameters within their ranges, bodies that have voxels, one-line messages.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <ctime>
#include <filesystem>
#include <string>

#include "SceneText.h"
#include "TempDir.h"
#include "voxcut/core/Error.h"
#include "voxcut/cutting/Blade.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/Scene.h"

namespace voxcut {
namespace {

namespace fs = std::filesystem;
using test::expectError;
using test::parse;
using test::parseError;
using test::TempDir;
using test::withBody;
using test::withTop;

TEST(SceneLimits, ControlCharactersInKeysStayOnOneLine) {
  // Keys are decoded JSON strings: escapes become newlines and other control characters,
  // which messages write escaped again.
  expectError(withTop(R"("a\nb": 1, "a\nb": 2)"), R"(key "a\nb" appears twice in one object)");
  expectError(withTop(R"("time\u001bstep": 1)"), R"(time\u001bstep: unknown key)");
  const Scene scene = parse(withBody(R"("materials": {"x\r\ny": {}})"));
  try {
    (void)loadBodyModel(scene, 0);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(R"(scene.json: bodies[0].materials.x\r\ny: )", 0), 0u)
        << e.what();
  }
}

/// The message of the InputError that readScene(path) throws; fails the test if none is.
std::string readError(const std::string& path) {
  try {
    (void)readScene(path);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError for " << path;
  return {};
}

TEST(SceneLimits, OnlyRegularFiles) {
  const TempDir dir;
  // A device that never ends, a FIFO nobody writes to: rejected without being opened (opening
  // the FIFO would block, reading /dev/zero would fill the memory).
  EXPECT_EQ(readError("/dev/zero"),
            "/dev/zero: not a regular file (a device, FIFO or socket); a scene is read from a "
            "regular file");
  const std::string fifo = dir.file("scene.fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_EQ(readError(fifo).rfind(fifo + ": not a regular file", 0), 0u);
  EXPECT_EQ(readError(dir.path().string()),
            dir.path().string() + ": is a directory, not a scene file");
  // A link to a regular file is read as the file.
  const std::string real = dir.write("real.json", withTop(R"("frames": 2)"));
  fs::create_symlink(real, dir.file("link.json"));
  EXPECT_EQ(readScene(dir.file("link.json")).frames, 2);
}

TEST(SceneLimits, OversizedFile) {
  const TempDir dir;
  // A sparse file one byte over the limit: refused on its size, before any byte is read.
  const std::string big = dir.write("big.json", "");
  fs::resize_file(big, kMaxSceneFileBytes + 1);
  EXPECT_EQ(readError(big), big + ": larger than 64 MiB, the limit of a scene file");
  // Exactly at the limit is read (here: a valid scene padded with spaces).
  std::string text = withTop(R"("frames": 3)");
  text.resize(kMaxSceneFileBytes, ' ');
  const std::string full = dir.write("full.json", text);
  EXPECT_EQ(readScene(full).frames, 3);
}

/// Processor time of this process since `start` (seconds): unlike wall time, it does not
/// grow when other processes load the machine, so the bounds below are not flaky.
double cpuSecondsSince(std::clock_t start) {
  return static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
}

TEST(SceneLimits, DeepNestingIsOneErrorQuickly) {
  const std::clock_t start = std::clock();
  // Unclosed and closed, at the top and inside a value: the depth is checked before parsing.
  EXPECT_EQ(parseError(std::string(100000, '[')),
            "scene.json: JSON nesting too deep at line 1, column 65: more than 64 lists and "
            "objects inside one another");
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  EXPECT_NE(parseError(deep).find("JSON nesting too deep at line 1, column 65"), std::string::npos);
  std::string objects;
  for (int i = 0; i < 50000; ++i) objects += "{\"a\":";
  const std::string msg =
      parseError("{\n\"bodies\": " + objects + "1" + std::string(50000, '}') + "}");
  EXPECT_NE(msg.find("nesting too deep at line 2, column 326: more than 64"), std::string::npos)
      << msg;
  EXPECT_LT(cpuSecondsSince(start), 5.0);
  // Brackets inside strings (escaped quotes included) do not count.
  EXPECT_EQ(parse(withTop("\"description\": \"\\\"" + std::string(1000, '[') + "\"")).bodies.size(),
            1u);
  // The deepest a scene needs (7) is far inside the limit; 64 levels pass the depth check.
  const std::string at64 = std::string(63, '[') + std::string(63, ']');
  EXPECT_NE(parseError(withTop("\"description\": " + at64)).find("description: must be a string"),
            std::string::npos);
}

TEST(SceneLimits, LongListsParseInLinearTime) {
  // 100,000 fixed boxes in one list and 50,000 materials in one object: a fraction of a
  // second of processor time in a release build, a few seconds in a debug or sanitizer build;
  // a parser whose time grows with the square of a container's size takes ten seconds or more.
  std::string fixed;
  for (int i = 0; i < 100000; ++i)
    fixed += std::string(i ? "," : "") + R"({"box": [[0, 0, 0], [0.01, 0.01, 0.01]]})";
  std::string materials;
  for (int i = 0; i < 50000; ++i)
    materials += std::string(i ? "," : "") + "\"m" + std::to_string(i) + "\": {\"density\": 900}";
  const std::string text =
      withBody("\"fixed\": [" + fixed + "], \"materials\": {" + materials + "}");
  const std::clock_t start = std::clock();
  const Scene scene = parse(text);
  const double seconds = cpuSecondsSince(start);
  EXPECT_EQ(scene.bodies[0].fixed.size(), 100000u);
  ASSERT_EQ(scene.bodies[0].materials.size(), 50000u);
  EXPECT_EQ(scene.bodies[0].materials[49999].name, "m49999");  // the order written is kept
  EXPECT_LT(seconds, 5.0) << text.size() << " bytes";
  // A repeated key is still found among 50,000.
  EXPECT_NE(parseError(withBody("\"materials\": {" + materials + ", \"m5\": {}}"))
                .find(R"(key "m5" appears twice in one object)"),
            std::string::npos);
}

TEST(SceneLimits, CoordinatesOutOfRangeNameTheKey) {
  expectError(withBody(R"("offset": [1e308, 0, 0])"),
              "bodies[0].offset[0]: must be in [-1e6, 1e6] m, got 1e+308");
  expectError(withBody(R"("fixed": [{"box": [[0, 0, 0], [1, 1500000, 1]]}])"),
              "bodies[0].fixed[0].box[1][1]: must be in [-1e6, 1e6] m, got 1500000");
  expectError(withBody(R"("fixed": [{"box": [[-1.5e6, 0, 0], [1, 1, 1]]}])"),
              "bodies[0].fixed[0].box[0][0]: must be in [-1e6, 1e6] m, got -1500000");
  const std::string blade =
      R"("tools": [{"type": "blade", "keys": [{"t": 0, "a": [0, 0, 0], "b": )";
  expectError(withTop(blade + "[1e155, 0, 0]}]}]"),
              "tools[0].keys[0].b[0]: must be in [-1e6, 1e6] m, got 1e+155");
  expectError(withTop(blade + "[0, 0, -1e308]}]}]"),
              "tools[0].keys[0].b[2]: must be in [-1e6, 1e6] m, got -1e+308");
  // The bounds themselves are inside.
  const Scene edge = parse(withTop(blade + "[1e6, -1e6, 1e6]}]}]"));
  EXPECT_EQ(edge.tools[0].keys[0].pose.b, Vec3d(1e6, -1e6, 1e6));
  // A primitive size is a length in [1e-6, 1e6] m.
  expectError(R"({"bodies": [{"model": "box:2e6,1,1"}]})",
              "bodies[0].model: bad model 'box:2e6,1,1': sizes must be in [1e-6, 1e6] m, got "
              "'2e6'");
  expectError(R"({"bodies": [{"model": "sphere:1e-300"}]})",
              "bodies[0].model: bad model 'sphere:1e-300': sizes must be in [1e-6, 1e6] m");
  expectError(R"({"bodies": [{"model": "sphere:1e155"}]})", "bodies[0].model: bad model");
}

TEST(SceneLimits, PhysicalParametersOutOfRange) {
  expectError(withTop(R"("time_step": 1e4)"), "time_step: must be <= 1e3 s, got 10000");
  expectError(withTop(R"("gravity": [0, -1e300, 0])"),
              "gravity[1]: must be in [-1e4, 1e4] m/s^2, got -1e+300");
  expectError(withTop(R"("solver": {"tolerance": 2})"), "solver.tolerance: must be <= 1, got 2");
  expectError(withBody(R"("materials": {"default": {"young_modulus": 1e300}})"),
              "bodies[0].materials.default.young_modulus: must be <= 1e12 Pa, got 1e+300");
  expectError(withBody(R"("materials": {"default": {"density": 1e6}})"),
              "bodies[0].materials.default.density: must be <= 1e5 kg/m^3, got 1000000");
  expectError(withBody(R"("materials": {"default": {"damping": [1e7, 0]}})"),
              "bodies[0].materials.default.damping[0]: must be <= 1e6 1/s, got 10000000");
  expectError(withTop(R"("tools": [{"type": "blade", "keys": [{"t": 1e10, "a": [0, 0, 0],
                                                               "b": [1, 0, 0]}]}])"),
              "tools[0].keys[0].t: must be in [-1e9, 1e9] s, got 10000000000");
}

TEST(SceneLimitsDeathTest, BladeOutsideTheCoordinateRangeIsAProgrammingError) {
  // Scenes built in code skip the reader's checks: the library asserts the range before any
  // predicate sees such a blade.
  SceneTool tool;
  tool.keys.push_back({0.0, {Vec3d(0, 0, 0), Vec3d(1e155, 0, 0)}});
  EXPECT_DEATH((void)bladePoseAt(tool, 0.0), "outside the coordinate range");
  const BladePose near{Vec3d(0, 0, 0), Vec3d(1, 0, 0)}, far{Vec3d(0, 1, 0), Vec3d(1e308, 1, 0)};
  EXPECT_DEATH((void)makeSweep(near, far, 0), "outside the coordinate range");
}

TEST(SceneLimits, OffsetMovingTheModelOutOfRange) {
  // Each number is in range, but the bunny moved by it reaches past 1e6 m.
  const Scene scene = parse(withBody(R"("offset": [1e6, 0, 0])"));
  try {
    (void)loadBodyModel(scene, 0);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind("scene.json: bodies[0]: the model, moved by offset, reaches outside the "
                        "coordinate range [-1e6, 1e6] m (a vertex at ",
                        0),
              0u)
        << msg;
  }
}

TEST(SceneLimits, BodyThatVoxelizesToNothing) {
  // A flat square encloses no volume: the body would have no voxels to simulate.
  const TempDir dir;
  const std::string flat =
      dir.write("flat.obj", "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0.1 0.1 0\nf 1 2 3\nf 2 4 3\n");
  const std::string path =
      dir.write("scene.json", R"({"bodies": [{"model": "box:0.1,0.1,0.1", "resolution": 8},
                                  {"model": "flat.obj", "resolution": 8}]})");
  const Scene scene = readScene(path);
  try {
    (void)voxelizeSceneBodies(scene, false);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 (path + ": bodies[1] (model '" + fs::path(flat).lexically_normal().string() +
                  "'): voxelizes to no voxels at resolution 8 (voxel size 0.0167 m): its "
                  "surface encloses no voxel centre (an open or flat surface, or a model "
                  "thinner than a voxel; try a finer resolution)")
                     .c_str());
  }
}

}  // namespace
}  // namespace voxcut
