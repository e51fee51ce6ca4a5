#pragma once
// `voxcut cut`: the paper's single-frame cutting test. `voxcut bench single-frame`: its
// Tables 3 and 4, with and without the octree at 1, 2 and 3 threads; `voxcut bench complex`
// (ComplexBench.h) and `voxcut bench soak` (SoakBench.h) are registered beside it.

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "ComplexBench.h"
#include "ModelOptions.h"
#include "SoakBench.h"

namespace voxcut::app {

struct CutOptions {
  ModelOptions model;
  bool noOctree = false;
  int repeat = 1;
  std::string deform = "none";
  std::string blade, to;
  std::string output;
};

void addCutCommand(CLI::App& app, CutOptions& opt, CLI::App*& cmd);
int runCut(const CutOptions& opt);

struct BenchOptions {
  std::vector<std::string> models{"bunny", "liver", "starfish"};
  std::vector<int> threads{1, 2, 3};
  int repeat = 10;
  std::string csv = "single-frame.csv";
  std::string deform = "none";
  std::string maxMemory;        // --max-memory SIZE; empty: the available memory
  ComplexBenchOptions complex;  // `bench complex` (ComplexBench.h)
  SoakBenchOptions soak;        // `bench soak` (SoakBench.h)
};

void addBenchCommand(CLI::App& app, BenchOptions& opt, CLI::App*& cmd);
int runBench(const BenchOptions& opt);

}  // namespace voxcut::app
