#pragma once
// Options shared by the subcommands that build a voxel model (info, surface), and the code
// that turns them into a built model.

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "voxcut/sim/ModelBuild.h"

namespace voxcut::app {

struct ModelOptions {
  std::string model;
  std::vector<std::string> materials;  // NAME=MESH
  int resolution = 0;                  // used when resolutionGiven
  double voxelSize = 0.0;              // used when voxelSizeGiven
  bool resolutionGiven = false;
  bool voxelSizeGiven = false;
  std::vector<std::string> cutPlanes;  // NX,NY,NZ,D
  int threads = 0;                     // 0: all cores
  bool json = false;
};

/// Adds the model options to a subcommand.
void addModelOptions(CLI::App& cmd, ModelOptions& opt);

/// Loads the model, voxelizes, cuts and contours it; progress on stderr when it is a terminal.
/// `modelName` receives the name to report. Throws InputError.
ModelBuild buildFromOptions(const ModelOptions& opt, std::string& modelName);

}  // namespace voxcut::app
