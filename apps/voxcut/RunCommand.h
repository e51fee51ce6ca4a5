#pragma once
// `voxcut run SCENE`: runs a scene (bodies, materials, key-framed blades) frame by frame.

#include <CLI/CLI.hpp>
#include <string>

namespace voxcut::app {

struct RunOptions {
  std::string scene;
  int frames = 0;        // 0: the scene's "frames", else 100
  int threads = 0;       // 0: all cores
  bool noOctree = false;
  std::string exportDir;
  int every = 1;
  std::string csv;
  bool json = false;
};

void addRunCommand(CLI::App& app, RunOptions& opt, CLI::App*& cmd);
int runRun(const RunOptions& opt);

}  // namespace voxcut::app
