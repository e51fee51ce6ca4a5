// Benchmarks of one implicit Euler step (ImplicitEuler.h) of the composite hexahedral FEM:
//  - Bunny: the bunny at resolution 101 (level-3/4 elements), base fixed, gravity, a softer
//    material than scenes/bunny-ear.json's (E 1e5 Pa, nu 0.4, damping [1, 0.01]; the scene
//    has E 1e6 Pa, damping [20, 0.005]) and its solver settings (dt 4 ms, tolerance 1e-3,
//    100 iterations);
//  - BunnyCut: the same after the blade of scenes/bunny-ear.json has cut through the ear's
//    base (elements there refined to level 0, so 1-voxel elements meet level-3 ones);
//  - Cantilever: scenes/cantilever.json (6,427 nodes of level-1 elements, E 1e7 Pa,
//    tolerance 1e-4, 400 iterations).
//  - BunnyScaling: the bunny at resolutions 173, 241 and 301 (about 3.1k, 6.3k and 10.3k
//    nodes), E 1e5 Pa, nu 0.3, dt 10 ms, relative tolerance 1e-6, one thread, with Jacobi,
//    TwoLevel, Cholesky and Multigrid, each with the start projected onto the last 8
//    solutions (the default) and from the previous step's dv alone (arguments: resolution,
//    preconditioner, solutions kept): how the step grows with the size of the body;
//  - BunnyThreads: the scaling case at resolutions 301 and 173 (about 10.3k and 3.1k nodes)
//    with Multigrid and the start projected onto the last 8 solutions, at 1, 2, 4, 8 and 16
//    threads (arguments: resolution, threads): how the step scales with the threads
//    (scripts/thread_scaling.sh);
//  - DirectSolvers: our block Cholesky against CHOLMOD (SuiteSparse) on the scaling case's
//    reduced matrix, one factorisation and solve per iteration (arguments: resolution,
//    solver);
//  - Constraints: BunnyCut's reduced-system structure rebuilt in full (ElasticModel::setFixed,
//    as for new fixed nodes; after a cut, updateTopology copies the rows away from it:
//    bench_topology ModelUpdate).
// Each step benchmark runs with 1 and 2 worker threads (first argument) and each
// preconditioner (second: 0 Jacobi, 1 BlockJacobi, 2 SymmetricGaussSeidel, 3
// IncompleteCholesky, 4 TwoLevel, 5 Cholesky, 6 Multigrid). A body is first
// stepped 20 times from rest (the warm start and rotations then look like a running
// simulation), then each benchmark iteration is one step, timed alone (manual time).
// Counters: iterations per step, assembly, solve, preconditioner set-up and iteration milliseconds
// per step (bench_step_parts gives every part of the step), steps that did not
// converge.
//
//   build/release/bench/bench_fem --benchmark_filter=Bunny

#include <benchmark/benchmark.h>

#include <Eigen/CholmodSupport>
#include <map>
#include <string>
#include <vector>

#include "FemCases.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEuler.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/linalg/BlockCholesky.h"
#include "voxcut/topology/CutTopology.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

using bench::FemCase;
using bench::bunnyBody;
using bench::earCutLinks;
using bench::fixBox;
using bench::scalingCase;
using bench::voxelGrid;

FemCase bunnyCase(bool cut) {
  FemCase c = bunnyBody(101, {1e5, 0.4, 1000.0, 1.0, 0.01}, cut);
  c.params.timeStep = 0.004;
  c.params.tolerance = 1e-3;
  c.params.maxIterations = 100;
  return c;
}

FemCase cantileverCase() {
  FemCase c;
  c.grid = voxelGrid("box:0.2,0.02,0.02", 162);
  DeformationOctreeParams dp;
  dp.startLevel = 1;
  dp.maxLevel = 2;
  c.octree = buildDeformationOctree(c.grid, dp);
  std::vector<ElasticMaterial> mats(2);
  mats[1] = {1e7, 0.3, 1000.0, 2.0, 0.002};
  c.model = ElasticModel(c.octree, c.grid, mats);
  fixBox(c, Vec3d(-0.11, -0.02, -0.02), Vec3d(-0.1, 0.02, 0.02));
  c.params.timeStep = 0.004;
  c.params.gravity = Vec3d(0, -9.81, 0);
  c.params.tolerance = 1e-4;
  c.params.maxIterations = 400;
  return c;
}

void runSteps(benchmark::State& state, const FemCase& base, long threadsArg, long preconditioner,
              long projectionHistory = ImplicitEulerParams{}.projectionHistory) {
  const int threads = static_cast<int>(threadsArg);
  const ThreadLimit limit(threads);
  DeformationOctree octree = base.octree;
  ImplicitEulerParams params = base.params;
  params.preconditioner = static_cast<PreconditionerKind>(preconditioner);
  params.projectionHistory = static_cast<int>(projectionHistory);
  ImplicitEuler solver(params);
  for (int s = 0; s < 20; ++s) (void)solver.step(base.model, octree);
  double iterations = 0, assembly = 0, solve = 0, failed = 0, steps = 0;
  StepParts parts;
  for (auto _ : state) {
    Timer timer;
    const StepStatus st = solver.step(base.model, octree);
    state.SetIterationTime(timer.ms() * 1e-3);
    iterations += st.iterations;
    assembly += st.assemblyMs;
    solve += st.solveMs;
    failed += st.converged ? 0 : 1;
    steps += 1;
    parts.setup += st.parts.setup;
    parts.iterations += st.parts.iterations;
  }
  state.counters["setup_ms"] = parts.setup / steps;
  state.counters["iterate_ms"] = parts.iterations / steps;
  state.counters["threads"] = threads;
  state.counters["free_nodes"] = static_cast<double>(base.model.freeNodeCount());
  state.counters["blocks"] = static_cast<double>(base.model.sparsity().blockCount());
  state.counters["aggregates"] = static_cast<double>(base.model.aggregation().count());
  state.counters["iterations"] = iterations / steps;
  state.counters["assembly_ms"] = assembly / steps;
  state.counters["solve_ms"] = solve / steps;
  state.counters["not_converged"] = failed;
  state.counters["projection"] = params.projectionHistory;
  state.SetLabel(preconditionerName(params.preconditioner));
}

void Bunny(benchmark::State& state) {
  static const FemCase c = bunnyCase(false);
  runSteps(state, c, state.range(0), state.range(1));
}

void BunnyCut(benchmark::State& state) {
  static const FemCase c = bunnyCase(true);
  runSteps(state, c, state.range(0), state.range(1));
}

void Cantilever(benchmark::State& state) {
  static const FemCase c = cantileverCase();
  runSteps(state, c, state.range(0), state.range(1));
}


/// Arguments: resolution, preconditioner, solutions kept for the start's projection
/// (ImplicitEulerParams::projectionHistory: 8, the default, or 0 for the previous step's dv
/// alone, the warm start Jacobi-PCG solvers such as Vega's use); one thread.
void BunnyScaling(benchmark::State& state) {
  static std::map<int, FemCase> cases;
  const int resolution = static_cast<int>(state.range(0));
  if (!cases.contains(resolution)) cases.emplace(resolution, scalingCase(resolution));
  state.counters["nodes"] = static_cast<double>(cases.at(resolution).octree.nodeCount());
  runSteps(state, cases.at(resolution), 1, state.range(1), state.range(2));
}

/// Arguments: resolution, threads; the scaling case with the multigrid preconditioner and the
/// start projected onto the last 8 solutions (the solver's default start).
void BunnyThreads(benchmark::State& state) {
  static std::map<int, FemCase> cases;
  const int resolution = static_cast<int>(state.range(0));
  if (!cases.contains(resolution)) cases.emplace(resolution, scalingCase(resolution));
  state.counters["nodes"] = static_cast<double>(cases.at(resolution).octree.nodeCount());
  runSteps(state, cases.at(resolution), state.range(1),
           static_cast<long>(PreconditionerKind::Multigrid), 8);
}

/// The direct solvers on the scaling case's reduced matrix after 20 steps: our block
/// Cholesky (BlockCholesky.h) against CHOLMOD's supernodal Cholesky (SuiteSparse, through
/// Eigen's CholmodSupport), each analysed once and then timed for one factorisation and one
/// solve per iteration. Arguments: resolution, solver (0 block Cholesky, 1 CHOLMOD); one
/// thread (CHOLMOD's BLAS may use its own threads: run with OPENBLAS_NUM_THREADS=1).
void DirectSolvers(benchmark::State& state) {
  static std::map<int, std::pair<FemCase, Eigen::SparseMatrix<double>>> cases;
  const int resolution = static_cast<int>(state.range(0));
  const ThreadLimit limit(1);
  if (!cases.contains(resolution)) {
    FemCase c = scalingCase(resolution);
    c.params.preconditioner = PreconditionerKind::Multigrid;
    DeformationOctree octree = c.octree;
    ImplicitEuler solver(c.params);
    for (int s = 0; s < 20; ++s) (void)solver.step(c.model, octree);
    Eigen::SparseMatrix<double> a = solver.reducedMatrix(c.model);
    cases.emplace(resolution, std::pair{std::move(c), std::move(a)});
  }
  const auto& [c, a] = cases.at(resolution);
  const BlockSparsity& sp = c.model.sparsity();
  const std::size_t rows = c.model.freeNodeCount();
  std::vector<Vec3d> b(rows, Vec3d(0.0, -1.0, 0.0)), x;
  Eigen::VectorXd bv = Eigen::Map<const Eigen::VectorXd>(b.data()->data(), 3 * rows);
  double analyseMs = 0.0, residual = 0.0, fill = 0.0;
  if (state.range(1) == 0) {
    const std::vector<Eigen::Matrix3d> blocks = bench::reducedBlocks(sp, a);
    BlockCholesky chol;
    Timer t;
    chol.analyse(sp);
    analyseMs = t.ms();
    for (auto _ : state) {
      Timer timer;
      if (!chol.factorise(sp, blocks, false)) state.SkipWithError("not positive definite");
      chol.solve(b, x);
      state.SetIterationTime(timer.ms() * 1e-3);
    }
    fill = static_cast<double>(chol.offDiagonalBlocks()) * 9.0 + 6.0 * static_cast<double>(rows);
    residual = (a * Eigen::Map<const Eigen::VectorXd>(x.data()->data(), 3 * rows) - bv).norm();
    state.SetLabel("block_cholesky");
  } else {
    Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> chol;
    Timer t;
    chol.analyzePattern(a);
    analyseMs = t.ms();
    Eigen::VectorXd xv;
    for (auto _ : state) {
      Timer timer;
      chol.factorize(a);
      xv = chol.solve(bv);
      state.SetIterationTime(timer.ms() * 1e-3);
    }
    fill = static_cast<double>(chol.cholmod().lnz);
    residual = (a * xv - bv).norm();
    state.SetLabel("cholmod_supernodal");
  }
  state.counters["free_nodes"] = static_cast<double>(rows);
  state.counters["analyse_ms"] = analyseMs;
  state.counters["factor_entries"] = fill;
  state.counters["relative_residual"] = residual / bv.norm();
}

void allSettings(benchmark::internal::Benchmark* b) {
  for (int p = 0; p < 7; ++p)
    for (int t : {1, 2}) b->Args({t, p});
  b->UseManualTime()->Unit(benchmark::kMillisecond)->MinTime(0.3);
}

/// The reduced system's structure rebuilt in full (hanging-node prolongation, restriction,
/// block sparsity with its sources), here on BunnyCut's model: what ElasticModel::setFixed
/// redoes. Threads: the argument.
void Constraints(benchmark::State& state) {
  const ThreadLimit limit(static_cast<int>(state.range(0)));
  static FemCase c = bunnyCase(true);
  const std::vector<std::uint8_t> fixed = c.model.fixed();
  for (auto _ : state) {
    Timer timer;
    c.model.setFixed(fixed);
    state.SetIterationTime(timer.ms() * 1e-3);
  }
  state.counters["threads"] = static_cast<double>(state.range(0));
  state.counters["blocks"] = static_cast<double>(c.model.sparsity().blockCount());
  state.counters["sources"] = static_cast<double>(c.model.sparsity().source.size());
}

BENCHMARK(BunnyScaling)
    ->ArgsProduct({{173, 241, 301}, {0, 4, 5, 6}, {8, 0}})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.3);
BENCHMARK(BunnyThreads)
    ->ArgsProduct({{301, 173}, {1, 2, 4, 8, 16}})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.3);
BENCHMARK(DirectSolvers)
    ->ArgsProduct({{173, 241, 301}, {0, 1}})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.3);
BENCHMARK(Bunny)->Apply(allSettings);
BENCHMARK(BunnyCut)->Apply(allSettings);
BENCHMARK(Cantilever)->Apply(allSettings);
BENCHMARK(Constraints)
    ->Arg(1)
    ->Arg(2)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.3);

}  // namespace
}  // namespace voxcut

BENCHMARK_MAIN();
