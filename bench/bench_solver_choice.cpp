// Whether the automatic preconditioner choice (PreconditionerKind::Automatic,
// fem/PreconditionerChoice.h) keeps within 1.15x of the best fixed choice of one implicit Euler
// step (fem/ImplicitEuler.h), at body sizes from about 500 to about 30,000 deformation-octree
// nodes, in three states of the body:
//  - rest: the bunny fixed on its low-x side (the nodes in the first tenth of its width),
//    swinging under gravity;
//  - cut: the same while a blade cuts it in every step: the connected y-links crossing the
//    plane at 60 % of its height, x within 35-75 % of its width, one layer of voxels along z
//    a step, from the body's front backwards (rest-grid links, as bench_topology's
//    BladeSequence); updateCutTopology (refining the cut elements to level 0, its default, as
//    bench_fem and bench_topology; --cut-level), then ElasticModel::updateTopology and
//    ImplicitEuler::updateTopology, as the world's cut stage does;
//  - contact: the same pressed by a plate from above, its face (normal -y) starting half a
//    voxel below the body's top and moving down 1 mm a step: every surface voxel of the upper
//    half that is in the plate or headed into it within the step (the world's rule for
//    obstacles) is a point contact (ContactLaw.h) of stiffness 10 E h (the world's default).
// Sizes: the bunny at resolutions 75, 112, 173 and 241 with the deformation octree's default
// levels (3/4), and at 166 and 250 with levels 2/3 (elements of the same size relative to the
// body on a grid 8 times smaller): about 0.5k, 1.2k, 3.1k, 6.3k, 12k and 30k nodes.
// Settings as bench_fem's scaling case: E 1e5 Pa, nu 0.3, rho 1000 kg/m^3, Rayleigh damping
// [0.1, 0.01], dt 10 ms, relative tolerance 1e-6 (--tolerance), at most 2,000 iterations,
// gravity, one thread (--threads).
//
// Method. Each size is built once and stepped 15 times from rest (two-level V-cycle). Each
// round, every choice takes its own copy of that body (octree, and solver with its velocities
// and warm start; the model is shared), steps it --warmup times unmeasured and --steps times
// measured, the cuts or the plate acting in all of those steps. The choices are interleaved
// step by step (their order rotated each step) and get the same cut links, and the same
// contact set: found on the automatic choice's body (elements and weights), each copy with its
// own gaps.
// A step's time is the wall time of ImplicitEuler::step alone (not the cut's topology update).
// Per choice: the median over --rounds rounds of each round's mean, and their range. A fixed
// choice whose mean, after half a round's steps, is over 3x the best fixed choice's stops for
// the rest of the case (marked *). Also recorded: iterations, factorisations and the
// preconditioner each step used (stderr after each case, and --json): with the default cost
// limits (ImplicitEulerParams::maxFactorUpdatesPerBlock) "cholesky" hands its steps to the
// two-level V-cycle from about 1k nodes up.
//
//   build/release/bench/bench_solver_choice [--quick] [--all] [--json FILE] [--help]

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEuler.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/topology/CutTopology.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

/// One body size: the bunny at `resolution` with deformation-octree levels start/max.
struct SizeSpec {
  const char* label;
  int resolution;
  int startLevel;
  int maxLevel;
};

constexpr std::array<SizeSpec, 6> kSizes{{{"500", 75, 3, 4},
                                          {"1.2k", 112, 3, 4},
                                          {"3k", 173, 3, 4},
                                          {"6k", 241, 3, 4},
                                          {"12k", 166, 2, 3},
                                          {"30k", 250, 2, 3}}};
constexpr std::size_t kQuickSizes = 3;  // --quick: the sizes up to 3k nodes

enum class BodyState { Rest, Cut, Contact };
constexpr std::array<BodyState, 3> kStates{BodyState::Rest, BodyState::Cut, BodyState::Contact};
constexpr std::array<const char*, 3> kStateNames{"rest", "cut", "contact"};

const char* stateName(BodyState s) { return kStateNames[static_cast<std::size_t>(s)]; }

constexpr int kSettleSteps = 15;         // from rest, once per size, shared by every choice
constexpr double kSlowFactor = 3.0;      // a fixed choice this much slower than the best stops
constexpr double kWithin = 1.15;         // the target: auto / best fixed at most this
constexpr double kPlateSpeed = 0.001;    // m the plate moves down per step

/// The command line's settings.
struct Options {
  double tolerance = 1e-6;
  int threads = 1;
  int steps = 10;
  int warmup = 3;
  int rounds = 3;
  int cutLevel = 0;  // the finest level a cut refines to (CutTopologyParams::finestLevel)
  bool quick = false;
  bool all = false;
  std::string json;
  std::vector<std::string> sizes;   // labels; empty: all (--quick: the small ones)
  std::vector<std::string> states;  // names; empty: all
};

/// What each choice steps: an octree and the solver (velocities, warm start,
/// preconditioners). The model is shared: ImplicitEuler::step only reads it, and it depends on
/// the octree's structure alone (rest geometry), which every copy shares, cuts included. One
/// model instead of one per choice keeps the 30k-node cases within about 2 GB.
struct Body {
  DeformationOctree octree;
  ImplicitEuler solver;
};

/// A size, built and settled: its rest grid, its model, the body after kSettleSteps, the step
/// settings.
struct SizeCase {
  SizeSpec spec{};
  VoxelGrid grid;
  ElasticModel model;
  Body settled;
  ImplicitEulerParams params;
  double buildMs = 0.0;
};

// ---------------------------------------------------------------------------------------------
// Building a body.

ImplicitEulerParams stepParams(const Options& o) {
  ImplicitEulerParams p;
  p.timeStep = 0.01;
  p.gravity = Vec3d(0, -9.81, 0);
  p.tolerance = o.tolerance;
  p.maxIterations = 2000;
  return p;
}

/// One flag per node: fixed when its rest x lies in the first tenth of the voxels' x range.
std::vector<std::uint8_t> sideFixed(const DeformationOctree& octree) {
  const Eigen::AlignedBox3d& b = octree.restVoxelBounds();
  const double limit = b.min().x() + 0.1 * (b.max().x() - b.min().x());
  std::vector<std::uint8_t> fixed(octree.nodeCount(), 0);
  for (std::size_t n = 0; n < fixed.size(); ++n)
    fixed[n] = octree.restPositions()[n].x() <= limit ? 1 : 0;
  return fixed;
}

/// The bunny of `spec`, fixed on one side, stepped kSettleSteps times from rest with the
/// two-level V-cycle (whose state, copied into every choice's solver, is small).
SizeCase buildSize(const SizeSpec& spec, const Options& o) {
  Timer timer;
  SizeCase c;
  c.spec = spec;
  c.params = stepParams(o);
  VoxelizeParams vp;
  vp.resolution.resolution = spec.resolution;
  c.grid = voxelize(loadModel("bunny").materials, vp);
  DeformationOctreeParams dp;
  dp.startLevel = spec.startLevel;
  dp.maxLevel = spec.maxLevel;
  Body& b = c.settled;
  b.octree = buildDeformationOctree(c.grid, dp);
  std::vector<ElasticMaterial> materials(2);
  materials[1] = {1e5, 0.3, 1000.0, 0.1, 0.01};
  c.model = ElasticModel(b.octree, c.grid, materials);
  c.model.setFixed(sideFixed(b.octree));
  ImplicitEulerParams p = c.params;
  p.preconditioner = PreconditionerKind::TwoLevel;
  b.solver = ImplicitEuler(p);
  for (int s = 0; s < kSettleSteps; ++s) (void)b.solver.step(c.model, b.octree);
  c.buildMs = timer.ms();
  return c;
}

// ---------------------------------------------------------------------------------------------
// The cut: a blade's links per step.

/// The links the blade cuts in each of `steps` steps (the file comment): step k cuts the
/// links of the k-th layer of voxels along z behind the front-most one.
std::vector<std::vector<std::uint64_t>> bladeSteps(const VoxelGrid& g,
                                                   const Eigen::AlignedBox3d& bounds, int steps) {
  const double h = g.voxelSize();
  const Vec3d lo = bounds.min(), size = bounds.max() - bounds.min();
  const double y = lo.y() + 0.6 * size.y(), x0 = lo.x() + 0.35 * size.x(),
               x1 = lo.x() + 0.75 * size.x();
  std::vector<std::pair<double, std::uint64_t>> crossed;  // (z, link)
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    if (!g.hasLink(v, 1) || !g.connected(v, 1)) continue;
    const Vec3d p = g.position(v);
    if (p.y() < y && p.y() + h >= y && p.x() >= x0 && p.x() <= x1)
      crossed.emplace_back(p.z(), VoxelGrid::linkId(v, 1));
  }
  std::vector<std::vector<std::uint64_t>> out(static_cast<std::size_t>(steps));
  if (crossed.empty()) return out;
  double front = crossed.front().first;
  for (const auto& c : crossed) front = std::max(front, c.first);
  for (const auto& [z, link] : crossed) {
    const auto band = static_cast<std::size_t>(std::lround((front - z) / h));
    if (band < out.size()) out[band].push_back(link);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// The contact: a plate pressing from above.

/// Whether occupied voxel v has a face without a connected neighbour.
bool onSurface(const VoxelGrid& g, std::size_t v) {
  const Index3 c = g.coord(v);
  for (int a = 0; a < 3; ++a) {
    if (!g.hasLink(v, a) || !g.connected(v, a)) return true;
    if (c[a] == 0 || !g.connected(v - g.stride(a), a)) return true;
  }
  return false;
}

/// The plate: its face at height y0 - k kPlateSpeed in step k, normal -y, pressing on the
/// surface voxels of the body's upper half.
struct Plate {
  std::vector<std::size_t> voxels;  ///< the points it may press
  double y0 = 0.0;                  ///< its face's height in step 0 (m)
  double stiffness = 0.0;           ///< per point (N/m)

  [[nodiscard]] double face(int step) const { return y0 - step * kPlateSpeed; }
};

/// The plate over `body` (the settled body: its face starts half a voxel below its top) of
/// `model`'s material.
Plate makePlate(const VoxelGrid& g, const ElasticModel& model, const Body& body) {
  Plate plate;
  const Eigen::AlignedBox3d& b = body.octree.restVoxelBounds();
  const double half = b.min().y() + 0.5 * (b.max().y() - b.min().y());
  double top = -std::numeric_limits<double>::infinity();
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    if (!g.occupied(v) || g.position(v).y() < half || !onSurface(g, v)) continue;
    plate.voxels.push_back(v);
    top = std::max(top, body.octree.voxelPosition(v).y());
  }
  plate.y0 = top - 0.5 * g.voxelSize();
  plate.stiffness = 10.0 * model.materials()[1].youngModulus * g.voxelSize();
  return plate;
}

/// The plate's voxels in `ref` that lie in the plate at step `step`'s start or are headed
/// into it within the step at their current velocity (gap + dt n.v < 0).
std::vector<std::size_t> pressedVoxels(const Plate& plate, int step, const Body& ref,
                                       double dt) {
  std::vector<std::size_t> out;
  const std::vector<Vec3d>& velocity = ref.solver.velocities();
  for (std::size_t v : plate.voxels) {
    const double gap = plate.face(step) - ref.octree.voxelPosition(v).y();
    const VoxelEmbedding& em = ref.octree.embedding(v);
    const Vec3d vp = contactPointVelocity(ref.octree.weights(v),
                                          ref.octree.element(em.element).nodes, velocity);
    if (gap < 0.0 || gap - dt * vp.y() < 0.0) out.push_back(v);
  }
  return out;
}

/// The point contacts of `voxels` in `octree`, each with its gap in that octree.
std::vector<PointContact> plateContacts(const Plate& plate, int step,
                                        const std::vector<std::size_t>& voxels,
                                        const DeformationOctree& octree) {
  std::vector<PointContact> out;
  out.reserve(voxels.size());
  for (std::size_t v : voxels) {
    PointContact pc;
    pc.element = octree.owner(v);
    pc.weight = octree.weights(v);
    pc.normal = Vec3d(0, -1, 0);
    pc.gap = plate.face(step) - octree.voxelPosition(v).y();
    pc.stiffness = plate.stiffness;
    out.push_back(pc);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Running a case: every choice on its copy of one size in one state.

/// What one choice's measured steps gave over the rounds.
struct ChoiceResult {
  PreconditionerKind kind = PreconditionerKind::Automatic;
  std::vector<double> roundMs;  ///< per round run: mean wall ms per measured step
  double steps = 0, iterations = 0, factorisations = 0, notConverged = 0, notFinite = 0;
  /// Summed over the measured steps: StepStatus::parts' preconditioner set-up and
  /// iterations (ms), what the automatic choice's weights (fem/AutomaticChoice.h) are fitted to.
  double setupMs = 0, iterationsMs = 0;
  std::map<PreconditionerKind, int> used;  ///< steps per preconditioner actually used
  bool cutShort = false;
};

/// One row of the table: a size in a state.
struct CaseResult {
  SizeSpec spec{};
  BodyState state = BodyState::Rest;
  std::size_t nodes = 0, freeNodes = 0;        ///< at the first measured step
  std::size_t nodesEnd = 0, freeNodesEnd = 0;  ///< after the last
  double linksPerStep = 0, changedShare = 0;   ///< cut: links and topology changes per step
  double topologyMs = 0;                       ///< cut: update per body and step
  double contactsPerStep = 0;                  ///< contact: point contacts per step
  std::vector<ChoiceResult> choices;           ///< the automatic choice last
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? std::numeric_limits<double>::quiet_NaN()
                : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

/// Per-step set-up shared by the choices of a case: the cut's grid and links, the plate.
struct CaseAction {
  BodyState state = BodyState::Rest;
  std::vector<std::vector<std::uint64_t>> cuts;  ///< cut: links per step
  CutTopologyParams topology;                    ///< cut: the finest level it refines to
  Plate plate;                                   ///< contact
  VoxelGrid grid;                                ///< cut: this round's grid, links cut so far
  ElasticModel model;                            ///< cut: this round's model, cut so far
};

/// What a step's cut did: whether the topology changed, and what the update cost one body
/// (its octree's and solver's update plus the model's), ms.
struct CutStepResult {
  bool changed = false;
  double ms = 0.0;
};

/// Cuts step k's links: in the grid, in every live body's octree and solver, and once in the
/// shared model (with the automatic choice's octree, the last body; every copy's topology is
/// the same, as it depends on the grid and the octree's structure only).
CutStepResult cutStep(CaseAction& act, int k, std::vector<std::optional<Body>>& bodies) {
  const std::vector<std::uint64_t>& links = act.cuts[static_cast<std::size_t>(k)];
  if (links.empty()) return {};
  for (std::uint64_t id : links)
    act.grid.setConnected(static_cast<std::size_t>(id / 3), static_cast<int>(id % 3), false);
  Timer timer;
  TopologyChange change;
  double live = 0;
  for (std::optional<Body>& b : bodies) {
    if (!b) continue;
    change = updateCutTopology(b->octree, act.grid, links, act.topology);
    if (change.changed) b->solver.updateTopology(change);
    live += 1;
  }
  const DeformationOctree& ref = bodies.back()->octree;
  for (const std::optional<Body>& b : bodies)
    if (b && (b->octree.nodeCount() != ref.nodeCount() ||
              b->octree.elementCount() != ref.elementCount()))
      throw std::logic_error("the copies' cut topologies differ");
  const double perBody = timer.ms() / live;
  timer.restart();
  if (change.changed) act.model.updateTopology(ref, act.grid, change);
  return {change.changed, perBody + timer.ms()};
}

/// Before step `k`: cuts the step's links, or gives each live body its contacts. Adds to the
/// case's cut and contact figures when `measured`.
void prepareStep(CaseAction& act, int k, std::vector<std::optional<Body>>& bodies,
                 double dt, bool measured, CaseResult& r) {
  if (act.state == BodyState::Cut) {
    const CutStepResult cut = cutStep(act, k, bodies);
    if (measured) {
      r.linksPerStep += static_cast<double>(act.cuts[static_cast<std::size_t>(k)].size());
      r.changedShare += cut.changed ? 1.0 : 0.0;
      r.topologyMs += cut.ms;
    }
  } else if (act.state == BodyState::Contact) {
    const std::vector<std::size_t> voxels = pressedVoxels(act.plate, k, *bodies.back(), dt);
    for (std::optional<Body>& b : bodies)
      if (b) b->solver.setContacts(plateContacts(act.plate, k, voxels, b->octree));
    if (measured) r.contactsPerStep += static_cast<double>(voxels.size());
  }
}

/// Adds one measured step's status to a choice's counts.
void record(ChoiceResult& c, const StepStatus& st) {
  c.steps += 1;
  c.iterations += st.iterations;
  c.factorisations += st.factorised ? 1 : 0;
  c.notConverged += st.converged ? 0 : 1;
  c.notFinite += st.finite ? 0 : 1;
  c.setupMs += st.parts.setup;
  c.iterationsMs += st.parts.iterations;
  ++c.used[st.preconditioner];
}

/// After `measured` steps of a round (at least half of them): stops each fixed choice whose
/// mean so far is over kSlowFactor times the best fixed choice's, keeping that mean.
void cutSlowChoices(CaseResult& r, const std::vector<double>& sumMs, int measured,
                    std::vector<std::optional<Body>>& bodies) {
  const std::size_t fixedCount = r.choices.size() - 1;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < fixedCount; ++i)
    if (bodies[i]) best = std::min(best, sumMs[i] / measured);
  for (std::size_t i = 0; i < fixedCount; ++i) {
    if (!bodies[i] || sumMs[i] / measured <= kSlowFactor * best) continue;
    r.choices[i].cutShort = true;
    r.choices[i].roundMs.push_back(sumMs[i] / measured);
    bodies[i].reset();
  }
}

/// One round: fresh copies of the settled body, warm-up and measured steps interleaved.
void runRound(const SizeCase& sc, CaseAction& act, int round, const Options& o,
              CaseResult& r) {
  const std::size_t n = r.choices.size();
  std::vector<std::optional<Body>> bodies(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (r.choices[i].cutShort) continue;
    bodies[i] = sc.settled;
    ImplicitEulerParams p = sc.params;
    p.preconditioner = r.choices[i].kind;
    bodies[i]->solver.setParams(p);
  }
  if (act.state == BodyState::Cut) {
    act.grid = sc.grid;
    act.model = sc.model;
  }
  const ElasticModel& model = act.state == BodyState::Cut ? act.model : sc.model;
  std::vector<double> sumMs(n, 0.0);
  int measured = 0;
  for (int k = 0; k < o.warmup + o.steps; ++k) {
    const bool isMeasured = k >= o.warmup;
    prepareStep(act, k, bodies, sc.params.timeStep, isMeasured && round == 0, r);
    const Body& ref = *bodies.back();
    if (k == o.warmup && round == 0) {
      r.nodes = ref.octree.nodeCount();
      r.freeNodes = model.freeNodeCount();
    }
    for (std::size_t j = 0; j < n; ++j) {
      const std::size_t i = (j + static_cast<std::size_t>(k)) % n;
      if (!bodies[i]) continue;
      Timer timer;
      const StepStatus st = bodies[i]->solver.step(model, bodies[i]->octree);
      const double ms = timer.ms();
      if (!isMeasured) continue;
      sumMs[i] += ms;
      record(r.choices[i], st);
    }
    if (isMeasured && ++measured >= (o.steps + 1) / 2) cutSlowChoices(r, sumMs, measured, bodies);
  }
  for (std::size_t i = 0; i < n; ++i)
    if (bodies[i]) r.choices[i].roundMs.push_back(sumMs[i] / measured);
  r.nodesEnd = bodies.back()->octree.nodeCount();
  r.freeNodesEnd = model.freeNodeCount();
}

/// Every choice of `kinds` (the automatic one last) on size `sc` in state `state`.
CaseResult runCase(const SizeCase& sc, BodyState state,
                   const std::vector<PreconditionerKind>& kinds, const Options& o) {
  CaseResult r;
  r.spec = sc.spec;
  r.state = state;
  for (PreconditionerKind k : kinds) {
    ChoiceResult c;
    c.kind = k;
    r.choices.push_back(c);
  }
  CaseAction act;
  act.state = state;
  act.topology.finestLevel = o.cutLevel;
  if (state == BodyState::Cut)
    act.cuts = bladeSteps(sc.grid, sc.settled.octree.restVoxelBounds(), o.warmup + o.steps);
  if (state == BodyState::Contact) act.plate = makePlate(sc.grid, sc.model, sc.settled);
  for (int round = 0; round < o.rounds; ++round) {
    Timer timer;
    runRound(sc, act, round, o, r);
    std::fprintf(stderr, "[%s %s] round %d/%d (%.1f s):", sc.spec.label, stateName(state),
                 round + 1, o.rounds, timer.ms() * 1e-3);
    for (const ChoiceResult& c : r.choices)
      if (static_cast<int>(c.roundMs.size()) == round + 1)
        std::fprintf(stderr, " %s %.2f%s", preconditionerName(c.kind), c.roundMs.back(),
                     c.cutShort ? "*" : "");
    std::fprintf(stderr, " ms/step\n");
  }
  r.linksPerStep /= o.steps;
  r.changedShare /= o.steps;
  r.topologyMs /= o.steps;
  r.contactsPerStep /= o.steps;
  return r;
}

// ---------------------------------------------------------------------------------------------
// Results: the best fixed choice, the table, the JSON.

/// The index of the fixed choice with the lowest median, and auto's median over it.
struct Verdict {
  std::size_t best = 0;
  double ratio = std::numeric_limits<double>::quiet_NaN();
};

Verdict verdict(const CaseResult& r) {
  Verdict v;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < r.choices.size(); ++i) {
    const double m = median(r.choices[i].roundMs);
    if (!r.choices[i].cutShort && m < best) {
      best = m;
      v.best = i;
    }
  }
  v.ratio = median(r.choices.back().roundMs) / best;
  return v;
}

/// A time in ms with three significant digits or so.
std::string ms(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, x < 10 ? "%.2f" : (x < 100 ? "%.1f" : "%.0f"), x);
  return buf;
}

/// A table cell: the median of the rounds' means and their range; * when cut short.
std::string cell(const ChoiceResult& c) {
  const auto [lo, hi] = std::minmax_element(c.roundMs.begin(), c.roundMs.end());
  std::string s = ms(median(c.roundMs));
  if (c.roundMs.size() > 1) s += " (" + ms(*lo) + "-" + ms(*hi) + ")";
  return c.cutShort ? s + "*" : s;
}

std::string counts(std::size_t start, std::size_t end) {
  return start == end ? std::to_string(start)
                      : std::to_string(start) + "->" + std::to_string(end);
}

std::string bodyName(const SizeSpec& s) {
  return "bunny r" + std::to_string(s.resolution) + " L" + std::to_string(s.startLevel) + "/" +
         std::to_string(s.maxLevel);
}

void printTable(const std::vector<CaseResult>& results, const Options& o) {
  std::printf("ms per step, median of %d round(s) (min-max); %d warm-up + %d measured steps;"
              " tolerance %g; %d thread(s)\n",
              o.rounds, o.warmup, o.steps, o.tolerance, o.threads);
  std::printf("%-5s %-15s %-8s %13s %13s", "size", "body", "state", "nodes", "free");
  for (const ChoiceResult& c : results.front().choices)
    std::printf("  %-19s", preconditionerName(c.kind));
  std::printf("  %-12s %s\n", "best fixed", "auto/best");
  for (const CaseResult& r : results) {
    std::printf("%-5s %-15s %-8s %13s %13s", r.spec.label, bodyName(r.spec).c_str(),
                stateName(r.state), counts(r.nodes, r.nodesEnd).c_str(),
                counts(r.freeNodes, r.freeNodesEnd).c_str());
    for (const ChoiceResult& c : r.choices) std::printf("  %-19s", cell(c).c_str());
    const Verdict v = verdict(r);
    std::printf("  %-12s %.2f\n", preconditionerName(r.choices[v.best].kind), v.ratio);
  }
  std::printf("* cut short: over %gx the best fixed choice's mean after half a round; its mean"
              " over the steps it ran\n",
              kSlowFactor);
  std::printf("nodes, free: at the first measured step (->: after the last, the cut's"
              " refinement)\n");
}

/// The final line: in how many cases auto is within kWithin of the best fixed choice.
std::string summaryLine(const std::vector<CaseResult>& results) {
  int within = 0;
  double worst = 0.0;
  std::string where;
  for (const CaseResult& r : results) {
    const double ratio = verdict(r).ratio;
    if (ratio <= kWithin) ++within;
    if (!(ratio <= worst)) {
      worst = ratio;
      where = std::string(r.spec.label) + " " + stateName(r.state);
    }
  }
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "auto within %.2fx of the best fixed choice in %d of %zu cases (worst %.2f at "
                "%s)",
                kWithin, within, results.size(), worst, where.c_str());
  return buf;
}

nlohmann::ordered_json choiceJson(const ChoiceResult& c) {
  nlohmann::ordered_json j;
  const auto [lo, hi] = std::minmax_element(c.roundMs.begin(), c.roundMs.end());
  const double steps = std::max(c.steps, 1.0);
  j["name"] = preconditionerName(c.kind);
  j["ms_median"] = median(c.roundMs);
  j["ms_min"] = *lo;
  j["ms_max"] = *hi;
  j["round_ms"] = c.roundMs;
  j["cut_short"] = c.cutShort;
  j["measured_steps"] = c.steps;
  j["iterations_per_step"] = c.iterations / steps;
  j["factorisations"] = c.factorisations;
  j["setup_ms_per_step"] = c.setupMs / steps;
  j["ms_per_iteration"] = c.iterationsMs / std::max(c.iterations, 1.0);
  j["not_converged"] = c.notConverged;
  j["not_finite"] = c.notFinite;
  nlohmann::ordered_json used = nlohmann::ordered_json::object();
  for (const auto& [kind, count] : c.used) used[preconditionerName(kind)] = count;
  j["used"] = used;
  return j;
}

nlohmann::ordered_json resultsJson(const std::vector<CaseResult>& results, const Options& o,
                                   double totalS) {
  nlohmann::ordered_json j;
  j["settings"] = {{"tolerance", o.tolerance}, {"threads", o.threads},
                   {"warmup_steps", o.warmup}, {"measured_steps", o.steps},
                   {"rounds", o.rounds},       {"settle_steps", kSettleSteps},
                   {"time_step_s", 0.01},      {"young_modulus_pa", 1e5},
                   {"poisson_ratio", 0.3}};
  j["cases"] = nlohmann::ordered_json::array();
  for (const CaseResult& r : results) {
    const Verdict v = verdict(r);
    nlohmann::ordered_json c;
    c["size"] = r.spec.label;
    c["body"] = bodyName(r.spec);
    c["state"] = stateName(r.state);
    c["nodes"] = r.nodes;
    c["free_nodes"] = r.freeNodes;
    c["nodes_end"] = r.nodesEnd;
    c["free_nodes_end"] = r.freeNodesEnd;
    if (r.state == BodyState::Cut) {
      c["links_per_step"] = r.linksPerStep;
      c["topology_changed_share"] = r.changedShare;
      c["topology_update_ms"] = r.topologyMs;
    }
    if (r.state == BodyState::Contact) c["contacts_per_step"] = r.contactsPerStep;
    c["choices"] = nlohmann::ordered_json::array();
    for (const ChoiceResult& ch : r.choices) c["choices"].push_back(choiceJson(ch));
    c["best_fixed"] = preconditionerName(r.choices[v.best].kind);
    c["auto_over_best"] = v.ratio;
    j["cases"].push_back(c);
  }
  j["summary"] = summaryLine(results);
  j["total_s"] = totalS;
  return j;
}

/// Per choice on stderr: iterations, factorisations, failures, the preconditioners used.
void printDetails(const CaseResult& r) {
  std::fprintf(stderr, "[%s %s] %zu nodes (%zu free)", r.spec.label, stateName(r.state),
               r.nodes, r.freeNodes);
  if (r.state == BodyState::Cut)
    std::fprintf(stderr, ", %.0f links/step, topology changed in %.0f%% of steps, update %.1f ms",
                 r.linksPerStep, 100.0 * r.changedShare, r.topologyMs);
  if (r.state == BodyState::Contact) std::fprintf(stderr, ", %.0f contacts/step", r.contactsPerStep);
  std::fprintf(stderr, "\n");
  for (const ChoiceResult& c : r.choices) {
    const double steps = std::max(c.steps, 1.0);
    std::fprintf(stderr,
                 "    %-22s %7.1f it/step, %6.3f ms/it, set-up %6.2f ms/step, %3.0f "
                 "factorisations, %2.0f not converged, used",
                 preconditionerName(c.kind), c.iterations / steps,
                 c.iterationsMs / std::max(c.iterations, 1.0), c.setupMs / steps,
                 c.factorisations, c.notConverged);
    for (const auto& [kind, count] : c.used)
      std::fprintf(stderr, " %s %d", preconditionerName(kind), count);
    std::fprintf(stderr, "\n");
  }
}

// ---------------------------------------------------------------------------------------------
// The program.

std::vector<PreconditionerKind> choices(bool all) {
  std::vector<PreconditionerKind> out;
  for (PreconditionerKind k : kPreconditionerKinds) {
    const bool extra = k == PreconditionerKind::BlockJacobi ||
                       k == PreconditionerKind::SymmetricGaussSeidel ||
                       k == PreconditionerKind::IncompleteCholesky;
    if (k != PreconditionerKind::Automatic && (all || !extra)) out.push_back(k);
  }
  out.push_back(PreconditionerKind::Automatic);
  return out;
}

bool wanted(const std::vector<std::string>& list, const std::string& name) {
  return list.empty() || std::find(list.begin(), list.end(), name) != list.end();
}

void run(const Options& o, std::ofstream* json) {
  const ThreadLimit limit(o.threads);
  const std::vector<PreconditionerKind> kinds = choices(o.all);
  std::vector<CaseResult> results;
  Timer total;
  for (std::size_t s = 0; s < kSizes.size(); ++s) {
    const SizeSpec& spec = kSizes[s];
    if (!wanted(o.sizes, spec.label) || (o.quick && o.sizes.empty() && s >= kQuickSizes))
      continue;
    std::fprintf(stderr, "[%s] building %s, settling %d steps...\n", spec.label,
                 bodyName(spec).c_str(), kSettleSteps);
    const SizeCase sc = buildSize(spec, o);
    std::fprintf(stderr, "[%s] %zu nodes, %zu free, built and settled in %.1f s\n", spec.label,
                 sc.settled.octree.nodeCount(), sc.model.freeNodeCount(),
                 sc.buildMs * 1e-3);
    for (BodyState state : kStates) {
      if (!wanted(o.states, stateName(state))) continue;
      results.push_back(runCase(sc, state, kinds, o));
      printDetails(results.back());
    }
  }
  if (results.empty()) return;  // no case selected: nothing to print
  printTable(results, o);
  std::printf("%s\n", summaryLine(results).c_str());
  std::fflush(stdout);
  std::fprintf(stderr, "total %.1f s\n", total.ms() * 1e-3);
  if (json) *json << resultsJson(results, o, total.ms() * 1e-3).dump(2) << "\n";
}

/// The command line (the file comment): every option into `o`.
void addOptions(CLI::App& app, Options& o) {
  app.description(
      "Steps the bunny (about 500 to 30,000 deformation-octree nodes; fixed on one side, "
      "under gravity) at rest, while a blade cuts it, and pressed by a plate, with the "
      "jacobi, two_level, cholesky and multigrid preconditioners and the automatic choice, "
      "interleaved in rounds; prints a table of ms per step (median of the rounds' means, "
      "min-max) with auto over the best fixed choice, and how often that is within 1.15x. "
      "Progress and per-choice iterations on stderr. Exit status 2 for a bad argument.");
  app.add_option("--tolerance", o.tolerance, "relative residual tolerance of the solve")
      ->check(CLI::Validator(
          [](const std::string& text) {
            char* end = nullptr;
            const double t = std::strtod(text.c_str(), &end);
            const bool ok = end != text.c_str() && *end == '\0' && t > 0.0 && t < 0.5;
            return ok ? std::string() : "must be a number in (0, 0.5), not " + text;
          },
          "in (0, 0.5)"))
      ->capture_default_str();
  app.add_option("--threads", o.threads, "worker threads")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  app.add_option("--steps", o.steps, "measured steps per choice and round (--quick: 5)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--warmup", o.warmup,
                 "unmeasured steps per choice and round before them (--quick: 2)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  app.add_option("--rounds", o.rounds, "rounds; per choice the median of their means (--quick: 1)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--cut-level", o.cutLevel,
                 "cut: the finest level the cut's elements are refined to (0: the library's "
                 "default, as bench_fem and bench_topology; the world refines a moving blade's "
                 "elements to the body's start level only, here 3, or 2 from 12k nodes)")
      ->check(CLI::Range(0, 7))
      ->capture_default_str();
  app.add_flag("--quick", o.quick,
               "smoke run (under a minute): the sizes up to 3k nodes, and the --quick values "
               "of --steps, --warmup and --rounds unless given");
  app.add_flag("--all", o.all,
               "also block_jacobi, symmetric_gauss_seidel and incomplete_cholesky (about "
               "0.7 GB more memory at 30k nodes until they are cut short)");
  app.add_option("--json", o.json, "also write the results to this JSON file");
  std::vector<std::string> sizeLabels;
  for (const SizeSpec& s : kSizes) sizeLabels.emplace_back(s.label);
  app.add_option("--sizes", o.sizes, "only these sizes, comma-separated")
      ->delimiter(',')
      ->check(CLI::IsMember(sizeLabels));
  app.add_option("--states", o.states, "only these states, comma-separated")
      ->delimiter(',')
      ->check(CLI::IsMember({"rest", "cut", "contact"}));
}

}  // namespace
}  // namespace voxcut

int main(int argc, char** argv) {
  voxcut::Options o;
  CLI::App app("", "bench_solver_choice");
  voxcut::addOptions(app, o);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "bench_solver_choice: error: %s\n", e.what());
    return 2;
  }
  if (o.quick) {
    if (app.count("--steps") == 0) o.steps = 5;
    if (app.count("--warmup") == 0) o.warmup = 2;
    if (app.count("--rounds") == 0) o.rounds = 1;
  }
  std::ofstream json;
  if (!o.json.empty()) {
    json.open(o.json);
    if (!json) {
      std::fprintf(stderr, "bench_solver_choice: error: cannot write %s\n", o.json.c_str());
      return 2;
    }
  }
  try {
    voxcut::run(o, o.json.empty() ? nullptr : &json);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_solver_choice: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
