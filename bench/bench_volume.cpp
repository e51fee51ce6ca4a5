// The model build of a real segmented CT at its native resolution against the bunny at a
// similar number of voxels: the time of each stage (reading, resampling or voxelizing,
// contouring, pieces, topology, both octrees) and the memory the grid takes, in one run so the
// two are compared on the same machine state.
//
//   build/release/bench/bench_volume [--repeats R] [--threads T] [--voxel-size H]
//
// The CT is data/volumes/ct-liver.nrrd (liver and lesion chosen, voxel 0.617188 mm by
// default: its own in-plane spacing). The bunny's resolution is chosen so that its occupied
// voxels come close to the liver's.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/io/VolumeReader.h"
#include "voxcut/sim/ModelBuild.h"

namespace voxcut {
namespace {

// Resident set size of the process now (MiB), from /proc/self/status; -1 when unknown.
double residentMiB() {
  std::ifstream in("/proc/self/status");
  std::string key;
  while (in >> key) {
    if (key == "VmRSS:") {
      double kib = 0;
      in >> kib;
      return kib / 1024.0;
    }
    std::getline(in, key);
  }
  return -1;
}

struct Result {
  std::map<std::string, double> ms;  // per stage, the median over the repeats
  std::size_t voxels = 0;
  double gridMiB = 0, estimateMiB = 0, rssMiB = 0;
  int resolution = 0;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Builds `model` `repeats` times; the read time (ms per repeat) is added as stage "read".
Result measure(const Model& model, const ModelBuildParams& params, int repeats,
               const std::vector<double>& readMs) {
  std::map<std::string, std::vector<double>> stages;
  Result r;
  for (int i = 0; i < repeats; ++i) {
    const ModelBuild b = buildModel(model, params);
    for (const auto& [stage, ms] : b.timings) stages[stage].push_back(ms);
    r.voxels = b.stats.voxels;
    r.gridMiB = static_cast<double>(b.grid.bytes()) / (1 << 20);
    r.estimateMiB = static_cast<double>(b.memory.bytes) / (1 << 20);
    r.rssMiB = residentMiB();
    r.resolution = std::max({b.grid.dims().x, b.grid.dims().y, b.grid.dims().z});
  }
  if (!readMs.empty()) stages["read"] = readMs;
  for (auto& [stage, v] : stages) r.ms[stage] = median(v);
  return r;
}

int run(int argc, char** argv) {
  int repeats = 3, threads = 2;
  double voxelSize = 0.617188e-3;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--repeats" && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--threads" && i + 1 < argc) {
      threads = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--voxel-size" && i + 1 < argc) {
      voxelSize = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr,
                   "usage: bench_volume [--repeats R] [--threads T] [--voxel-size H]\n");
      return 2;
    }
  }
  const ThreadLimit limit(threads);
  const std::string path = std::string(VOXCUT_SOURCE_DIR) + "/data/volumes/ct-liver.nrrd";

  std::vector<double> readMs;
  Model ct;
  for (int i = 0; i < repeats; ++i) {
    Timer t;
    ct = loadModel(path);
    readMs.push_back(t.ms());
  }
  ct.labels = {{255, "liver"}, {85, "tumor"}};
  ModelBuildParams params;
  params.voxelize.resolution.voxelSize = voxelSize;
  const Result liver = measure(ct, params, repeats, readMs);

  // The bunny at the resolution whose occupied voxels come closest to the liver's: volume
  // grows as the cube of the resolution, from a first build at 150.
  const Model bunny = loadModel("bunny");
  ModelBuildParams bp;
  bp.voxelize.resolution.resolution = 150;
  bp.octrees = false;
  const std::size_t at150 = buildModel(bunny, bp).stats.voxels;
  bp.octrees = true;
  bp.voxelize.resolution.resolution = static_cast<int>(std::lround(
      150.0 * std::cbrt(static_cast<double>(liver.voxels) / static_cast<double>(at150))));
  const Result rabbit = measure(bunny, bp, repeats, {});

  std::printf("model build, medians of %d, %d threads (ms; ratio = CT liver / bunny)\n", repeats,
              threads);
  std::printf("%-20s %14s %14s %8s\n", "", "CT liver", "bunny", "ratio");
  std::printf("%-20s %14d %14d\n", "resolution", liver.resolution, rabbit.resolution);
  std::printf("%-20s %14zu %14zu %8.2f\n", "occupied voxels", liver.voxels, rabbit.voxels,
              static_cast<double>(liver.voxels) / static_cast<double>(rabbit.voxels));
  double totalL = 0, totalB = 0;
  for (const char* stage : {"read", "voxelize", "cut", "contour", "pieces", "topology",
                            "voxel_octree", "deformation_octree"}) {
    const double l = liver.ms.count(stage) ? liver.ms.at(stage) : 0.0;
    const double b = rabbit.ms.count(stage) ? rabbit.ms.at(stage) : 0.0;
    totalL += l;
    totalB += b;
    const std::string label = std::string(stage) == "voxelize" ? "voxelize/resample" : stage;
    char ratio[16] = "-";
    if (b > 0) std::snprintf(ratio, sizeof ratio, "%.2f", l / b);
    std::printf("%-20s %14.1f %14.1f %8s\n", label.c_str(), l, b, ratio);
  }
  std::printf("%-20s %14.1f %14.1f %8.2f\n", "total", totalL, totalB, totalL / totalB);
  std::printf("%-20s %14.1f %14.1f %8.2f\n", "grid MiB", liver.gridMiB, rabbit.gridMiB,
              liver.gridMiB / rabbit.gridMiB);
  std::printf("%-20s %14.1f %14.1f %8.2f\n", "estimate MiB", liver.estimateMiB,
              rabbit.estimateMiB, liver.estimateMiB / rabbit.estimateMiB);
  std::printf("%-20s %14.1f %14.1f\n", "resident MiB after", liver.rssMiB, rabbit.rssMiB);
  return 0;
}

}  // namespace
}  // namespace voxcut

int main(int argc, char** argv) {
  try {
    return voxcut::run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_volume: error: %s\n", e.what());
    return 2;
  }
}
