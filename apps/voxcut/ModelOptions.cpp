#include "ModelOptions.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <sstream>

#include "voxcut/io/ModelSource.h"

namespace voxcut::app {
namespace {

Plane parsePlane(const std::string& text) {
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
      throw InputError("--cut-plane '" + text + "': '" + item + "' is not a finite number");
    v.push_back(x);
  }
  if (v.size() != 4) throw InputError("--cut-plane '" + text + "': expected NX,NY,NZ,D");
  return {Vec3d(v[0], v[1], v[2]), v[3]};
}

}  // namespace

void addModelOptions(CLI::App& cmd, ModelOptions& opt) {
  cmd.add_option("model", opt.model,
                 "Built-in model (bunny, liver, starfish, box:LX,LY,LZ, sphere:R; metres) or a "
                 "mesh file (OBJ, STL, PLY, OFF, ...)");
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
  cmd.add_option("--cut-plane", opt.cutPlanes,
                 "NX,NY,NZ,D: disconnect every link the plane n.x = d crosses (repeatable)");
  cmd.add_option("--threads", opt.threads, "Worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  cmd.add_flag("--json", opt.json, "Print one JSON object on stdout");
}

ModelBuild buildFromOptions(const ModelOptions& opt, std::string& modelName) {
  Model model;
  if (!opt.materials.empty()) {
    if (!opt.model.empty()) throw InputError("give either MODEL or --material, not both");
    std::vector<std::pair<std::string, std::string>> pairs;
    for (const auto& m : opt.materials) {
      const auto eq = m.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == m.size())
        throw InputError("--material '" + m + "': expected NAME=MESH");
      pairs.emplace_back(m.substr(0, eq), m.substr(eq + 1));
    }
    model = loadMaterials(pairs);
  } else {
    if (opt.model.empty()) throw InputError("no model given (try 'bunny', or see --help)");
    model = loadModel(opt.model);
  }
  modelName = model.name;

  ModelBuildParams params;
  if (opt.voxelSizeGiven) {
    if (!(opt.voxelSize > 0) || !std::isfinite(opt.voxelSize))
      throw InputError("--voxel-size must be a positive number of metres");
    params.voxelize.resolution.voxelSize = opt.voxelSize;
  } else {
    params.voxelize.resolution.resolution = opt.resolutionGiven ? opt.resolution : model.defaultResolution;
  }
  for (const auto& p : opt.cutPlanes) params.cuts.push_back(parsePlane(p));
  if (isatty(STDERR_FILENO)) {
    params.voxelize.progress = [](std::string_view stage, double f) {
      std::fprintf(stderr, "\r%.*s %3d%%", static_cast<int>(stage.size()), stage.data(),
                   static_cast<int>(std::lround(100 * f)));
      if (f >= 1.0) std::fprintf(stderr, "\r\033[K");
      std::fflush(stderr);
      return true;
    };
  }
  return buildModel(model.materials, params);
}

}  // namespace voxcut::app
