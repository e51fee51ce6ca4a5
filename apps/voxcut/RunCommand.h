#pragma once
// `voxcut run SCENE`: runs a scene (bodies, materials, key-framed tools, obstacles) frame by
// frame.

#include <CLI/CLI.hpp>
#include <string>

namespace voxcut::app {

struct RunOptions {
  std::string scene;
  int frames = 0;   // 0: the scene's "frames", else 100
  int threads = 0;  // 0: all cores
  bool noOctree = false;
  std::string exportDir;
  std::string screenshotDir;  // --screenshots DIR: pictures drawn by the viewer's renderer
  std::string size = "640x480";
  int every = 1;
  std::string csv;
  std::string record;  // --record FILE: the tools' poses, one key per frame
  bool json = false;
  std::string maxMemory;  // --max-memory SIZE; empty: the available memory
};

void addRunCommand(CLI::App& app, RunOptions& opt, CLI::App*& cmd);

/// Runs the scene. Output paths are checked before any work. SIGINT and SIGTERM stop the run
/// at the next frame boundary (or during voxelization): the CSV keeps a whole row per finished
/// frame, exported frames are whole files, the summary covers the frames run and says
/// "interrupted", and the status is 130; a --record file holds the frames run. A second signal
/// changes nothing; a third ends the program at once, leaving no temporary file. A run that fails
/// leaves no CSV and removes the surfaces it exported (each is written to a temporary and renamed
/// when complete). Returns the exit status (0 or 130); throws InputError on errors.
int runRun(const RunOptions& opt);

}  // namespace voxcut::app
