// Benchmarks of the model path: voxelizing and dual-contouring the built-in models,
// each stage alone at two resolutions and with 1 and 2 worker threads, so one run compares
// the stages and the thread counts side by side.
//
//   build/release/bench/bench_model --benchmark_min_time=0.2

#include <benchmark/benchmark.h>

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/surface/DualContour.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

/// The materials of a built-in model, loaded once per process.
const std::vector<MaterialMesh>& materialsOf(const std::string& name) {
  static std::map<std::string, std::vector<MaterialMesh>> cache;
  auto it = cache.find(name);
  if (it == cache.end()) it = cache.emplace(name, loadModel(name).materials).first;
  return it->second;
}

VoxelizeParams voxelizeParams(int resolution) {
  VoxelizeParams p;
  p.resolution.resolution = resolution;
  return p;
}

std::size_t occupiedVoxels(const VoxelGrid& grid) {
  std::size_t n = 0;
  for (std::size_t v = 0; v < grid.voxelCount(); ++v) n += grid.occupied(v) ? 1 : 0;
  return n;
}

void setCounters(benchmark::State& state, const VoxelGrid* grid, const SurfaceMesh* surface,
                 int threads) {
  state.counters["threads"] = threads;
  if (grid) state.counters["voxels"] = static_cast<double>(occupiedVoxels(*grid));
  if (surface) state.counters["surf_verts"] = static_cast<double>(surface->positions.size());
}

/// Voxelizes `model`; args: resolution, threads.
void voxelizeModel(benchmark::State& state, const std::string& model) {
  const auto& materials = materialsOf(model);
  const int threads = static_cast<int>(state.range(1));
  const ThreadLimit limit(threads);
  const VoxelizeParams params = voxelizeParams(static_cast<int>(state.range(0)));
  VoxelGrid grid;
  for (auto _ : state) {
    grid = voxelize(materials, params);
    benchmark::DoNotOptimize(grid);
  }
  setCounters(state, &grid, nullptr, threads);
}

/// Dual-contours `model`, voxelized once outside the timed loop; args: resolution, threads.
void dualContourModel(benchmark::State& state, const std::string& model) {
  const int threads = static_cast<int>(state.range(1));
  const ThreadLimit limit(threads);
  const VoxelGrid grid =
      voxelize(materialsOf(model), voxelizeParams(static_cast<int>(state.range(0))));
  SurfaceMesh surface;
  for (auto _ : state) {
    surface = dualContour(grid);
    benchmark::DoNotOptimize(surface);
  }
  setCounters(state, &grid, &surface, threads);
}

/// Voxelizes and dual-contours `model`, both timed; args: resolution, threads.
void voxelizeAndContourModel(benchmark::State& state, const std::string& model) {
  const auto& materials = materialsOf(model);
  const int threads = static_cast<int>(state.range(1));
  const ThreadLimit limit(threads);
  const VoxelizeParams params = voxelizeParams(static_cast<int>(state.range(0)));
  VoxelGrid grid;
  SurfaceMesh surface;
  for (auto _ : state) {
    grid = voxelize(materials, params);
    surface = dualContour(grid);
    benchmark::DoNotOptimize(surface);
  }
  setCounters(state, &grid, &surface, threads);
}

void configure(benchmark::internal::Benchmark* b, std::vector<int> resolutions) {
  b->ArgNames({"res", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
  for (const int r : resolutions)
    for (const int t : {1, 2}) b->Args({r, t});
}

BENCHMARK_CAPTURE(voxelizeModel, bunny, std::string("bunny"))->Apply([](auto* b) {
  configure(b, {101, 256});
});
BENCHMARK_CAPTURE(dualContourModel, bunny, std::string("bunny"))->Apply([](auto* b) {
  configure(b, {101, 256});
});
BENCHMARK_CAPTURE(voxelizeAndContourModel, liver, std::string("liver"))->Apply([](auto* b) {
  configure(b, {100});
});
BENCHMARK_CAPTURE(voxelizeAndContourModel, starfish, std::string("starfish"))->Apply([](auto* b) {
  configure(b, {180});
});

}  // namespace
}  // namespace voxcut

BENCHMARK_MAIN();
