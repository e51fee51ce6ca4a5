// Benchmarks of the deformation octree's cut-topology update (updateCutTopology, CutTopology.h)
// on the bunny at resolution 101 (level-3/4 elements, cut elements refined to level 0):
//  - BladeSequence: a horizontal blade advancing front to back through the ears, like
//    scenes/bunny-ear.json (100 frames, a few links per frame); counters give the mean and
//    the largest single update in milliseconds.
//  - PlaneCut: one plane through the ears at once (about 1,500 links).
//  - ModelUpdate: the composite FEM model following BladeSequence's updates, the bunny fixed
//    at its base. Per update, ElasticModel::updateTopology is timed (new elements' matrices,
//    node masses, prolongation, and the block sparsity with the rows of unchanged
//    neighbourhoods copied), and right after it, on a copy, the full rebuild of the reduced
//    structure that the update replaces (setFixed: prolongation and every row gathered
//    anew). Counters: both means per update, their ratio, the share of rows copied.
// Each runs with 1 and 2 worker threads. Only the updates are timed (manual time); copying the
// octree and disconnecting the links before each update are not.
//
//   build/release/bench/bench_topology --benchmark_repetitions=3

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/topology/CutTopology.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

/// The bunny at resolution 101 and its deformation octree (default build: levels 3/4, parts
/// split), made once per process.
struct BunnyCase {
  VoxelGrid grid;
  DeformationOctree octree;
};

const BunnyCase& bunny() {
  static const BunnyCase c = [] {
    VoxelizeParams vp;
    vp.resolution.resolution = 101;
    BunnyCase b{voxelize(loadModel("bunny").materials, vp), {}};
    b.octree = buildDeformationOctree(b.grid);
    return b;
  }();
  return c;
}

/// The connected y-links of the rest grid that the blade of scenes/bunny-ear.json crosses in
/// each of its `frames` frames: the blade is the segment x in [-0.044, 0.012] m at height
/// 0.129 m, moving along z from 0.025 m to -0.025 m; frame f sweeps z in (z(f+1), z(f)].
std::vector<std::vector<std::uint64_t>> bladeFrames(const VoxelGrid& g, int frames) {
  const double h = g.voxelSize(), y = 0.129, x0 = -0.044, x1 = 0.012, z0 = 0.025, z1 = -0.025;
  std::vector<std::vector<std::uint64_t>> out(static_cast<std::size_t>(frames));
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    if (!g.hasLink(v, 1) || !g.connected(v, 1)) continue;
    const Vec3d p = g.position(v);
    if (!(p.y() < y && p.y() + h >= y) || p.x() < x0 || p.x() > x1) continue;
    // Frame f covers (z0 + (f+1) dz, z0 + f dz] with dz < 0.
    const double dz = (z1 - z0) / frames;
    const double f = (p.z() - z0) / dz;
    if (f < 0 || f >= frames) continue;
    out[static_cast<std::size_t>(f)].push_back(VoxelGrid::linkId(v, 1));
  }
  return out;
}

/// The connected links crossed by the plane n.x = d (voxel coordinates), as in
/// tests/topology/CutTopologyTest.cpp's bunny ear cut.
std::vector<std::uint64_t> planeLinks(const VoxelGrid& g, const Vec3d& n, double d) {
  std::vector<std::uint64_t> ids;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    const Index3 c = g.coord(v);
    const double sv = n.dot(Vec3d(c.x, c.y, c.z)) - d;
    for (int a = 0; a < 3; ++a) {
      if (!g.hasLink(v, a) || !g.connected(v, a)) continue;
      Index3 w = c;
      ++w[a];
      if ((sv < 0) != (n.dot(Vec3d(w.x, w.y, w.z)) - d < 0)) ids.push_back(VoxelGrid::linkId(v, a));
    }
  }
  return ids;
}

void disconnect(VoxelGrid& g, const std::vector<std::uint64_t>& links) {
  for (std::uint64_t id : links)
    g.setConnected(static_cast<std::size_t>(id / 3), static_cast<int>(id % 3), false);
}

/// Runs `cuts` in order on fresh copies of the bunny, timing only the updates.
void runCuts(benchmark::State& state, const std::vector<std::vector<std::uint64_t>>& cuts) {
  const int threads = static_cast<int>(state.range(0));
  const ThreadLimit limit(threads);
  const BunnyCase& base = bunny();
  CutTopologyParams params;
  params.threaded = threads > 1;
  double maxMs = 0, sumMs = 0;
  std::size_t updates = 0, links = 0, elements = 0, nodes = 0, hanging = 0;
  for (auto _ : state) {
    VoxelGrid grid = base.grid;
    DeformationOctree octree = base.octree;
    double total = 0;
    links = 0;
    for (const auto& cut : cuts) {
      if (cut.empty()) continue;
      disconnect(grid, cut);
      Timer timer;
      const TopologyChange tc = updateCutTopology(octree, grid, cut, params);
      const double ms = timer.ms();
      benchmark::DoNotOptimize(tc);
      total += ms;
      maxMs = std::max(maxMs, ms);
      sumMs += ms;
      ++updates;
      links += cut.size();
    }
    state.SetIterationTime(total * 1e-3);
    elements = octree.elementCount();
    nodes = octree.nodeCount();
    hanging = octree.hangingNodeCount();
  }
  state.counters["threads"] = threads;
  state.counters["links"] = static_cast<double>(links);
  state.counters["updates"] = static_cast<double>(
      std::count_if(cuts.begin(), cuts.end(), [](const auto& c) { return !c.empty(); }));
  state.counters["elements"] = static_cast<double>(elements);
  state.counters["nodes"] = static_cast<double>(nodes);
  state.counters["hanging"] = static_cast<double>(hanging);
  state.counters["mean_ms"] = updates ? sumMs / static_cast<double>(updates) : 0.0;
  state.counters["max_ms"] = maxMs;
}

void BladeSequence(benchmark::State& state) {
  static const std::vector<std::vector<std::uint64_t>> frames = bladeFrames(bunny().grid, 100);
  runCuts(state, frames);
}

void PlaneCut(benchmark::State& state) {
  const VoxelGrid& g = bunny().grid;
  static const std::vector<std::vector<std::uint64_t>> cut{
      planeLinks(g, Vec3d(0.2, 1, 0.1), 0.78 * g.dims().y)};
  runCuts(state, cut);
}

void ModelUpdate(benchmark::State& state) {
  static const std::vector<std::vector<std::uint64_t>> frames = bladeFrames(bunny().grid, 100);
  const int threads = static_cast<int>(state.range(0));
  const ThreadLimit limit(threads);
  const BunnyCase& base = bunny();
  std::vector<ElasticMaterial> materials(2);
  materials[1] = {1e5, 0.4, 1000.0, 1.0, 0.01};
  double updateMs = 0, rebuildMs = 0, rows = 0, copied = 0, updates = 0;
  for (auto _ : state) {
    VoxelGrid grid = base.grid;
    DeformationOctree octree = base.octree;
    ElasticModel model(octree, grid, materials);
    std::vector<std::uint8_t> fixed(octree.nodeCount(), 0);
    for (std::size_t n = 0; n < fixed.size(); ++n)
      fixed[n] = octree.restPositions()[n].y() <= 0.004 ? 1 : 0;
    model.setFixed(fixed);
    double total = 0;
    for (const auto& cut : frames) {
      if (cut.empty()) continue;
      disconnect(grid, cut);
      const TopologyChange tc = updateCutTopology(octree, grid, cut);
      if (!tc.changed) continue;
      Timer timer;
      model.updateTopology(octree, grid, tc);
      const double ms = timer.ms();
      total += ms;
      updateMs += ms;
      ElasticModel full = model;
      timer.restart();
      full.setFixed(model.requestedFixed());
      rebuildMs += timer.ms();
      rows += static_cast<double>(model.freeNodeCount());
      copied += static_cast<double>(model.sparsityRowsReused());
      updates += 1;
    }
    state.SetIterationTime(total * 1e-3);
  }
  state.counters["threads"] = threads;
  state.counters["update_ms"] = updates > 0 ? updateMs / updates : 0.0;
  state.counters["rebuild_ms"] = updates > 0 ? rebuildMs / updates : 0.0;
  state.counters["update/rebuild"] = rebuildMs > 0 ? updateMs / rebuildMs : 0.0;
  state.counters["rows_copied"] = rows > 0 ? copied / rows : 0.0;
}

BENCHMARK(BladeSequence)
    ->Arg(1)
    ->Arg(2)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5);
BENCHMARK(PlaneCut)->Arg(1)->Arg(2)->UseManualTime()->Unit(benchmark::kMillisecond)->MinTime(0.5);
BENCHMARK(ModelUpdate)
    ->Arg(1)
    ->Arg(2)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5);

}  // namespace
}  // namespace voxcut

BENCHMARK_MAIN();
