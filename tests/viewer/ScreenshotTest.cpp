// voxcut-view headless: pictures of scenes taken with no window shown, checked by their pixels.
// Needs a display (scripts/test.sh runs the tests under Xvfb with Mesa's software renderer);
// without one these tests are skipped.
#include <gtest/gtest.h>
#include <stb_image.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "Command.h"

namespace {

namespace fs = std::filesystem;

bool haveDisplay() {
  const char* d = std::getenv("DISPLAY");
  return d != nullptr && *d != '\0';
}

struct Picture {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;
  [[nodiscard]] const unsigned char* at(int x, int y) const {
    return &rgb[3 * (static_cast<std::size_t>(y) * width + x)];
  }
};

Picture load(const std::string& path) {
  Picture p;
  int channels = 0;
  unsigned char* data = stbi_load(path.c_str(), &p.width, &p.height, &channels, 3);
  if (data == nullptr) return p;
  p.rgb.assign(data, data + 3 * static_cast<std::size_t>(p.width) * p.height);
  stbi_image_free(data);
  return p;
}

/// The environment of a child that draws. Under AddressSanitizer, leak checking stays off:
/// Mesa's driver keeps what it allocates for a context to the end, reported from a module
/// unloaded by then (nothing to name in a suppression). Under ThreadSanitizer, reports stay
/// off: the OpenGL and X libraries are not instrumented, and a lock taken in one and released
/// in another looks wrong to it. The viewer's own code, threads included, is checked in this
/// process by the logic tests.
const std::string kDrawingChild =
    "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 TSAN_OPTIONS=report_bugs=0 ";

/// Runs voxcut-view with `args`; returns its exit status, its output in `out`.
int view(const std::string& args, std::string& out) {
  return voxcut::view::runCommand(kDrawingChild + std::string(VOXCUT_VIEW_EXE) + " " + args, out);
}

const std::string kEar = std::string(VOXCUT_SOURCE_DIR) + "/scenes/bunny-ear.json";

/// The renderer's background (DrawData.cpp, backgroundColour), in bytes.
bool background(const unsigned char* p) {
  return std::abs(p[0] - 28) <= 2 && std::abs(p[1] - 31) <= 2 && std::abs(p[2] - 38) <= 2;
}
/// The bunny's skin and its cuts: clearly red.
bool tissue(const unsigned char* p) {
  return p[0] > p[1] + 25 && p[0] > p[2] + 25;
}

/// Sizes of the 4-connected regions of pixels where `in` holds, largest first.
template <class In>
std::vector<int> regions(const Picture& p, In in) {
  std::vector<int> label(static_cast<std::size_t>(p.width) * p.height, -1), sizes, stack;
  for (int start = 0; start < p.width * p.height; ++start) {
    if (label[start] >= 0 || !in(p.at(start % p.width, start / p.width))) continue;
    const int id = static_cast<int>(sizes.size());
    sizes.push_back(0);
    stack.push_back(start);
    label[start] = id;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      ++sizes.back();
      const int x = i % p.width, y = i / p.width;
      for (const auto& [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int nx = x + dx, ny = y + dy;
        if (nx < 0 || ny < 0 || nx >= p.width || ny >= p.height) continue;
        const int j = ny * p.width + nx;
        if (label[j] < 0 && in(p.at(nx, ny))) {
          label[j] = id;
          stack.push_back(j);
        }
      }
    }
  }
  std::sort(sizes.rbegin(), sizes.rend());
  return sizes;
}

class Screenshot : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!haveDisplay()) GTEST_SKIP() << "no display (run under xvfb-run -a)";
    dir = fs::temp_directory_path() / ("voxcut-view-test-" + std::to_string(::getpid()));
    fs::create_directories(dir);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  fs::path dir;
};

// The bunny at the start: its silhouette fills a sensible share of the picture, in its
// material's colour, as one region.
TEST_F(Screenshot, BunnyShowsItsSilhouette) {
  const std::string png = (dir / "bunny.png").string();
  std::string out;
  ASSERT_EQ(view(kEar + " --frames 0 --size 320x240 --screenshot " + png, out), 0) << out;
  const Picture p = load(png);
  ASSERT_EQ(p.width, 320);
  ASSERT_EQ(p.height, 240);
  std::size_t fg = 0, red = 0;
  double r = 0, g = 0, b = 0;
  for (int y = 0; y < p.height; ++y)
    for (int x = 0; x < p.width; ++x) {
      const unsigned char* c = p.at(x, y);
      if (background(c)) continue;
      ++fg;
      if (tissue(c)) ++red;
      r += c[0];
      g += c[1];
      b += c[2];
    }
  const double fraction = static_cast<double>(fg) / (p.width * p.height);
  EXPECT_GT(fraction, 0.1);
  EXPECT_LT(fraction, 0.6);
  EXPECT_GT(static_cast<double>(red), 0.9 * static_cast<double>(fg));
  EXPECT_GT(r, 1.2 * g);
  EXPECT_GT(r, 1.2 * b);
  const std::vector<int> parts = regions(p, tissue);
  ASSERT_FALSE(parts.empty());
  // One region, but for slivers the blade's rod cuts off.
  EXPECT_GT(parts[0], 0.9 * static_cast<double>(red));
}

// After bunny-ear.json the cut-off ear lies apart from the bunny: two regions of tissue.
TEST_F(Screenshot, EarAndBunnyAreSeparateAfterTheCut) {
  const std::string png = (dir / "ear.png").string();
  std::string out;
  // Seen from the side, where the ear has fallen clear of the bunny.
  ASSERT_EQ(view(kEar + " --frames 250 --size 320x240 --view 90 20 --screenshot " + png, out), 0)
      << out;
  const Picture p = load(png);
  ASSERT_EQ(p.width, 320);
  const std::vector<int> parts = regions(p, tissue);
  ASSERT_GE(parts.size(), 2u);
  EXPECT_GT(parts[1], 40);            // the ear
  EXPECT_GT(parts[0], 5 * parts[1]);  // the bunny
}

// The active links drawn in a section through the bunny: with the octree, the shell and the
// cubes' frames; without it, every link, a dense grid.
TEST_F(Screenshot, ActiveLinksShowTheOctree) {
  auto yellow = [](const unsigned char* c) { return c[0] > 200 && c[1] > 170 && c[2] < 110; };
  std::string out;
  std::size_t counts[2] = {0, 0};
  for (int baseline = 0; baseline < 2; ++baseline) {
    const std::string png = (dir / ("links" + std::to_string(baseline) + ".png")).string();
    ASSERT_EQ(view("bunny --resolution 64 --frames 0 --links --slice --view 0 0 --size 480x360 "
                   "--screenshot " +
                       png + (baseline ? " --no-octree" : ""),
                   out),
              0)
        << out;
    const Picture p = load(png);
    ASSERT_EQ(p.width, 480);
    for (int y = 0; y < p.height; ++y)
      for (int x = 0; x < p.width; ++x) counts[baseline] += yellow(p.at(x, y));
  }
  EXPECT_GT(counts[0], 500u);
  EXPECT_GT(counts[1], 2 * counts[0]);
}

// An image sequence, and errors as one line with a non-zero exit.
TEST_F(Screenshot, SequencesAndErrors) {
  std::string out;
  ASSERT_EQ(view("bunny --resolution 24 --frames 4 --every 2 --size 64x48 --screenshots " +
                     (dir / "seq").string(),
                 out),
            0)
      << out;
  for (const char* name : {"frame-000000.png", "frame-000002.png", "frame-000004.png"})
    EXPECT_EQ(load((dir / "seq" / name).string()).width, 64) << name;
  EXPECT_FALSE(fs::exists(dir / "seq" / "frame-000001.png"));
  // A sequence shows the motion: the probe of bunny-poke.json has come down onto the back by
  // frame 100 (same camera, same topology, so only new positions tell the pictures apart).
  ASSERT_EQ(view(std::string(VOXCUT_SOURCE_DIR) +
                     "/scenes/bunny-poke.json --frames 100 --every 100 --fit start --size "
                     "160x120 --screenshots " +
                     (dir / "poke").string(),
                 out),
            0)
      << out;
  const Picture before = load((dir / "poke" / "frame-000000.png").string());
  const Picture after = load((dir / "poke" / "frame-000100.png").string());
  ASSERT_EQ(before.rgb.size(), after.rgb.size());
  std::size_t changed = 0;
  for (std::size_t i = 0; i < before.rgb.size(); i += 3)
    changed += before.rgb[i] != after.rgb[i] || before.rgb[i + 1] != after.rgb[i + 1];
  EXPECT_GT(changed, 50u);
  EXPECT_EQ(view((dir / "missing.json").string() + " --frames 1", out), 1);
  EXPECT_EQ(out.rfind("voxcut-view: error: ", 0), 0u) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
  EXPECT_NE(view("bunny --frames 1 --size 10x10", out), 0);
  EXPECT_NE(out.find("--size"), std::string::npos) << out;
}

// The window itself, with its panel, playing a scene for a moment: it draws frames while the
// simulation's thread runs its own.
TEST_F(Screenshot, WindowDrawsWhileTheSimulationRuns) {
  std::string out;
  ASSERT_EQ(view("bunny --resolution 24 --size 320x240 --measure 1.5", out), 0) << out;
  long drawn = 0;
  int simulated = 0;
  ASSERT_EQ(std::sscanf(out.c_str(), "drawn %ld frames in %*f s: %*f fps; simulated %d", &drawn,
                        &simulated),
            2)
      << out;
  EXPECT_GT(drawn, 5);
  EXPECT_GT(simulated, 5);
}

// `voxcut run --screenshots`: the same renderer leaves a batch run's pictures; without a
// display it stops before any work with one line.
TEST_F(Screenshot, RunLeavesPictures) {
  std::string out;
  const std::string pics = (dir / "run").string();
  const std::string run = std::string(VOXCUT_EXE) + " run " + kEar +
                          " --frames 4 --every 2 --size 64x48 --screenshots " + pics;
  ASSERT_EQ(voxcut::view::runCommand(kDrawingChild + run, out), 0) << out;
  for (const char* name : {"frame_00000.png", "frame_00002.png", "frame_00004.png"})
    EXPECT_EQ(load((fs::path(pics) / name).string()).width, 64) << name;
  EXPECT_EQ(voxcut::view::runCommand("env -u DISPLAY " + run + "-none", out), 2);
  const std::string line = out.substr(0, out.find('\n'));
  EXPECT_NE(line.find("no display"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(pics + "-none"));
}

}  // namespace
