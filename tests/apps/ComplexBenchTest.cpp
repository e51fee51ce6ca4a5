// Tests of `voxcut bench complex` (apps/voxcut/ComplexBench.h): a short run on a small scene
// writes one CSV per run with the documented columns and a row per frame, the runs cut the
// same links, bad options and scenes fail with one error line, and scripts/plot_complex.py
// draws every figure from the CSVs where matplotlib is installed.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "CliProcess.h"
#include "voxcut/sim/World.h"

namespace voxcut {
namespace {

namespace fs = std::filesystem;
using cli::runVoxcut;
using cli::TempFolder;

/// A sphere cut through by a blade within 20 frames while a probe presses it from below.
constexpr const char* kScene = R"({
  "time_step": 0.004, "gravity": [0, 0, 0], "frames": 40,
  "bodies": [{"model": "sphere:0.02", "resolution": 24, "element_level": 2}],
  "tools": [{"type": "blade", "keys": [
    {"t": 0.0, "a": [-0.05, 0.003, -0.03], "b": [0.05, 0.003, -0.03]},
    {"t": 0.05, "a": [-0.05, 0.005, 0.0], "b": [0.05, 0.001, 0.0]},
    {"t": 0.08, "a": [-0.05, 0.003, 0.03], "b": [0.05, 0.003, 0.03]}]},
    {"type": "probe", "radius": 0.005, "keys": [{"t": 0, "p": [0, -0.03, 0]},
                                                {"t": 0.08, "p": [0, -0.018, 0]}]}]})";

/// The runs of a scene whose materials have the default max_internal_level (4).
const std::vector<std::string> kRuns{"octree-t1",    "baseline-t1",  "octree-t2",
                                     "baseline-t2",  "octree-t2-L1", "octree-t2-L2",
                                     "octree-t2-L3", "octree-t3",    "baseline-t3"};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line);
  std::string c;
  while (std::getline(in, c, ',')) cells.push_back(c);
  return cells;
}

/// The lines of a text file, without their newlines.
std::vector<std::string> lines(const std::string& path) {
  std::vector<std::string> out;
  std::stringstream in(cli::readText(path));
  std::string line;
  while (std::getline(in, line)) out.push_back(line);
  return out;
}

/// Runs `bench complex` on kScene for `frames` frames into folder/out; expects success.
std::string runBench(const TempFolder& folder, int frames) {
  const std::string scene = folder.write("sphere-cut.json", kScene);
  const std::string out = folder.file("out");
  const std::vector<std::string> args{"bench",     "complex",  "--frames", std::to_string(frames),
                                      "--no-plot", "--scenes", scene,      "--out",
                                      out};
  const cli::ProcessResult r = runVoxcut(args);
  EXPECT_EQ(r.status, 0) << cli::describe(args, r);
  EXPECT_NE(r.out.find("cut_set_hash"), std::string::npos) << r.out;
  EXPECT_EQ(r.err.find("error"), std::string::npos) << r.err;
  return out;
}

TEST(ComplexBench, WritesOneCsvPerRunWithEveryColumnAndFrame) {
  const TempFolder folder("complex_bench");
  const int frames = 20;
  const std::string out = runBench(folder, frames);

  std::string header = "frame,time_s,frame_ms,fps";
  for (const std::string& s : frameStageNames()) header += "," + s + "_ms";
  header += ",cut_links,cutting,contacts,tool_force_N,solver_iterations";
  const std::vector<std::string> index = lines(out + "/runs.csv");
  ASSERT_EQ(index.size(), kRuns.size() + 1);
  std::set<std::string> hashes, named;
  for (std::size_t i = 1; i < index.size(); ++i) {
    // scene,run,csv,threads,octree,max_internal_level,frames,time_step,cut_links,cut_set_hash,...
    const std::vector<std::string> c = split(index[i]);
    ASSERT_GE(c.size(), 11u) << index[i];
    EXPECT_EQ(c[0], "sphere-cut");
    named.insert(c[1]);
    EXPECT_EQ(c[6], std::to_string(frames));
    EXPECT_GT(std::stol(c[8]), 0) << "the blade cuts: " << index[i];
    hashes.insert(c[9]);

    const std::vector<std::string> rows = lines(out + "/" + c[2]);
    ASSERT_EQ(rows.size(), static_cast<std::size_t>(frames) + 1) << c[2];
    EXPECT_EQ(rows[0], header);
    const std::vector<std::string> columns = split(header);
    const auto col = [&](const char* name) {
      return static_cast<std::size_t>(std::find(columns.begin(), columns.end(), name) -
                                      columns.begin());
    };
    bool cutting = false, pushed = false;
    for (std::size_t f = 1; f < rows.size(); ++f) {
      const std::vector<std::string> v = split(rows[f]);
      ASSERT_EQ(v.size(), columns.size()) << c[2] << " row " << f;
      EXPECT_EQ(std::stoi(v[0]), static_cast<int>(f) - 1);
      EXPECT_GT(std::stod(v[col("frame_ms")]), 0.0);
      cutting = cutting || v[col("cutting")] == "1";
      pushed = pushed || std::stod(v[col("tool_force_N")]) > 0.0;
    }
    EXPECT_TRUE(cutting) << c[2];
    EXPECT_TRUE(pushed) << c[2];
  }
  EXPECT_EQ(named, std::set<std::string>(kRuns.begin(), kRuns.end()));
  EXPECT_EQ(hashes.size(), 1u) << "the runs cut different links";
}

TEST(ComplexBench, BadOptionsAndScenesFailWithOneLine) {
  const TempFolder folder("complex_bench_bad");
  const std::string bad = folder.write("bad.json", R"({"bodies": [{"model": "bunny"}], "x": 1})");
  const std::string good = folder.write("sphere-cut.json", kScene);
  const std::string out = folder.file("out");
  const std::vector<std::vector<std::string>> cases{
      {"bench", "complex", "--frames", "0", "--out", out},
      {"bench", "complex", "--bogus", "--out", out},
      {"bench", "complex", "--no-plot", "--plot", "--out", out},
      {"bench", "complex", "--scenes", folder.file("missing.json"), "--out", out},
      {"bench", "complex", "--scenes", good, bad, "--out", out},
      {"bench", "complex", "--scenes", good, good, "--out", out},
      {"bench", "complex", "--scenes", good, "--out", folder.write("file", "x") + "/sub"},
  };
  for (const auto& args : cases) {
    const cli::ProcessResult r = runVoxcut(args);
    EXPECT_EQ(r.status, 2) << cli::describe(args, r);
    EXPECT_TRUE(r.out.empty()) << cli::describe(args, r);
    EXPECT_EQ(r.err.rfind("voxcut: error: ", 0), 0u) << cli::describe(args, r);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << cli::describe(args, r);
    EXPECT_FALSE(fs::exists(out)) << "nothing is written before every scene was read";
  }
}

/// A Python 3 that imports matplotlib, as the bench looks for one; empty when none.
std::string plotPython() {
  for (const char* python : {"python3", "/usr/bin/python3"})
    if (std::system((std::string(python) + " -c 'import matplotlib' >/dev/null 2>&1").c_str()) == 0)
      return python;
  return {};
}

TEST(ComplexBench, PlotScriptDrawsEveryFigure) {
  const std::string python = plotPython();
  if (python.empty()) GTEST_SKIP() << "no python3 with matplotlib (python3-matplotlib)";
  const TempFolder folder("complex_bench_plot");
  const std::string out = runBench(folder, 12);
  const std::string script = std::string(VOXCUT_SOURCE_DIR) + "/scripts/plot_complex.py";
  const std::string command = python + " '" + script + "' '" + out + "' >/dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  for (const char* figure : {"fps-threads", "fps-levels", "collision-steps"})
    for (const char* ext : {"png", "svg"}) {
      const fs::path path = fs::path(out) / ("sphere-cut-" + std::string(figure) + "." + ext);
      ASSERT_TRUE(fs::exists(path)) << path;
      EXPECT_GT(fs::file_size(path), 1000u) << path;
    }
}

}  // namespace
}  // namespace voxcut
