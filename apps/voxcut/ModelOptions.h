#pragma once
// Options shared by the subcommands that build a voxel model (info, surface), and the code
// that turns them into a built model.

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "voxcut/io/ModelSource.h"
#include "voxcut/sim/ModelBuild.h"

namespace voxcut::app {

struct ModelOptions {
  std::string model;
  std::vector<std::string> materials;  // NAME=MESH
  int resolution = 0;                  // used when resolutionGiven
  double voxelSize = 0.0;              // used when voxelSizeGiven
  bool resolutionGiven = false;
  bool voxelSizeGiven = false;
  std::vector<std::string> cutPlanes;      // NX,NY,NZ,D
  std::vector<std::string> maxLevel;       // L or NAME=L
  std::vector<std::string> boundaryLevel;  // B or NAME=B
  int threads = 0;                         // 0: all cores
  bool json = false;
  std::string maxMemory;  // --max-memory SIZE; empty: the available memory
  std::string labels;     // --labels VALUE=NAME,... or all (label volumes)
  std::string labelNames; // --label-names FILE
  int minIsland = 8;      // --min-island N
};

/// Adds `--max-memory SIZE` to a command that builds models.
void addMaxMemoryOption(CLI::App& cmd, std::string& maxMemory);

/// The memory limit of `--max-memory` (parseMemorySize), or the available memory when it was
/// not given. Throws InputError for a bad size.
std::size_t memoryLimit(const std::string& maxMemory);

/// Parses `count` comma-separated finite numbers given to `option` (`form` shows the syntax in
/// the error). Throws InputError.
std::vector<double> parseNumberList(const std::string& text, const char* option, std::size_t count,
                                    const char* form);

/// Adds the model options to a subcommand (the cut-plane option only when `cutPlanes`).
void addModelOptions(CLI::App& cmd, ModelOptions& opt, bool cutPlanes = true);

/// Loads MODEL or the --material meshes; for a label volume, applies --labels, --label-names
/// and --min-island, and refuses a header asking for more than `maxMemory` bytes (0: no
/// limit). Throws InputError.
Model loadFromOptions(const ModelOptions& opt, std::size_t maxMemory = 0);

/// Prints the resampling's warnings (islands dropped, labels too small for the grid) and the
/// volume's (NIfTI sform and qform disagreeing) as "voxcut: warning: ..." lines on stderr.
void printModelWarnings(const Model& model, const LabelResampleReport& report);

/// Progress of long stages on stderr when it is a terminal; asks them to stop (Interrupted)
/// once a signal was caught (Interrupt.h; only while an InterruptGuard is alive).
ProgressCallback terminalProgress();

/// Voxelizer settings from the options (resolution, voxel size, terminalProgress).
VoxelizeParams voxelizeParams(const ModelOptions& opt, const Model& model);

/// Voxel octree levels per material from --max-level / --boundary-level (defaults 4 and 0).
OctreeParams octreeParams(const ModelOptions& opt, const std::vector<std::string>& materials);

/// Loads the model, checks the memory estimate against --max-memory, voxelizes, cuts and
/// contours it; progress on stderr when it is a terminal.
/// `modelName` receives the name to report; `octrees` builds both octrees for the report.
/// Throws InputError, also for a model that voxelizes to no voxels (requireVoxels).
ModelBuild buildFromOptions(const ModelOptions& opt, std::string& modelName, bool octrees);

/// "model 'MODEL'" as the user gave it (or the joined --material names), for messages.
std::string modelSubject(const ModelOptions& opt, const Model& model);

}  // namespace voxcut::app
