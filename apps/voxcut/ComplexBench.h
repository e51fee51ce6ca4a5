#pragma once
// `voxcut bench complex`: the paper's complex scenario (§4.2, figures 6 to 8). Each scene (a
// recorded probe and blade poking and cutting a body) runs with the voxel octree at 1, 2 and 3
// threads, at maximum internal levels 1 to 4 (2 threads), and without it (the baseline) at 1,
// 2 and 3 threads; one CSV per run, a summary of the octree / baseline FPS ratio in the
// non-cutting and cutting periods with the stages behind it, and the figures drawn by
// scripts/plot_complex.py.

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace voxcut::app {

struct ComplexBenchOptions {
  std::vector<std::string> scenes;  // empty: scenes/complex-{bunny,liver,starfish}.json
  std::string out = "out/complex";
  int frames = 0;         // 0: each scene's "frames" (else 100); otherwise at most this many
  bool noPlot = false;    // --no-plot: CSVs and summary only
  bool plot = false;      // --plot: drawing the figures is required (fail without matplotlib)
  bool selected = false;  // set when `bench complex` is on the command line
};

/// Adds `complex` under the `bench` command.
void addComplexBenchCommand(CLI::App& bench, ComplexBenchOptions& opt);

/// Runs the benchmark (docs/performance.md, "Complex scenario"). Every scene is read before
/// any runs, and the output folder checked. Writes OUT/SCENE/RUN.csv per run, OUT/runs.csv
/// (one row per run), prints the summary on stdout and progress on stderr (on a terminal),
/// then draws the figures into OUT unless --no-plot. Returns 0; 2 when the runs of a scene cut
/// different links (the results must not depend on the thread count or the octree), when the
/// plot script fails, or when --plot was given and no python3 with matplotlib was found (a
/// missing matplotlib otherwise costs a note on stderr only). Throws InputError for bad
/// options and scenes, Interrupted when SIGINT or SIGTERM stop it between frames.
int runComplexBench(const ComplexBenchOptions& opt);

}  // namespace voxcut::app
