// `voxcut run` interrupted mid-run by SIGINT or SIGTERM, once or twice: it stops at a frame
// boundary with status 130, the CSV holds one whole row per finished frame, every exported OBJ
// is complete, no temporary file is left, and the summary covers the frames run and says
// "interrupted". A third signal ends it at once, and still leaves no temporary file.
// Also: `info box:0.1,0.1,0.1 --resolution 1024` refused at once, naming the memory.

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "CliProcess.h"
#include "voxcut/sim/MemoryEstimate.h"

namespace voxcut::cli {
namespace {

/// A scene whose frames are quick and whose run would take minutes: a sphere falling under
/// gravity for 100,000 frames.
const char* kLongScene =
    R"({"frames": 100000, "bodies": [{"model": "sphere:0.05", "resolution": 31}]})";

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) out.push_back(line);
  return out;
}

std::size_t fieldCount(const std::string& row) {
  return static_cast<std::size_t>(std::count(row.begin(), row.end(), ',')) + 1;
}

/// Waits until `path` holds at least `count` lines (or `seconds` pass); returns whether it did.
bool waitForLines(const std::string& path, std::size_t count, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    const std::string text = readText(path);
    if (static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) >= count) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

/// Checks that an OBJ written by voxcut is complete: it ends with a newline, holds the vertex
/// and triangle counts its first line announces, and every face index is in range.
void expectCompleteObj(const std::string& path) {
  const std::string text = readText(path);
  ASSERT_FALSE(text.empty()) << path;
  EXPECT_EQ(text.back(), '\n') << path << ": last line cut";
  long announcedV = -1, announcedF = -1;
  std::sscanf(text.c_str(), "# voxcut surface: %ld vertices, %ld triangles", &announcedV,
              &announcedF);
  long v = 0, f = 0;
  bool inRange = true;
  for (const std::string& line : lines(text)) {
    if (line.rfind("v ", 0) == 0) ++v;
    if (line.rfind("f ", 0) != 0) continue;
    ++f;
    std::istringstream ls(line.substr(2));
    std::string word;
    int n = 0;
    while (ls >> word) {
      const long i = std::stol(word.substr(0, word.find('/')));
      inRange = inRange && i >= 1 && i <= announcedV;
      ++n;
    }
    inRange = inRange && n == 3;
  }
  EXPECT_EQ(v, announcedV) << path;
  EXPECT_EQ(f, announcedF) << path;
  EXPECT_TRUE(inRange) << path << ": a face index out of range or a face cut short";
}

/// Starts the long run, signals it after a few frames (`times` signals at once, as `timeout`
/// sends one to its command and one to the command's process group), and checks everything it
/// left.
void interruptRun(int signal, bool json, int times = 1) {
  const TempFolder folder("interrupt");
  const std::string scene = folder.write("long.json", kLongScene);
  const std::string csv = folder.file("run.csv"), dir = folder.file("frames");
  std::vector<std::string> args{"run", scene, "--export", dir, "--csv", csv, "--threads", "1"};
  if (json) args.emplace_back("--json");
  ProcessOptions options;
  options.workingFolder = folder.path().string();
  options.timeLimitSeconds = 120;
  VoxcutProcess run(args, options);
  // The CSV is written beside its name until the run ends; a header and 5 rows mean 5 frames.
  ASSERT_TRUE(waitForLines(csv + ".tmp", 6, 100)) << "the run did not get going";
  for (int k = 0; k < times; ++k) run.signal(signal);
  const ProcessResult r = run.wait();
  ASSERT_EQ(r.status, 130) << describe(args, r);
  EXPECT_LT(r.seconds, 100);

  // The CSV: a header and whole rows for frames 0..n-1.
  ASSERT_TRUE(fs::exists(csv)) << describe(args, r);
  const std::vector<std::string> rows = lines(readText(csv));
  ASSERT_GE(rows.size(), 6u);
  const std::size_t fields = fieldCount(rows.front());
  for (std::size_t i = 1; i < rows.size(); ++i) {
    EXPECT_EQ(fieldCount(rows[i]), fields) << "row " << i << ": " << rows[i];
    EXPECT_EQ(rows[i].substr(0, rows[i].find(',')), std::to_string(i - 1));
  }
  const long frames = static_cast<long>(rows.size()) - 1;
  EXPECT_EQ(readText(csv).back(), '\n');

  // The surfaces: the start and one per finished frame, each complete.
  std::size_t objs = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    EXPECT_EQ(e.path().extension(), ".obj") << e.path();
    expectCompleteObj(e.path().string());
    ++objs;
  }
  EXPECT_EQ(static_cast<long>(objs), frames + 1);
  for (const std::string& name : folder.entries())
    EXPECT_EQ(name.find(".tmp"), std::string::npos) << "temporary left: " << name;

  // The summary.
  if (json) {
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_TRUE(j.at("interrupted").get<bool>());
    EXPECT_EQ(j.at("frames").get<long>(), frames);
  } else {
    EXPECT_NE(
        r.out.find("interrupted         after " + std::to_string(frames) + " of 100000 frames"),
        std::string::npos)
        << r.out;
  }
}

TEST(CliInterrupt, SigintStopsRunAtAFrameBoundary) {
  interruptRun(SIGINT, true);
}

TEST(CliInterrupt, SigtermStopsRunAtAFrameBoundary) {
  interruptRun(SIGTERM, false);
}

TEST(CliInterrupt, SigtermTwiceStillStopsAtAFrameBoundaryWithNoTemporaryLeft) {
  interruptRun(SIGTERM, false, 2);
}

/// A scene of slow frames (about 100 ms on one thread): three signals 1 ms apart land within
/// one frame.
const char* kSlowScene =
    R"({"frames": 100000, "bodies": [{"model": "sphere:0.05", "resolution": 48,
        "element_level": 0}]})";

TEST(CliInterrupt, ThirdSignalEndsAtOnceAndLeavesNoTemporary) {
  const TempFolder folder("interrupt_forced");
  const std::string scene = folder.write("slow.json", kSlowScene);
  const std::string csv = folder.file("run.csv"), dir = folder.file("frames");
  const std::vector<std::string> args{"run",   scene, "--export",  dir,
                                      "--csv", csv,   "--threads", "1"};
  ProcessOptions options;
  options.workingFolder = folder.path().string();
  options.timeLimitSeconds = 120;
  VoxcutProcess run(args, options);
  ASSERT_TRUE(waitForLines(csv + ".tmp", 3, 100)) << "the run did not get going";
  for (int k = 0; k < 3; ++k) {
    run.signal(SIGTERM);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const ProcessResult r = run.wait();
  // Ended by the signal itself (or, where a frame boundary came between the signals, stopped
  // there): either way no temporary is left, and a CSV, if the run got to write one, is whole.
  EXPECT_TRUE(r.status == 128 + SIGTERM || r.status == 130) << describe(args, r);
  // The second signal says that a third ends the run; where the run stopped at a frame
  // boundary before the second arrived, nothing was left to say.
  if (r.status == 128 + SIGTERM) {
    EXPECT_NE(r.err.find("signal once more to end at once"), std::string::npos) << r.err;
  }
  for (const std::string& name : folder.entries())
    EXPECT_EQ(name.find(".tmp"), std::string::npos) << "temporary left: " << name;
  for (const auto& e : fs::directory_iterator(dir)) expectCompleteObj(e.path().string());
  if (fs::exists(csv)) {
    EXPECT_EQ(readText(csv).back(), '\n');
    const std::vector<std::string> rows = lines(readText(csv));
    for (const std::string& row : rows) EXPECT_EQ(fieldCount(row), fieldCount(rows.front()));
  }
}

TEST(CliMemory, Resolution1024BoxRefusedAtOnceNamingTheMemory) {
  // The estimate is about 58 GiB; a machine with that much free memory builds the model.
  if (availableMemory() > (std::size_t{50} << 30)) GTEST_SKIP() << "enough memory to build it";
  const std::vector<std::string> args{"info", "box:0.1,0.1,0.1", "--resolution", "1024"};
  ProcessOptions options;
  options.timeLimitSeconds = 10;
  options.addressSpaceLimit = kRunawayLimit;
  const ProcessResult r = runVoxcut(args, options);
  EXPECT_EQ(r.status, 2) << describe(args, r);
  EXPECT_LT(r.seconds, 1.0) << describe(args, r);
  EXPECT_EQ(r.err.rfind("voxcut: error: model needs about ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(" GiB at resolution 1024 (grid 1024 x 1024 x 1024)"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("--max-memory"), std::string::npos) << r.err;
}

TEST(CliMemory, MaxMemoryAllowsWhatFits) {
  const std::vector<std::string> args{"info",   "sphere:0.05",  "--resolution", "21",
                                      "--json", "--max-memory", "512M"};
  const ProcessResult r = runVoxcut(args);
  ASSERT_EQ(r.status, 0) << describe(args, r);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_GT(j.at("memory_estimate_bytes").get<double>(), 21.0 * 21 * 21 * 2);
  EXPECT_LT(j.at("memory_estimate_bytes").get<double>(), 512.0 * 1024 * 1024);
}

}  // namespace
}  // namespace voxcut::cli
