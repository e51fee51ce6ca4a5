#pragma once
// `voxcut bench soak`: a long, seeded session of random cutting and poking
// (SoakInteraction.h) on a built-in model resting on a floor under gravity, logged frame by
// frame, with a summary of how frame time, the deformation octree and memory grew from the
// first frames to the last (docs/performance.md, "Soak benchmark").

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

namespace voxcut::app {

struct SoakBenchOptions {
  std::string model = "bunny";
  int resolution = 64;
  int elementLevel = 3;
  int finestLevel = -1;  // -1: the library's default
  int frames = 600;
  std::uint64_t seed = 1;
  int seeds = 1;    // runs seeds seed .. seed + seeds - 1
  int blades = 0;   // 1..3; 0: drawn from each seed
  int threads = 0;  // 0: all cores
  std::string selfCollision = "on";
  bool noOctree = false;
  std::string out = "out/soak";
  std::string maxMemory;  // --max-memory SIZE; empty: the available memory
  bool selected = false;  // set when `bench soak` is on the command line
};

/// Adds `soak` under the `bench` command.
void addSoakBenchCommand(CLI::App& bench, SoakBenchOptions& opt);

/// Runs one soak per seed (docs/performance.md, "Soak benchmark"). The model is voxelized once
/// and every run starts from a copy. Writes OUT/MODEL-rRES-lLEVEL-sSEED.csv per run (one row
/// per frame) and OUT/summary.csv (one row per run), prints the summary on stdout and progress
/// on stderr (on a terminal). SIGINT and SIGTERM stop the run at the next frame boundary: its
/// CSV and the summary cover the frames run and no further seeds run. A run whose simulation
/// fails (a non-finite position) is reported as failed and the next seed runs. Returns 0 (the
/// issue's bar, met or not, is reported, not enforced) or 130 when interrupted; throws
/// InputError for bad options.
int runSoakBench(const SoakBenchOptions& opt);

}  // namespace voxcut::app
