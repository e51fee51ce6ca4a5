// One implicit Euler step (fem/ImplicitEuler.h) by its parts, against what each part's
// arithmetic costs on this machine (docs/performance.md, "The step by its parts").
//
// The body: bench_fem's scaling case (bench/FemCases.h; the bunny at resolutions 173, 241 and
// 301: about 3.1k, 6.3k and 10.3k nodes; base fixed, under gravity, E 1e5 Pa, nu 0.3, dt 10 ms,
// relative tolerance 1e-6), one thread. Each run steps a fresh solver with the automatic
// preconditioner choice 20 times from rest, then --steps times measured, the wall time of
// every part of each step taken from StepStatus::parts; then the same with Jacobi-PCG started
// from the previous step's solution alone (projectionHistory 0), the baseline the issue's
// "8x Jacobi" is measured against. Runs repeat --runs times; the tables give the median over
// the runs of each run's mean, and the range.
//
// The machine's rates, measured twice in the same process before the runs (after one warm-up
// measurement; the better of each pair is a rate the machine reached): the rate it reads
// memory at (a dot product of two 128 MB arrays, one thread, the best of 5; the parts mostly
// read), the same over arrays a quarter of the last-level cache's size, and its rate of 3x3
// block products held in cache (a block matrix of 295 kB times a vector, the product's own
// kernel, linalg/BlockMatrix.h). Each part's bound is the larger of its bytes over the bandwidth
// (the cache's where the part's data fits in three quarters of it) and its flops over the in-cache
// rate, from a count of what it must read, write and compute (partWork below,
// docs/performance.md).
// These are models of the data each part moves at least, not counters.
//
//   build/release/bench/bench_step_parts [--sizes 173,241,301] [--runs 3] [--steps 20]
//   build/release/bench/bench_step_parts --weights   # the automatic choice's weights

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "FemCases.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/linalg/BlockMatrix.h"
#include "voxcut/linalg/Multigrid.h"
#include "voxcut/linalg/TwoLevelPreconditioner.h"

namespace voxcut {
namespace {

/// The machine's measured rates.
struct Rates {
  double bandwidth = 0.0;       ///< bytes per second, streaming from memory, one thread
  double cacheBandwidth = 0.0;  ///< the same for data that stays in the last-level cache
  double blockRate = 0.0;       ///< 3x3 block products per second, in cache
  double cacheBytes = 8e6;      ///< the last-level cache's size

  /// The better of two measurements of each rate (each is a rate the machine reached).
  [[nodiscard]] Rates best(const Rates& o) const {
    return {std::max(bandwidth, o.bandwidth), std::max(cacheBandwidth, o.cacheBandwidth),
            std::max(blockRate, o.blockRate), cacheBytes};
  }
};

template <class F>
double bestSeconds(int repeats, F&& f) {
  double best = 1e30;
  for (int k = 0; k < repeats; ++k) {
    const Timer t;
    f();
    best = std::min(best, t.ms() * 1e-3);
  }
  return best;
}

/// The best of `repeats` times of one product y = A x with `a` (ms).
double productMs(const BlockMatrixView& a, const std::vector<Vec3d>& x, std::vector<Vec3d>& y,
                 int repeats) {
  return 1e3 * bestSeconds(repeats, [&] {
           for (std::size_t i = 0; i < a.rows; ++i) y[i] = blockRowProduct(a, x.data(), i);
         });
}

/// Bytes per second read by a dot product of two arrays of n doubles (four sums, so that the
/// adds do not wait on each other), the best of `repeats`, each running it `inner` times. The
/// step's parts mostly read (a matrix, element matrices), so a reading rate bounds them.
double readRate(std::size_t n, int repeats, int inner) {
  std::vector<double> a(n, 1.0), b(n, 0.5);
  double sum = 0.0;
  const double s = bestSeconds(repeats, [&] {
    for (int k = 0; k < inner; ++k) {
      double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
      for (std::size_t i = 0; i + 3 < n; i += 4) {
        s0 += a[i] * b[i];
        s1 += a[i + 1] * b[i + 1];
        s2 += a[i + 2] * b[i + 2];
        s3 += a[i + 3] * b[i + 3];
      }
      sum += s0 + s1 + s2 + s3;
    }
  });
  if (!std::isfinite(sum)) std::fprintf(stderr, "(non-finite)\n");  // keeps the loop alive
  return 2.0 * 8.0 * static_cast<double>(n) * inner / s;
}

/// The last-level cache's size from sysfs (bytes; 8 MB when it cannot be read).
double lastLevelCache() {
  double best = 0.0;
  for (int index = 0; index < 8; ++index) {
    const std::string dir = "/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(index);
    std::FILE* f = std::fopen((dir + "/size").c_str(), "r");
    if (f == nullptr) continue;
    double size = 0.0;
    char unit = 0;
    if (std::fscanf(f, "%lf%c", &size, &unit) >= 1)
      best = std::max(best, size * (unit == 'K' ? 1024.0 : unit == 'M' ? 1048576.0 : 1.0));
    std::fclose(f);
  }
  return best > 0.0 ? best : 8e6;
}

Rates measureRates() {
  Rates r;
  r.cacheBytes = lastLevelCache();
  r.bandwidth = readRate(std::size_t{16} << 20, 5, 1);  // 128 MB per array
  // Two arrays together a quarter of the cache.
  const auto inCache = static_cast<std::size_t>(r.cacheBytes / (4.0 * 2.0 * 8.0));
  r.cacheBandwidth = readRate(inCache, 5, 20);
  // A block matrix of 256 rows x 16 blocks (random columns), 295 kB, times a vector, 400
  // times: the fine product's kernel on data in cache.
  const std::size_t rows = 256, perRow = 16;
  BlockMatrix m;
  std::mt19937 rng(7);
  for (std::size_t i = 0; i < rows; ++i) {
    for (std::size_t k = 0; k < perRow; ++k) {
      m.column.push_back(static_cast<std::uint32_t>(rng() % rows));
      m.blocks.push_back(Eigen::Matrix3d::Constant(1e-3 * static_cast<double>(k + 1)));
    }
    m.rowStart.push_back(static_cast<std::uint32_t>(m.column.size()));
    m.diagonal.push_back(m.rowStart[i]);
  }
  std::vector<Vec3d> x(rows, Vec3d::Ones()), y(rows);
  const BlockMatrixView v = m.view();
  const int sweeps = 400;
  const double t = bestSeconds(5, [&] {
    for (int k = 0; k < sweeps; ++k) {
      for (std::size_t i = 0; i < rows; ++i) y[i] = blockRowProduct(v, x.data(), i);
      std::swap(x, y);
    }
  });
  r.blockRate = static_cast<double>(sweeps * rows * perRow) / t;
  if (!x[0].allFinite()) std::fprintf(stderr, "(non-finite)\n");  // keeps the loop alive
  return r;
}

/// Bytes and flops of one part (per step), and the data it works on: what stays in the
/// last-level cache between its passes streams at the cache's rate.
struct Work {
  double bytes = 0.0;
  double flops = 0.0;
  double footprint = 0.0;  ///< bytes of the data it reads and writes
  [[nodiscard]] bool cached(const Rates& r) const { return footprint < 0.75 * r.cacheBytes; }
  [[nodiscard]] double boundMs(const Rates& r) const {
    const double bw = cached(r) ? r.cacheBandwidth : r.bandwidth;
    return 1e3 * std::max(bytes / bw, flops / (18.0 * r.blockRate));
  }
};

/// The structure the counts are made from.
struct Structure {
  double nodes = 0, rows = 0, elements = 0, blocks = 0, sources = 0;
  std::vector<std::size_t> levelRows, levelBlocks;  ///< the multigrid's, fine first
  double coarsestFactor = 0;                        ///< blocks of its factor below the diagonal
  double elementBytes = 0;                          ///< one element's stored matrices
};

/// The step's parts, in StepParts order.
constexpr const char* kPartNames[] = {"prepare", "assembly",   "rigid modes", "projection",
                                      "set-up",  "iterations", "advance"};
constexpr std::size_t kParts = 7;

std::array<double, kParts> partArray(const StepParts& p) {
  return {p.prepare, p.assembly, p.rigid, p.projection, p.setup, p.iterations, p.advance};
}

constexpr double kVec = 24.0;  ///< bytes of one Vec3d

/// One fine product A x: each block (72 bytes) and its column (4) read once; its row starts,
/// x and y; 18 flops a block. Its data is all it reads.
Work productWork(const Structure& s) {
  const double matrix = s.blocks * 76.0 + s.rows * (4.0 + 2.0 * kVec);
  return {matrix, 18.0 * s.blocks, matrix};
}

/// What each part must move and compute at least (the notes of docs/performance.md).
std::array<Work, kParts> partWork(const Structure& s, double iterations, double history) {
  const double vec = kVec;
  const Work product = productWork(s);
  const double matrix = product.footprint;
  // One V-cycle: per level, the forward sweep, the residual and the backward sweep each read
  // the level's single-precision blocks (36 bytes) and columns (4); about six vector passes a
  // level (residual, correction, restriction, prolongation); the coarsest factor's two
  // triangular solves. Its data: each level's blocks and four vectors, and the factor.
  Work vcycle{2.0 * s.coarsestFactor * 76.0, 2.0 * 18.0 * s.coarsestFactor,
              s.coarsestFactor * 76.0};
  for (std::size_t l = 0; l < s.levelRows.size(); ++l) {
    const double lb = static_cast<double>(s.levelBlocks[l]);
    const double lr = static_cast<double>(s.levelRows[l]);
    vcycle.bytes += 3.0 * lb * 40.0 + 6.0 * lr * vec;
    vcycle.flops += 3.0 * 18.0 * lb;
    vcycle.footprint += lb * 40.0 + 4.0 * lr * vec;
  }
  std::array<Work, kParts> w{};
  // prepare: velocities projected (prolongation read and written), positions and masses
  // gathered per free row.
  w[0] = {s.nodes * 3.0 * vec + s.rows * (vec + 8.0 + 4.0), 0.0, s.nodes * 3.0 * vec};
  // assembly: per element its stored matrices read, 8 corner positions and velocities, the
  // 36 rotated blocks and 8 forces written; per element two 3x3 products for each of the 36
  // blocks (108 flops each), K y (24 x 24), the rotation and displacement (about 600); per
  // source of a reduced block its element block (72), index (4) and weight (8) read and 18
  // flops; the reduced blocks written (upper) and mirrored (read and written).
  w[1].bytes = s.elements * (s.elementBytes + 8.0 * 2.0 * vec + 36.0 * 72.0 + 8.0 * vec) +
               s.sources * 84.0 + s.blocks * 0.5 * 72.0 + s.blocks * 0.5 * (72.0 + 72.0 + 4.0) +
               s.rows * 2.0 * 72.0;
  w[1].flops = s.elements * (36.0 * 108.0 + 2.0 * 576.0 + 600.0) + s.sources * 18.0;
  w[1].footprint = s.elements * (s.elementBytes + 36.0 * 72.0) + s.sources * 12.0 + matrix;
  // rigid modes: one pass over A for its six products (RigidModes::rowProducts), the six
  // modes written and read twice (the start's and the result's corrections).
  w[2] = {product.bytes + 3.0 * 6.0 * s.rows * vec, 6.0 * product.flops,
          matrix + 6.0 * s.rows * vec};
  // projection: a product per kept solution, and the kept solutions read twice; the initial
  // residual one more product.
  w[3] = {(history + 1.0) * product.bytes + 2.0 * history * s.rows * vec,
          (history + 1.0) * product.flops, matrix + history * s.rows * vec};
  // set-up (the fine smoother following the matrix): the blocks read and their
  // single-precision copy written, the point inverses (about 100 flops a row).
  w[4] = {s.blocks * (72.0 + 36.0 + 4.0) + s.rows * 72.0, 100.0 * s.rows, s.blocks * (76.0 + 40.0)};
  // iterations: a product, a V-cycle and the conjugate gradients' vector work (about ten
  // vector passes) each.
  w[5] = {iterations * (product.bytes + vcycle.bytes + 10.0 * s.rows * vec),
          iterations * (product.flops + vcycle.flops + 30.0 * s.rows),
          matrix + vcycle.footprint + 5.0 * s.rows * vec};
  // advance: the solution kept, prolonged, the positions moved.
  w[6] = {s.rows * 2.0 * vec + s.nodes * 4.0 * vec, 0.0, s.nodes * 3.0 * vec};
  return w;
}

/// The multigrid's structure on the body's current matrix (built apart from the solver's).
void hierarchy(const bench::FemCase& c, const DeformationOctree& octree,
               const ImplicitEuler& solver, Structure& s, double& productMs, double& vcycleMs) {
  const BlockSparsity& sp = c.model.sparsity();
  const std::size_t rows = c.model.freeNodeCount();
  const std::vector<Eigen::Matrix3d> blocks =
      bench::reducedBlocks(sp, solver.reducedMatrix(c.model));
  const BlockMatrixView view = sp.view(blocks);
  std::vector<Index3> coords(rows);
  for (std::size_t i = 0; i < rows; ++i) coords[i] = octree.nodeCoord(c.model.freeNodes()[i]);
  Multigrid mg;
  mg.build(view, coords, c.params.multigrid, false);
  if (!mg.setup(view, false)) std::fprintf(stderr, "(multigrid set-up failed)\n");
  s.levelRows = mg.rowsPerLevel();
  s.levelBlocks = mg.smootherBlocksPerLevel();
  s.coarsestFactor = static_cast<double>(mg.coarsestFactorBlocks());
  std::vector<Vec3d> x(rows, Vec3d::Ones()), y(rows);
  productMs = voxcut::productMs(view, x, y, 20);
  vcycleMs = 1e3 * bestSeconds(20, [&] { mg.apply(view, x, y, false); });
}

struct Options {
  std::vector<int> sizes{173, 241, 301};
  int runs = 3;
  int steps = 20;
  bool weights = false;
};

template <class F>
double meanMs(int repeats, F&& f) {
  const Timer t;
  for (int k = 0; k < repeats; ++k) f();
  return t.ms() / repeats;
}

/// --weights: what the automatic choice's weights (fem/AutomaticChoice.h, AutomaticCosts) are
/// fitted to. On the bunny at bench_solver_choice's six sizes, after five multigrid steps, each
/// preconditioner operation timed alone (one thread) and divided by one fine product's time
/// on the same matrix: a V-cycle, new coarse levels, a new hierarchy beyond them, the fine
/// smoother's refresh, the two-level V-cycle and its set-up, and its coarse factor's entries
/// per fine block.
void weightsTable() {
  const ThreadLimit limit(1);
  struct Size {
    int resolution, startLevel, maxLevel;
  };
  constexpr Size kSizes[] = {{75, 3, 4},  {112, 3, 4}, {173, 3, 4},
                             {241, 3, 4}, {166, 2, 3}, {250, 2, 3}};
  std::printf("\n## The preconditioners' operations in fine products (one thread)\n\n");
  std::printf(
      "| nodes | free rows | fine blocks | product, ms | V-cycle | coarse levels anew | "
      "hierarchy beyond them | fine smoother | two-level V-cycle | its set-up | its "
      "coarse factor, entries per fine block |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Size& z : kSizes) {
    bench::FemCase c = bench::bunnyBody(z.resolution, {1e5, 0.3, 1000.0, 0.1, 0.01}, false,
                                        z.startLevel, z.maxLevel);
    c.params.timeStep = 0.01;
    c.params.tolerance = 1e-6;
    c.params.preconditioner = PreconditionerKind::Multigrid;
    ImplicitEuler solver(c.params);
    for (int k = 0; k < 5; ++k) (void)solver.step(c.model, c.octree);
    const BlockSparsity& sp = c.model.sparsity();
    const std::size_t rows = c.model.freeNodeCount();
    const std::vector<Eigen::Matrix3d> blocks =
        bench::reducedBlocks(sp, solver.reducedMatrix(c.model));
    std::vector<Eigen::Matrix3d> inverse(rows);
    for (std::size_t i = 0; i < rows; ++i) inverse[i] = blocks[sp.diagonal[i]].inverse();
    const BlockMatrixView view = sp.view(blocks);
    std::vector<Vec3d> positions(rows);
    std::vector<Index3> coords(rows);
    for (std::size_t i = 0; i < rows; ++i) {
      positions[i] = c.octree.positions()[c.model.freeNodes()[i]];
      coords[i] = c.octree.nodeCoord(c.model.freeNodes()[i]);
    }
    std::vector<Vec3d> x(rows, Vec3d::Ones()), y(rows);
    const int reps =
        std::max(5, static_cast<int>(200000 / std::max<std::size_t>(1, sp.blockCount())));
    const double product = productMs(view, x, y, 4 * reps);
    Multigrid mg;
    const double build = meanMs(3, [&] {
      mg.build(view, coords, c.params.multigrid, false);
      (void)mg.setup(view, false);
    });
    const double refresh = meanMs(5, [&] { (void)mg.setup(view, false); });
    const double fine = meanMs(reps, [&] { (void)mg.updateFine(view, false); });
    const double vcycle = 1e3 * bestSeconds(reps, [&] { mg.apply(view, x, y, false); });
    TwoLevelPreconditioner tl;
    const double tlSetup =
        meanMs(5, [&] { (void)tl.setup(sp, c.model.aggregation(), blocks, &positions, false); });
    const double tlApply = 1e3 * bestSeconds(reps, [&] {
                             tl.apply(sp, c.model.aggregation(), blocks, inverse, x, y, false);
                           });
    std::printf("| %zu | %zu | %zu | %.3f | %.1f | %.0f | %.0f | %.1f | %.1f | %.0f | %.2f |\n",
                c.model.nodeCount(), rows, sp.blockCount(), product, vcycle / product,
                refresh / product, (build - refresh) / product, fine / product, tlApply / product,
                tlSetup / product, tl.coarseFactorEntries() / static_cast<double>(sp.blockCount()));
    std::fflush(stdout);
  }
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? 0.0 : n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// "median (min-max)".
std::string spread(const std::vector<double>& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.2f (%.2f-%.2f)", median(v),
                *std::min_element(v.begin(), v.end()), *std::max_element(v.begin(), v.end()));
  return buf;
}

/// One run of `steps` steps after 20 from rest: the mean of each part, of the step, of the
/// iterations.
struct RunResult {
  std::array<double, kParts> parts{};
  double stepMs = 0.0, iterations = 0.0;
  PreconditionerKind used = PreconditionerKind::Automatic;
};

RunResult runOnce(const bench::FemCase& c, PreconditionerKind kind, int history, int steps,
                  DeformationOctree* keepOctree = nullptr, ImplicitEuler* keepSolver = nullptr) {
  DeformationOctree octree = c.octree;
  ImplicitEulerParams params = c.params;
  params.preconditioner = kind;
  params.projectionHistory = history;
  ImplicitEuler solver(params);
  for (int k = 0; k < 20; ++k) (void)solver.step(c.model, octree);
  RunResult r;
  for (int k = 0; k < steps; ++k) {
    const Timer t;
    const StepStatus st = solver.step(c.model, octree);
    r.stepMs += t.ms();
    r.iterations += st.iterations;
    const std::array<double, kParts> p = partArray(st.parts);
    for (std::size_t q = 0; q < kParts; ++q) r.parts[q] += p[q];
    r.used = st.preconditioner;
  }
  const double n = std::max(1, steps);
  r.stepMs /= n;
  r.iterations /= n;
  for (double& p : r.parts) p /= n;
  if (keepOctree != nullptr) *keepOctree = octree;
  if (keepSolver != nullptr) *keepSolver = solver;
  return r;
}

void runSize(const Options& o, int resolution, const Rates& rates) {
  const ThreadLimit limit(1);
  const bench::FemCase c = bench::scalingCase(resolution);
  std::vector<RunResult> autoRuns, jacobiRuns;
  DeformationOctree octree;
  ImplicitEuler solver;
  for (int run = 0; run < o.runs; ++run) {
    autoRuns.push_back(runOnce(c, PreconditionerKind::Automatic, 8, o.steps, &octree, &solver));
    jacobiRuns.push_back(runOnce(c, PreconditionerKind::Jacobi, 0, o.steps));
  }
  Structure s;
  s.nodes = static_cast<double>(c.model.nodeCount());
  s.rows = static_cast<double>(c.model.freeNodeCount());
  s.elements = static_cast<double>(c.model.elementCount());
  s.blocks = static_cast<double>(c.model.sparsity().blockCount());
  s.sources = static_cast<double>(c.model.sparsity().source.size());
  s.elementBytes = sizeof(ElementMatrices);
  double productMs = 0.0, vcycleMs = 0.0;
  hierarchy(c, octree, solver, s, productMs, vcycleMs);

  std::vector<double> iterations, steps, jacobi, speedup;
  for (int run = 0; run < o.runs; ++run) {
    iterations.push_back(autoRuns[static_cast<std::size_t>(run)].iterations);
    steps.push_back(autoRuns[static_cast<std::size_t>(run)].stepMs);
    jacobi.push_back(jacobiRuns[static_cast<std::size_t>(run)].stepMs);
    speedup.push_back(jacobi.back() / steps.back());
  }
  const std::array<Work, kParts> work = partWork(s, median(iterations), 8.0);
  std::printf("\n## resolution %d: %.0f nodes (%.0f free rows), %.0f elements, %.0f blocks\n",
              resolution, s.nodes, s.rows, s.elements, s.blocks);
  std::printf("auto ran %s, %.1f iterations a step; multigrid levels (rows/blocks):",
              preconditionerName(autoRuns.back().used), median(iterations));
  for (std::size_t l = 0; l < s.levelRows.size(); ++l)
    std::printf(" %zu/%zu", s.levelRows[l], s.levelBlocks[l]);
  std::printf(", coarsest factor %.0f blocks\n\n", s.coarsestFactor);
  std::printf(
      "| part | ms, median (min-max) | MB moved | Mflop | data, MB | bound, ms | ms / bound |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  double boundSum = 0.0;
  for (std::size_t q = 0; q < kParts; ++q) {
    std::vector<double> v;
    for (const RunResult& r : autoRuns) v.push_back(r.parts[q]);
    const Work& w = work[q];
    const double bound = w.boundMs(rates);
    boundSum += bound;
    std::printf("| %s | %s | %.2f | %.2f | %.1f%s | %.2f | %.1f |\n", kPartNames[q],
                spread(v).c_str(), w.bytes * 1e-6, w.flops * 1e-6, w.footprint * 1e-6,
                w.cached(rates) ? " (cached)" : "", bound, median(v) / std::max(bound, 1e-9));
  }
  std::printf("| **step** | %s | | | | %.2f | %.1f |\n\n", spread(steps).c_str(), boundSum,
              median(steps) / boundSum);
  const std::size_t blocks = static_cast<std::size_t>(s.blocks);
  const Work product = productWork(s);
  std::printf("kernels: one fine product %.3f ms (bound %.3f, %zu blocks); one V-cycle %.3f ms\n",
              productMs, product.boundMs(rates), blocks, vcycleMs);
  std::printf("Jacobi-PCG from the previous dv: %s ms a step; auto %s times faster\n",
              spread(jacobi).c_str(), spread(speedup).c_str());
  std::fflush(stdout);
}

}  // namespace
}  // namespace voxcut

int main(int argc, char** argv) {
  voxcut::Options o;
  CLI::App app(
      "One implicit Euler step of the bunny scaling case by its parts, against what "
      "their arithmetic costs on this machine (docs/performance.md, \"The step by its "
      "parts\").",
      "bench_step_parts");
  app.add_option("--sizes", o.sizes, "bunny resolutions (173, 241, 301: 3.1k, 6.3k, 10.3k nodes)")
      ->delimiter(',')
      ->check(CLI::Range(8, 400));
  app.add_option("--runs", o.runs, "runs per size (median and range reported)")
      ->check(CLI::Range(1, 100));
  app.add_option("--steps", o.steps, "measured steps per run, after 20 from rest")
      ->check(CLI::Range(1, 10000));
  app.add_flag("--weights", o.weights,
               "instead: the preconditioners' operations in fine products at the six sizes of "
               "bench_solver_choice (what the automatic choice's weights are fitted to)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "bench_step_parts: error: %s\n", e.what());
    return 2;
  }
  try {
    (void)voxcut::measureRates();  // the clock and the pages warmed up
    const voxcut::Rates before = voxcut::measureRates();
    const voxcut::Rates after = voxcut::measureRates();
    const voxcut::Rates rates = before.best(after);
    std::printf("# The step by its parts (one thread)\n\n");
    std::printf(
        "machine (one thread, two measurements): memory %.1f / %.1f GB/s, last-level "
        "cache (%.0f MB) %.1f / %.1f GB/s, in-cache 3x3 block products %.0f / %.0f M/s "
        "(%.1f Gflop/s at best); the bounds use the better of each\n",
        before.bandwidth * 1e-9, after.bandwidth * 1e-9, rates.cacheBytes * 1e-6,
        before.cacheBandwidth * 1e-9, after.cacheBandwidth * 1e-9, before.blockRate * 1e-6,
        after.blockRate * 1e-6, 18.0 * rates.blockRate * 1e-9);
    if (o.weights)
      voxcut::weightsTable();
    else
      for (int res : o.sizes) voxcut::runSize(o, res, rates);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_step_parts: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
