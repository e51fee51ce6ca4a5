// Tests of `voxcut bench soak` (apps/voxcut/SoakBench.h): a tiny soak writes a CSV per run with
// the documented columns and a row per frame, and a summary (stdout and summary.csv); a seed
// gives the same run every time and at any thread count, another seed another run; bad
// options fail with one line; a signal stops it at a frame boundary with whole files.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "CliProcess.h"
#include "voxcut/sim/World.h"

namespace voxcut {
namespace {

using cli::runVoxcut;
using cli::TempFolder;

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line);
  std::string c;
  while (std::getline(in, c, ',')) cells.push_back(c);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

std::vector<std::string> lines(const std::string& path) {
  std::vector<std::string> out;
  std::stringstream in(cli::readText(path));
  std::string line;
  while (std::getline(in, line)) out.push_back(line);
  return out;
}

/// A CSV as rows of named cells.
struct Table {
  std::vector<std::string> columns;
  std::vector<std::map<std::string, std::string>> rows;
};

Table readCsv(const std::string& path) {
  Table t;
  const std::vector<std::string> text = lines(path);
  if (text.empty()) return t;
  t.columns = split(text.front());
  for (std::size_t i = 1; i < text.size(); ++i) {
    const std::vector<std::string> cells = split(text[i]);
    EXPECT_EQ(cells.size(), t.columns.size()) << path << " row " << i << ": " << text[i];
    std::map<std::string, std::string> row;
    for (std::size_t c = 0; c < std::min(cells.size(), t.columns.size()); ++c)
      row[t.columns[c]] = cells[c];
    t.rows.push_back(std::move(row));
  }
  return t;
}

/// The tiny soak: the bunny at resolution 24, element level 2, one thread unless told.
std::vector<std::string> soakArgs(const std::string& out, int frames, int seed, int seeds = 1,
                                  int threads = 1) {
  return {"bench",           "soak",
          "--resolution",    "24",
          "--element-level", "2",
          "--frames",        std::to_string(frames),
          "--seed",          std::to_string(seed),
          "--seeds",         std::to_string(seeds),
          "--threads",       std::to_string(threads),
          "--out",           out};
}

/// Runs the soak; expects success and returns its stdout.
std::string runSoak(const std::vector<std::string>& args) {
  const cli::ProcessResult r = runVoxcut(args);
  EXPECT_EQ(r.status, 0) << cli::describe(args, r);
  EXPECT_EQ(r.err.find("error"), std::string::npos) << r.err;
  return r.out;
}

/// The per-frame values a run's seed decides (not its timings or memory).
std::vector<std::string> decided(const Table& t) {
  std::vector<std::string> out;
  for (const auto& row : t.rows) {
    std::string v;
    for (const char* c :
         {"episode", "cut_links", "nodes", "elements", "pieces", "contacts", "solver_iterations"})
      v += row.at(c) + " ";
    out.push_back(v);
  }
  return out;
}

TEST(SoakBench, WritesEveryColumnPerFrameAndASummary) {
  const TempFolder folder("soak_bench");
  const std::string out = folder.file("out");
  const int frames = 40;
  const std::string stdoutText = runSoak(soakArgs(out, frames, 1));

  std::vector<std::string> expected{"frame"};
  for (const std::string& s : frameStageNames()) expected.push_back(s + "_ms");
  for (const char* c : {"frame_ms", "nodes", "elements", "pieces", "contacts", "solver_iterations",
                        "converged", "cut_links", "cut_links_frame", "max_penetration_m", "rss_mib",
                        "peak_rss_mib", "probe_force_N", "energy_J", "touched", "episode"})
    expected.emplace_back(c);
  const Table t = readCsv(out + "/bunny-r24-l2-s1.csv");
  EXPECT_EQ(t.columns, expected);
  ASSERT_EQ(t.rows.size(), static_cast<std::size_t>(frames));
  for (int f = 0; f < frames; ++f) {
    const auto& row = t.rows[static_cast<std::size_t>(f)];
    EXPECT_EQ(row.at("frame"), std::to_string(f));
    EXPECT_GT(std::stod(row.at("frame_ms")), 0.0);
    EXPECT_GT(std::stol(row.at("nodes")), 0);
    EXPECT_GT(std::stod(row.at("rss_mib")), 0.0);
    EXPECT_GE(std::stod(row.at("peak_rss_mib")), std::stod(row.at("rss_mib")) - 1.0);
    // Pieces are counted every 10th frame and at the last.
    EXPECT_EQ(row.at("pieces").empty(), f % 10 != 0 && f + 1 != frames) << "frame " << f;
    EXPECT_FALSE(row.at("episode").empty());
    EXPECT_GT(std::stod(row.at("energy_J")), 0.0);  // gravitational, above the floor's origin
    EXPECT_TRUE(row.at("touched") == "0" || row.at("touched") == "1");
    if (std::stol(row.at("cut_links_frame")) > 0) {
      EXPECT_EQ(row.at("touched"), "1");
    }
  }
  EXPECT_EQ(t.rows.front().at("episode"), "idle") << "the body settles first";

  const Table s = readCsv(out + "/summary.csv");
  ASSERT_EQ(s.rows.size(), 1u);
  const auto& run = s.rows.front();
  EXPECT_EQ(run.at("run"), "bunny-r24-l2-s1");
  EXPECT_EQ(run.at("frames"), std::to_string(frames));
  EXPECT_EQ(run.at("status"), "complete");
  EXPECT_EQ(run.at("window"), std::to_string(frames / 2));
  EXPECT_EQ(run.at("nodes_start"), t.rows.front().at("nodes"));
  EXPECT_EQ(run.at("nodes_end"), t.rows.back().at("nodes"));
  EXPECT_EQ(run.at("cut_links"), t.rows.back().at("cut_links"));
  EXPECT_GT(std::stod(run.at("time_ratio")), 0.0);
  EXPECT_GE(std::stod(run.at("memory_ratio")), 0.9);
  EXPECT_TRUE(run.at("meets_bar") == "1" || run.at("meets_bar") == "0");
  EXPECT_EQ(run.at("meets_bar") == "1", run.at("misses") == "-");
  // The largest growth of the energy over an untouched frame, from the frames' own columns.
  double gain = 0.0;
  for (std::size_t f = 1; f < t.rows.size(); ++f)
    if (t.rows[f].at("touched") == "0")
      gain = std::max(gain, std::stod(t.rows[f].at("energy_J")) -
                                std::stod(t.rows[f - 1].at("energy_J")));
  EXPECT_NEAR(std::stod(run.at("untouched_energy_gain_j")), gain, 1e-3 * gain + 1e-12);

  EXPECT_NE(stdoutText.find("| bunny-r24-l2-s1 | 40 |"), std::string::npos) << stdoutText;
  EXPECT_NE(stdoutText.find("\nbar ("), std::string::npos) << stdoutText;
  EXPECT_TRUE(stdoutText.find("met by every run (1)") != std::string::npos ||
              stdoutText.find("missed by 1 of 1 runs: bunny-r24-l2-s1 (") != std::string::npos)
      << stdoutText;
}

TEST(SoakBench, SameSeedSameRunAtAnyThreadCountOtherSeedOtherRun) {
  const TempFolder folder("soak_bench_seed");
  const int frames = 40;
  // Seeds 5 and 6 in one call on one thread; seed 5 alone again on two.
  runSoak(soakArgs(folder.file("a"), frames, 5, 2, 1));
  runSoak(soakArgs(folder.file("b"), frames, 5, 1, 2));
  const Table a5 = readCsv(folder.file("a/bunny-r24-l2-s5.csv"));
  const Table a6 = readCsv(folder.file("a/bunny-r24-l2-s6.csv"));
  const Table b5 = readCsv(folder.file("b/bunny-r24-l2-s5.csv"));
  ASSERT_EQ(a5.rows.size(), static_cast<std::size_t>(frames));
  ASSERT_EQ(a6.rows.size(), static_cast<std::size_t>(frames));
  EXPECT_EQ(decided(a5), decided(b5));
  EXPECT_NE(decided(a5), decided(a6));

  const Table a = readCsv(folder.file("a/summary.csv"));
  const Table b = readCsv(folder.file("b/summary.csv"));
  ASSERT_EQ(a.rows.size(), 2u);
  ASSERT_EQ(b.rows.size(), 1u);
  EXPECT_EQ(a.rows[0].at("seed"), "5");
  EXPECT_EQ(a.rows[1].at("seed"), "6");
  EXPECT_GT(std::stol(a.rows[0].at("cut_links")), 0) << "seed 5 cuts within " << frames;
  EXPECT_EQ(a.rows[0].at("cut_set_hash"), b.rows[0].at("cut_set_hash"));
  EXPECT_EQ(a.rows[0].at("cut_links"), b.rows[0].at("cut_links"));
  EXPECT_EQ(a.rows[0].at("nodes_end"), b.rows[0].at("nodes_end"));
  EXPECT_NE(a.rows[0].at("cut_set_hash"), a.rows[1].at("cut_set_hash"));
}

TEST(SoakBench, BadOptionsFailWithOneLine) {
  const TempFolder folder("soak_bench_bad");
  const std::string out = folder.file("out");
  const std::vector<std::vector<std::string>> cases{
      {"bench", "soak", "--element-level", "2", "--finest-level", "3", "--out", out},
      {"bench", "soak", "--model", "no-such-model", "--out", out},
      {"bench", "soak", "--self-collision", "maybe", "--out", out},
      {"bench", "soak", "--blades", "4", "--out", out},
      {"bench", "soak", "--frames", "0", "--out", out},
      {"bench", "soak", "--out", folder.write("file", "x") + "/sub"},
  };
  for (const auto& args : cases) {
    const cli::ProcessResult r = runVoxcut(args);
    EXPECT_EQ(r.status, 2) << cli::describe(args, r);
    EXPECT_EQ(r.err.rfind("voxcut: error: ", 0), 0u) << cli::describe(args, r);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << cli::describe(args, r);
  }
  EXPECT_FALSE(cli::fs::exists(out)) << "nothing is written for bad options";
}

TEST(SoakBench, SignalStopsAtAFrameBoundaryWithWholeFiles) {
  const TempFolder folder("soak_bench_signal");
  const std::string out = folder.file("out");
  std::vector<std::string> args = soakArgs(out, 1000000, 2, 3);
  cli::ProcessOptions options;
  options.timeLimitSeconds = 120;
  cli::VoxcutProcess soak(args, options);
  const std::string csv = out + "/bunny-r24-l2-s2.csv";
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(100);
  while (lines(csv + ".tmp").size() < 6 && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  soak.signal(SIGTERM);
  const cli::ProcessResult r = soak.wait();
  ASSERT_EQ(r.status, 130) << cli::describe(args, r);
  const Table t = readCsv(csv);
  ASSERT_GE(t.rows.size(), 5u);
  EXPECT_EQ(cli::readText(csv).back(), '\n');
  const Table s = readCsv(out + "/summary.csv");
  ASSERT_EQ(s.rows.size(), 1u) << "the later seeds do not run";
  EXPECT_EQ(s.rows[0].at("status"), "interrupted");
  EXPECT_EQ(s.rows[0].at("frames"), std::to_string(t.rows.size()));
  EXPECT_NE(r.out.find("interrupted after 1 of 3 runs"), std::string::npos) << r.out;
  for (const std::string& name : folder.entries())
    EXPECT_EQ(name.find(".tmp"), std::string::npos) << "temporary left: " << name;
}

}  // namespace
}  // namespace voxcut
