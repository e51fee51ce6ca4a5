// Static obstacles (docs/algorithms.md, "Contact"). Query: one signed-distance call, which the
// world makes per surface vertex and per element each frame: the Box obstacle as the baseline
// beside mesh obstacles of 12 triangles (the same box), an icosphere (5,120) and the bunny
// (3,674; both watertight), each 0.1 m across, for points near the surface (within 5 mm of
// it) and far (in a box three times its size), exact and with a bound of 1 cm (as nearShapes
// passes one). Landing: the object_collision stage per frame of a soft box dropped 0.3 m onto
// a table, as a Box obstacle and as the same box as a mesh, and 1 cm onto that mesh tilted by
// 10 degrees and onto the top of a ball mesh (5,120 triangles), the runs interleaved in each
// iteration.
//
//   build/release/bench/bench_obstacle --benchmark_min_time=0.2

#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "voxcut/collision/Obstacle.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"
#include "voxcut/voxel/BuiltinModels.h"

namespace voxcut {
namespace {

constexpr double kBound = 0.01;

/// The obstacles, each scaled to fit a 0.1 m cube centred at the origin.
const Obstacle& obstacleOf(const std::string& name) {
  static const Obstacle box = [] {
    Obstacle o;
    o.type = ObstacleType::Box;
    o.lo = Vec3d::Constant(-0.05);
    o.hi = Vec3d::Constant(0.05);
    return o;
  }();
  static const Obstacle boxMesh = meshObstacle(makeBox(Vec3d::Constant(0.1)));
  static const Obstacle sphere = meshObstacle(makeSphere(0.05, 4));
  static const Obstacle bunny = [] {
    TriangleMesh m = loadModel("bunny").materials.front().mesh;
    const auto [lo, hi] = m.bounds();
    const double scale = 0.1 / (hi - lo).maxCoeff();
    for (Vec3d& v : m.vertices) v = scale * (v - 0.5 * (lo + hi));
    return meshObstacle(m);
  }();
  if (name == "box") return box;
  if (name == "box_mesh") return boxMesh;
  if (name == "sphere_mesh") return sphere;
  return bunny;
}

/// 4096 points: near the obstacle's surface (the surface point nearest a random point of the
/// sphere of radius 0.05, moved up to 5 mm in a random direction) or far (anywhere in
/// [-0.15, 0.15]^3). The Box obstacle takes the points of its mesh.
std::vector<Vec3d> queries(const std::string& name, bool near) {
  const MeshDistance& surface = *obstacleOf(name == "box" ? "box_mesh" : name).mesh;
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3d> out;
  while (out.size() < 4096) {
    const Vec3d p(u(rng), u(rng), u(rng));
    if (!near) {
      out.push_back(0.15 * p);
    } else if (p.norm() > 0.1 && p.norm() < 1.0) {
      const Vec3d move(u(rng), u(rng), u(rng));
      out.push_back(surface.closestPoint(0.05 * p.normalized()) + 0.005 * move);
    }
  }
  return out;
}

/// args: near (1) or far (0), bounded (1) or exact (0).
void query(benchmark::State& state, const std::string& name) {
  const Obstacle& o = obstacleOf(name);
  const std::vector<Vec3d> points = queries(name, state.range(0) == 1);
  const double bound = state.range(1) == 1 ? kBound : std::numeric_limits<double>::infinity();
  std::size_t k = 0;
  for (auto _ : state) {
    Vec3d n;
    benchmark::DoNotOptimize(signedDistance(o, points[k], n, bound));
    benchmark::DoNotOptimize(n);
    k = (k + 1) % points.size();
  }
}

void cases(benchmark::internal::Benchmark* b) {
  b->ArgNames({"near", "bounded"});
  for (int near : {1, 0})
    for (int bounded : {0, 1}) b->Args({near, bounded});
}

void Box(benchmark::State& state) {
  query(state, "box");
}
void BoxMesh(benchmark::State& state) {
  query(state, "box_mesh");
}
void SphereMesh(benchmark::State& state) {
  query(state, "sphere_mesh");
}
void BunnyMesh(benchmark::State& state) {
  query(state, "bunny");
}

/// The table top 0.4 x 0.4 m at y = 0, 3 cm thick: a Box obstacle, or the same box as a mesh
/// rotated by `degrees` about z.
Obstacle table(bool mesh, double degrees) {
  if (!mesh) {
    Obstacle o;
    o.type = ObstacleType::Box;
    o.lo = Vec3d(-0.2, -0.03, -0.2);
    o.hi = Vec3d(0.2, 0.0, 0.2);
    return o;
  }
  TriangleMesh m = makeBox(Vec3d(0.4, 0.03, 0.4));
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(degrees * 3.14159265358979323846 / 180.0, Vec3d::UnitZ()).matrix();
  for (Vec3d& v : m.vertices) v = turn * (v - Vec3d(0, 0.015, 0));
  return meshObstacle(m);
}

/// object_collision ms per frame of a 0.1 x 0.06 x 0.08 m box (resolution 32, level-2 elements)
/// dropped from 0.3 m (0.01 m onto the tilted slab) for 150 frames.
double landing(const Obstacle& obstacle, double height) {
  const std::string json = R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
    "solver": {"tolerance": 1e-6, "max_iterations": 1000},
    "bodies": [{"model": "box:0.1,0.06,0.08", "resolution": 32, "element_level": 2,
      "offset": [0, )" + std::to_string(0.03 + height) +
                           R"(, 0], "materials": {"default": {"young_modulus": 1e5,
      "poisson_ratio": 0.3, "density": 1000, "damping": [2, 0.01]}}}]})";
  const Scene scene = parseScene(json, "landing", ".");
  World world = World::fromScene(scene, voxelizeSceneBodies(scene));
  world.addObstacle(obstacle);
  const auto& names = frameStageNames();
  const auto stage = static_cast<std::size_t>(
      std::find(names.begin(), names.end(), "object_collision") - names.begin());
  constexpr int kFrames = 150;
  double ms = 0.0;
  for (int f = 0; f < kFrames; ++f) ms += world.step().stageMs.at(stage);
  return ms / kFrames;
}

/// A ball of radius 0.5 m (5,120 triangles) whose top is at the origin.
Obstacle ball() {
  TriangleMesh m = makeSphere(0.5, 4);
  for (Vec3d& v : m.vertices) v.y() -= 0.5;
  Obstacle o = meshObstacle(m);
  o.friction = 0.5;
  return o;
}

void Landing(benchmark::State& state) {
  const Obstacle box = table(false, 0.0), mesh = table(true, 0.0), onBall = ball();
  Obstacle tilted = table(true, 10.0);
  tilted.friction = 0.5;
  double boxMs = 0.0, meshMs = 0.0, tiltedMs = 0.0, ballMs = 0.0, runs = 0.0;
  for (auto _ : state) {
    boxMs += landing(box, 0.3);
    meshMs += landing(mesh, 0.3);
    tiltedMs += landing(tilted, 0.01);
    ballMs += landing(onBall, 0.01);
    runs += 1.0;
  }
  state.counters["box_ms"] = boxMs / runs;
  state.counters["mesh_ms"] = meshMs / runs;
  state.counters["tilted_mesh_ms"] = tiltedMs / runs;
  state.counters["ball_mesh_ms"] = ballMs / runs;
}

BENCHMARK(Box)->Apply(cases);
BENCHMARK(BoxMesh)->Apply(cases);
BENCHMARK(SphereMesh)->Apply(cases);
BENCHMARK(BunnyMesh)->Apply(cases);
BENCHMARK(Landing)->Iterations(3)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace voxcut

BENCHMARK_MAIN();
