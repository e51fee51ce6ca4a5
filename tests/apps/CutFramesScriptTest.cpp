// Tests of scripts/cut_frames.py, the cutting frames' times against the others' from
// `voxcut run --csv`: a known answer on a written CSV, a real run's CSV, and bad input.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>

#include "CliProcess.h"

namespace voxcut {
namespace {

using cli::runVoxcut;
using cli::TempFolder;

struct ScriptResult {
  int status = -1;
  std::string out;
};

// Runs the script with `args` (stderr folded into the output).
ScriptResult runScript(const std::string& args) {
  const std::string command = "/usr/bin/python3 '" + std::string(VOXCUT_SOURCE_DIR) +
                              "/scripts/cut_frames.py' " + args + " 2>&1";
  ScriptResult r;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return r;
  char buffer[4096];
  while (const std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) r.out.append(buffer, n);
  const int status = pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// Frames 5, 10 and 11 cut (30, 40, 50 ms); the 17 others take 10 ms but one 20 ms. Nearest-rank
// p95s: 50 and 20, ratio 2.50.
TEST(CutFramesScript, KnownAnswer) {
  const TempFolder folder("cut_frames_known");
  const std::string path = folder.file("run.csv");
  std::ofstream out(path);
  out << "frame,time_s,frame_ms,cut_links,solver_iterations\n";
  for (int f = 0; f < 20; ++f) {
    const bool cuts = f == 5 || f == 10 || f == 11;
    const double ms = cuts ? (f == 5 ? 30 : (f == 10 ? 40 : 50)) : (f == 3 ? 20 : 10);
    out << f << "," << 0.004 * (f + 1) << "," << ms << "," << (cuts ? 7 * f : 0) << ",3\n";
  }
  out.close();
  const ScriptResult r = runScript("'" + path + "'");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("cutting     3 frames, mean   40.00, p95   50.00"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("other      17 frames, mean   10.59, p95   20.00"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("p95 ratio 2.50"), std::string::npos) << r.out;
}

// The columns it reads are the ones `voxcut run --csv` writes: liver-probe-cut's blade starts
// cutting within its first 60 frames.
TEST(CutFramesScript, ReadsARealRun) {
  const TempFolder folder("cut_frames_real");
  const std::string path = folder.file("lpc.csv");
  cli::ProcessOptions options;
  options.timeLimitSeconds = 300;
  const auto run =
      runVoxcut({"run", std::string(VOXCUT_SOURCE_DIR) + "/scenes/liver-probe-cut.json", "--frames",
                 "60", "--csv", path},
                options);
  ASSERT_EQ(run.status, 0) << run.err;
  const ScriptResult r = runScript("'" + path + "' '" + path + "'");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(r.out.find("cutting     0 frames"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("all files"), std::string::npos) << r.out;
}

// A file that is not such a CSV, or missing: one error line, exit 2.
TEST(CutFramesScript, BadInputIsOneErrorLine) {
  const TempFolder folder("cut_frames_bad");
  const std::string path = folder.file("other.csv");
  std::ofstream(path) << "a,b\n1,2\n";
  for (const std::string& arg : {"'" + path + "'", std::string("'/nonexistent/run.csv'")}) {
    const ScriptResult r = runScript(arg);
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_EQ(r.out.rfind("cut_frames: error: ", 0), 0u) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  }
}

}  // namespace
}  // namespace voxcut
