#include "ModelOptions.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "Interrupt.h"

namespace voxcut::app {

std::vector<double> parseNumberList(const std::string& text, const char* option, std::size_t count,
                                    const char* form) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    std::size_t used = 0;
    double x = 0;
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || !std::isfinite(x))
      throw InputError(std::string(option) + " '" + text + "': '" + item +
                       "' is not a finite number");
    v.push_back(x);
  }
  if (v.size() != count)
    throw InputError(std::string(option) + " '" + text + "': expected " + form);
  return v;
}

namespace {

Plane parsePlane(const std::string& text) {
  const std::vector<double> v = parseNumberList(text, "--cut-plane", 4, "NX,NY,NZ,D");
  return {Vec3d(v[0], v[1], v[2]), v[3]};
}

// Applies "L" (every material) or "NAME=L" entries to levels (indexed like materials).
void applyLevels(const std::vector<std::string>& entries, const char* option,
                 const std::vector<std::string>& materials, std::vector<int>& levels) {
  for (const std::string& e : entries) {
    const auto eq = e.find('=');
    const std::string value = eq == std::string::npos ? e : e.substr(eq + 1);
    int level = -1;
    std::size_t used = 0;
    try {
      level = std::stoi(value, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != value.size() || level < 0 || level > 16)
      throw InputError(std::string(option) + " '" + e + "': expected a level 0..16, or NAME=LEVEL");
    if (eq == std::string::npos) {
      std::fill(levels.begin(), levels.end(), level);
      continue;
    }
    const std::string name = e.substr(0, eq);
    const auto it = std::find(materials.begin(), materials.end(), name);
    if (it == materials.end())
      throw InputError(std::string(option) + " '" + e + "': no material named '" + name + "'");
    levels[static_cast<std::size_t>(it - materials.begin())] = level;
  }
}

}  // namespace

OctreeParams octreeParams(const ModelOptions& opt, const std::vector<std::string>& materials) {
  OctreeParams p = OctreeParams::uniform(materials.size(), 4, 0);
  // Plain values first, then per-material ones, whatever their order on the command line.
  std::vector<std::string> plainMax, namedMax, plainB, namedB;
  for (const auto& e : opt.maxLevel)
    (e.find('=') == std::string::npos ? plainMax : namedMax).push_back(e);
  for (const auto& e : opt.boundaryLevel)
    (e.find('=') == std::string::npos ? plainB : namedB).push_back(e);
  applyLevels(plainMax, "--max-level", materials, p.maxInternalLevel);
  applyLevels(namedMax, "--max-level", materials, p.maxInternalLevel);
  applyLevels(plainB, "--boundary-level", materials, p.maxBoundaryLevel);
  applyLevels(namedB, "--boundary-level", materials, p.maxBoundaryLevel);
  return p;
}

void addModelOptions(CLI::App& cmd, ModelOptions& opt, bool cutPlanes) {
  cmd.add_option("model", opt.model,
                 "Built-in model (bunny, liver, starfish, box:LX,LY,LZ, sphere:R; metres), a "
                 "mesh file (OBJ, STL, PLY, OFF, ...) or a label volume (NIfTI .nii/.nii.gz, "
                 "NRRD .nrrd/.nhdr/.seg.nrrd, MetaImage .mha/.mhd)");
  cmd.add_option("--material", opt.materials,
                 "NAME=MESH, repeatable, in order, instead of MODEL; later materials win inside "
                 "themselves (a tumor after its liver)");
  auto* res = cmd.add_option_function<int>(
      "--resolution",
      [&opt](const int& n) {
        opt.resolution = n;
        opt.resolutionGiven = true;
      },
      "Voxels along the longest side, padding included (default: the "
      "model's own, 101 for meshes)");
  auto* size = cmd.add_option_function<double>(
      "--voxel-size",
      [&opt](const double& h) {
        opt.voxelSize = h;
        opt.voxelSizeGiven = true;
      },
      "Voxel size in metres (instead of --resolution)");
  res->excludes(size);
  if (cutPlanes)
    cmd.add_option("--cut-plane", opt.cutPlanes,
                   "NX,NY,NZ,D: disconnect every link the plane n.x = d crosses (repeatable)");
  cmd.add_option("--max-level", opt.maxLevel,
                 "Voxel octree maximum internal level, for every material or NAME=L for one "
                 "(repeatable; default 4)");
  cmd.add_option("--boundary-level", opt.boundaryLevel,
                 "Voxel octree maximum inter-material boundary level, B or NAME=B (repeatable; "
                 "default 0)");
  cmd.add_option("--labels", opt.labels,
                 "Label volumes: the labels to make materials, VALUE=NAME,... (e.g. "
                 "255=liver,85=tumor), or all (default: every non-zero label, named by the "
                 "file or label_VALUE)");
  cmd.add_option("--label-names", opt.labelNames,
                 "Label volumes: a names file of 'VALUE NAME' lines (as the AAL atlas's "
                 "aal.nii.txt)");
  cmd.add_option("--min-island", opt.minIsland,
                 "Label volumes: drop pieces of a label smaller than N grid voxels (default 8; "
                 "0 keeps all)");
  cmd.add_option("--threads", opt.threads, "Worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  cmd.add_flag("--json", opt.json, "Print one JSON object on stdout");
  addMaxMemoryOption(cmd, opt.maxMemory);
}

void addMaxMemoryOption(CLI::App& cmd, std::string& maxMemory) {
  cmd.add_option("--max-memory", maxMemory,
                 "Refuse models estimated to need more memory than SIZE (bytes, or with a K, "
                 "M, G or T suffix: 512M, 8G; default: the available memory)")
      ->type_name("SIZE");
}

std::size_t memoryLimit(const std::string& maxMemory) {
  if (!maxMemory.empty()) return parseMemorySize(maxMemory, "--max-memory");
  return availableMemory();
}

Model loadFromOptions(const ModelOptions& opt, std::size_t maxMemory) {
  if (!opt.materials.empty()) {
    if (!opt.model.empty()) throw InputError("give either MODEL or --material, not both");
    if (!opt.labels.empty() || !opt.labelNames.empty())
      throw InputError("--labels and --label-names apply to a label volume, not to --material");
    std::vector<std::pair<std::string, std::string>> pairs;
    for (const auto& m : opt.materials) {
      const auto eq = m.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == m.size())
        throw InputError("--material '" + m + "': expected NAME=MESH");
      pairs.emplace_back(m.substr(0, eq), m.substr(eq + 1));
    }
    return loadMaterials(pairs);
  }
  if (opt.model.empty()) throw InputError("no model given (try 'bunny', or see --help)");
  ModelLoadParams lp;
  lp.maxMemory = maxMemory;
  lp.labelNames = opt.labelNames;
  Model model = loadModel(opt.model, lp);
  if (!model.isVolume()) {
    if (!opt.labels.empty() || !opt.labelNames.empty())
      throw InputError("--labels and --label-names apply to a label volume (.nii, .nii.gz, "
                       ".nrrd, .nhdr, .seg.nrrd, .mha, .mhd), not to model '" +
                       opt.model + "'");
    return model;
  }
  if (opt.minIsland < 0) throw InputError("--min-island must be 0 or more voxels");
  model.minIsland = opt.minIsland;
  if (!opt.labels.empty()) model.labels = parseLabelList(opt.labels, "--labels");
  checkLabelChoices(*model.volume,
                    model.labels.empty() ? defaultLabelChoices(*model.volume) : model.labels,
                    "--labels");
  return model;
}

void printModelWarnings(const Model& model, const LabelResampleReport& report) {
  if (model.volume)
    for (const std::string& w : model.volume->warnings)
      std::fprintf(stderr, "voxcut: warning: %s\n", w.c_str());
  for (const std::string& w : report.warnings)
    std::fprintf(stderr, "voxcut: warning: %s\n", w.c_str());
}

VoxelizeParams voxelizeParams(const ModelOptions& opt, const Model& model) {
  VoxelizeParams vp;
  if (opt.voxelSizeGiven) {
    if (!(opt.voxelSize > 0) || !std::isfinite(opt.voxelSize))
      throw InputError("--voxel-size must be a positive number of metres");
    vp.resolution.voxelSize = opt.voxelSize;
  } else {
    vp.resolution.resolution = opt.resolutionGiven ? opt.resolution : model.defaultResolution;
  }
  vp.progress = terminalProgress();
  return vp;
}

ProgressCallback terminalProgress() {
  const bool terminal = isatty(STDERR_FILENO) != 0;
  return [terminal](std::string_view stage, double f) {
    if (terminal) {
      std::fprintf(stderr, "\r%.*s %3d%%", static_cast<int>(stage.size()), stage.data(),
                   static_cast<int>(std::lround(100 * f)));
      if (f >= 1.0) std::fprintf(stderr, "\r\033[K");
      std::fflush(stderr);
    }
    return !interruptRequested();
  };
}

ModelBuild buildFromOptions(const ModelOptions& opt, std::string& modelName, bool octrees) {
  const std::size_t limit = memoryLimit(opt.maxMemory);
  const Model model = loadFromOptions(opt, limit);
  modelName = model.name;
  ModelBuildParams params;
  params.voxelize = voxelizeParams(opt, model);
  params.octree = octreeParams(opt, model.materialNames());
  params.octrees = octrees;
  params.maxMemory = limit;
  for (const auto& p : opt.cutPlanes) params.cuts.push_back(parsePlane(p));
  ModelBuild build = buildModel(model, params);
  printModelWarnings(model, build.resampleReport);
  requireVoxels(build.grid, modelSubject(opt, model));
  return build;
}

std::string modelSubject(const ModelOptions& opt, const Model& model) {
  return "model '" + (opt.model.empty() ? model.name : opt.model) + "'";
}

}  // namespace voxcut::app
