#include "SoakBench.h"

#include <unistd.h>

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "Interrupt.h"
#include "ModelOptions.h"
#include "OutputFiles.h"
#include "ProcessMemory.h"
#include "SoakInteraction.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/sim/World.h"

namespace voxcut::app {
namespace {

namespace fs = std::filesystem;

/// Frames of the windows compared at the start and the end of a run.
constexpr int kWindow = 100;
/// Pieces are counted (O(voxels)) every this many frames.
constexpr int kPiecesEvery = 10;

/// The bar for a run.
constexpr double kMaxTimeRatio = 3.0;    ///< last window's mean frame time over the first's
constexpr double kMaxLastMs = 30.0;      ///< last window's mean frame time
constexpr double kMaxNodesRatio = 3.0;   ///< nodes at the end over nodes after the first frame
constexpr double kMaxMemoryRatio = 2.0;  ///< peak resident memory over that after frame 0

/// What one run did, for the summary.
struct SoakRun {
  std::string name;
  std::uint64_t seed = 0;
  int blades = 0;
  std::string status = "complete";  ///< complete, interrupted, failed
  std::vector<double> frameMs;
  std::vector<std::vector<double>> stageMs;  ///< per frame
  std::size_t nodesStart = 0, nodesEnd = 0;
  int unconverged = 0;
  double residentFirst = 0.0, peak = 0.0;  ///< MiB
  double maxPenetration = 0.0;             ///< m
  /// The most the body's mechanical energy grew over a frame in which no tool touched it
  /// (no link cut, no probe reaction), J; and in how many such frames it grew by more than
  /// 1e-9 of itself.
  double energyGain = 0.0;
  int energyGainFrames = 0;
  double voxelSize = 0.0;
  std::size_t cutLinks = 0;
  int pieces = 0;
  std::uint64_t hash = 0;

  [[nodiscard]] int frames() const { return static_cast<int>(frameMs.size()); }
  /// Frames in each compared window: 100, or half the frames of a shorter run.
  [[nodiscard]] int window() const {
    return frames() >= 2 * kWindow ? kWindow : std::max(1, frames() / 2);
  }
  /// Mean of value(f) over the first (or last) window.
  template <class Value>
  [[nodiscard]] double windowMean(bool last, Value&& value) const {
    const int n = std::min(window(), frames());
    if (n == 0) return NAN;
    const int begin = last ? frames() - n : 0;
    double sum = 0.0;
    for (int f = begin; f < begin + n; ++f) sum += value(f);
    return sum / n;
  }
  [[nodiscard]] double firstMs() const {
    return windowMean(false, [this](int f) { return frameMs[f]; });
  }
  [[nodiscard]] double lastMs() const {
    return windowMean(true, [this](int f) { return frameMs[f]; });
  }
  [[nodiscard]] double timeRatio() const { return lastMs() / firstMs(); }
  [[nodiscard]] double nodesRatio() const {
    return nodesStart > 0 ? static_cast<double>(nodesEnd) / static_cast<double>(nodesStart) : NAN;
  }
  [[nodiscard]] double memoryRatio() const {
    return residentFirst > 0 ? peak / residentFirst : NAN;
  }
  [[nodiscard]] double penetrationVoxels() const {
    return voxelSize > 0 ? maxPenetration / voxelSize : NAN;
  }
  /// The stage whose mean time grew most from the first window to the last, and by how much.
  [[nodiscard]] std::pair<std::string, double> grownStage() const {
    std::pair<std::string, double> best{"-", 0.0};
    if (frames() == 0) return best;
    for (std::size_t s = 0; s < frameStageNames().size(); ++s) {
      const auto ms = [this, s](int f) { return s < stageMs[f].size() ? stageMs[f][s] : 0.0; };
      const double grown = windowMean(true, ms) - windowMean(false, ms);
      if (grown > best.second) best = {frameStageNames()[s], grown};
    }
    return best;
  }
  /// The parts of the bar the run misses, joined by ';' (empty: it meets the bar).
  [[nodiscard]] std::string misses() const {
    std::string m;
    const auto miss = [&m](const char* what) { m += (m.empty() ? "" : ";") + std::string(what); };
    if (status == "failed") miss("failed");
    if (frames() == 0) return m.empty() ? "no-frames" : m;
    if (!(timeRatio() <= kMaxTimeRatio)) miss("time-ratio");
    if (!(lastMs() <= kMaxLastMs)) miss("time");
    if (!(nodesRatio() <= kMaxNodesRatio)) miss("nodes");
    if (unconverged > 0) miss("unconverged");
    if (!(memoryRatio() <= kMaxMemoryRatio)) miss("memory");
    return m;
  }
};

/// The world frame's up axis of a model (gravity points down it): the liver and the starfish
/// lie in the x-y plane, as in their scenes; everything else stands along y.
int upAxis(const std::string& model) {
  return model == "liver" || model == "starfish" ? 2 : 1;
}

/// The model spec a scene body takes: built-ins and primitives as they are, a mesh file by its
/// absolute path.
std::string bodySpec(const std::string& model) {
  const std::vector<std::string> builtins = builtinModelNames();
  if (std::find(builtins.begin(), builtins.end(), model) != builtins.end() ||
      model.starts_with("box:") || model.starts_with("sphere:"))
    return model;
  std::error_code ec;
  const fs::path p = fs::absolute(model, ec);
  return ec ? model : p.lexically_normal().string();
}

/// A file name part from a model name: letters, digits, '-', '_' and '.', others as '_'.
std::string fileSafe(std::string name) {
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.') c = '_';
  return name;
}

/// The shipped scenes' tissue (scenes/complex-*.json): E 1 MPa (a tumour 3 MPa), nu 0.4,
/// 1000 kg/m^3, damping 20/s and 0.005 s, voxel octree levels 4 and 0.
std::vector<SceneMaterial> soakMaterials(const Model& model) {
  std::vector<SceneMaterial> out;
  for (const std::string& name : model.materialNames()) {
    SceneMaterial s;
    s.name = name;
    s.youngModulus = name == "tumor" ? 3.0e6 : 1.0e6;
    s.massDamping = 20.0;
    s.stiffnessDamping = 0.005;
    out.push_back(s);
  }
  return out;
}

/// The lowest live surface vertex of `body` along `up` (m).
double lowestPoint(World& world, BodyId body, const Vec3d& up) {
  const SurfaceView view = world.surface(body);
  double low = std::numeric_limits<double>::infinity();
  for (const std::array<int, 3>& t : view.triangles)
    if (t[0] >= 0)
      for (int v : t) low = std::min(low, view.positions[static_cast<std::size_t>(v)].dot(up));
  return std::isfinite(low) ? low : 0.0;
}

std::string csvHeader() {
  std::string h = "frame";
  for (const std::string& s : frameStageNames()) h += "," + s + "_ms";
  return h +
         ",frame_ms,nodes,elements,pieces,contacts,solver_iterations,converged,cut_links,"
         "cut_links_frame,max_penetration_m,rss_mib,peak_rss_mib,probe_force_N,energy_J,touched,"
         "episode";
}

std::string hex(std::uint64_t h) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, h);
  return buf;
}

/// A number for the summary: "-" for NaN.
std::string cell(double v, const char* format = "%.2f") {
  if (std::isnan(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

/// Everything a run needs besides its seed.
struct SoakSetup {
  const SoakBenchOptions& opt;
  std::string modelName;  ///< the model's name, as file names take it
  std::string stem;       ///< MODEL-rRES-lLEVEL
  Scene scene;
  VoxelGrid grid;
  int upAxis = 1;
  bool terminal = false;
};

/// Runs the soak of one seed; writes its CSV. Returns what it did.
SoakRun runSeed(const SoakSetup& setup, std::uint64_t seed) {
  const SoakBenchOptions& opt = setup.opt;
  SoakRun run;
  run.seed = seed;
  run.name = setup.stem + "-s" + std::to_string(seed);
  resetPeakMemory();
  WorldSettings ws;
  ws.useOctree = !opt.noOctree;
  std::vector<VoxelGrid> grids;
  grids.push_back(setup.grid);
  World world = World::fromScene(setup.scene, std::move(grids), ws);
  const Vec3d up = Vec3d::Unit(setup.upAxis);
  const BodyId body = world.bodies().front();
  run.voxelSize = world.bodyInfo(body).voxelSize;
  // The floor a quarter voxel under the body: it settles onto it in the first frames.
  Obstacle floor;
  floor.type = ObstacleType::Plane;
  floor.normal = up;
  floor.point = up * (lowestPoint(world, body, up) - 0.25 * run.voxelSize);
  world.addObstacle(floor);
  SoakInteraction user(world, body, {seed, opt.blades, setup.upAxis});
  run.blades = user.blades();
  // The probe's entry in FrameReport::toolReactions (the order of World::tools()).
  const std::vector<ToolId> tools = world.tools();
  const auto probeEntry = static_cast<std::size_t>(
      std::find(tools.begin(), tools.end(), user.probe()) - tools.begin());

  PendingFile csv((fs::path(opt.out) / (run.name + ".csv")).string(), "--out");
  csv.writeLine(csvHeader());
  double energyBefore = world.energy(body).total();
  for (int f = 0; f < opt.frames; ++f) {
    if (interruptRequested()) {
      run.status = "interrupted";
      break;
    }
    user.beforeStep(world);
    FrameReport r;
    try {
      r = world.step();
    } catch (const StepError& e) {
      std::fprintf(stderr, "%svoxcut: %s: %s\n", setup.terminal ? "\r\033[K" : "", run.name.c_str(),
                   e.what());
      run.status = "failed";
      break;
    }
    const BodyInfo info = world.bodyInfo(body);
    const ProcessMemory memory = processMemory();
    double probeForce = 0.0;
    if (probeEntry < r.toolReactions.size())
      probeForce = r.toolReactions[probeEntry].force.norm();
    // Touched: a link cut or a probe pressing in this frame (a blade moving in its own cut
    // touches nothing).
    bool touched = r.cutLinks > 0;
    for (const ToolReaction& t : r.toolReactions) touched = touched || t.force.squaredNorm() > 0.0;
    const double energy = world.energy(body).total();
    if (!touched && f > 0) {
      const double gain = energy - energyBefore;
      run.energyGain = std::max(run.energyGain, gain);
      if (gain > 1e-9 * std::abs(energyBefore)) ++run.energyGainFrames;
    }
    energyBefore = energy;
    const bool counted = f % kPiecesEvery == 0 || f + 1 == opt.frames;
    const int pieces = counted ? world.pieces(body) : 0;

    run.frameMs.push_back(r.totalMs);
    run.stageMs.push_back(r.stageMs);
    if (f == 0) {
      run.nodesStart = info.nodes;
      run.residentFirst = memory.residentMiB;
    }
    run.nodesEnd = info.nodes;
    run.unconverged += r.converged ? 0 : 1;
    run.peak = std::max({run.peak, memory.peakMiB, memory.residentMiB});
    run.maxPenetration = std::max(run.maxPenetration, r.maxPenetration);
    run.cutLinks = info.cutLinks;
    if (counted) run.pieces = pieces;

    std::ostringstream row;
    row << r.frame;
    for (double ms : r.stageMs) row << ',' << ms;
    row << ',' << r.totalMs << ',' << info.nodes << ',' << info.elements << ',';
    if (counted) row << pieces;
    row << ',' << r.contacts << ',' << r.solverIterations << ',' << (r.converged ? 1 : 0) << ','
        << info.cutLinks << ',' << r.cutLinks << ',' << r.maxPenetration << ','
        << memory.residentMiB << ',' << memory.peakMiB << ',' << probeForce << ',' << energy
        << ',' << (touched ? 1 : 0) << ',' << user.episode();
    csv.writeLine(row.str());
    if (setup.terminal) {
      std::fprintf(stderr, "\r%s: frame %d/%d  %.1f ms  %zu links cut  %s\033[K", run.name.c_str(),
                   f + 1, opt.frames, r.totalMs, info.cutLinks, user.episode().c_str());
      std::fflush(stderr);
    }
  }
  if (setup.terminal) std::fprintf(stderr, "\r\033[K");
  // The pieces at the end of a run stopped early (the last row may not have counted them).
  if (run.status != "complete" && run.frames() > 0) run.pieces = world.pieces(body);
  run.hash = world.cutSetHash();
  csv.commit();
  return run;
}

std::string summaryHeader() {
  return "run,model,resolution,element_level,finest_level,seed,blades,threads,octree,"
         "self_collision,frames,frames_asked,status,window,first_ms,last_ms,time_ratio,"
         "nodes_start,nodes_end,nodes_ratio,unconverged_frames,rss_first_mib,rss_peak_mib,"
         "memory_ratio,max_penetration_voxels,untouched_energy_gain_j,untouched_gain_frames,"
         "cut_links,pieces,cut_set_hash,grown_stage,grown_stage_ms,meets_bar,misses";
}

std::string summaryRow(const SoakSetup& setup, const SoakRun& r) {
  const SoakBenchOptions& o = setup.opt;
  const auto [stage, grown] = r.grownStage();
  const std::string misses = r.misses();
  std::ostringstream row;
  row << r.name << ',' << setup.modelName << ',' << o.resolution << ',' << o.elementLevel << ','
      << o.finestLevel << ',' << r.seed << ',' << r.blades << ',' << ThreadLimit::current() << ','
      << (o.noOctree ? 0 : 1) << ',' << (o.selfCollision == "on" ? 1 : 0) << ',' << r.frames()
      << ',' << o.frames << ',' << r.status << ',' << r.window() << ',' << cell(r.firstMs(), "%.4f")
      << ',' << cell(r.lastMs(), "%.4f") << ',' << cell(r.timeRatio(), "%.4f") << ','
      << r.nodesStart << ',' << r.nodesEnd << ',' << cell(r.nodesRatio(), "%.4f") << ','
      << r.unconverged << ',' << cell(r.residentFirst, "%.1f") << ',' << cell(r.peak, "%.1f") << ','
      << cell(r.memoryRatio(), "%.4f") << ',' << cell(r.penetrationVoxels(), "%.4f") << ','
      << cell(r.energyGain, "%.3g") << ',' << r.energyGainFrames << ',' << r.cutLinks << ',' << r.pieces << ',' << hex(r.hash) << ',' << stage << ','
      << cell(grown, "%.4f") << ',' << (misses.empty() ? 1 : 0) << ','
      << (misses.empty() ? "-" : misses);
  return row.str();
}

void printTableHeader(const SoakSetup& setup) {
  const SoakBenchOptions& o = setup.opt;
  std::printf(
      "# Soak: %s, resolution %d, element level %d, finest level %d, %d frames, %d thread(s), "
      "%s, self collision %s\n\n",
      o.model.c_str(), o.resolution, o.elementLevel, o.finestLevel, o.frames,
      ThreadLimit::current(), o.noOctree ? "no octree" : "voxel octree", o.selfCollision.c_str());
  std::printf(
      "| run | frames | first ms | last ms | ratio | nodes start | nodes end | ratio | "
      "unconverged | memory first MiB | peak MiB | ratio | max penetration (voxels) | "
      "energy gain untouched (J; frames) | cut links | pieces | most grown stage (ms) | bar |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::fflush(stdout);
}

void printTableRow(const SoakRun& r) {
  const auto [stage, grown] = r.grownStage();
  const std::string misses = r.misses();
  std::printf(
      "| %s | %d%s | %s | %s | %s | %zu | %zu | %s | %d | %s | %s | %s | %s | %s; %d | %zu | "
      "%d | %s %s | %s |\n",
      r.name.c_str(), r.frames(), r.status == "complete" ? "" : (" (" + r.status + ")").c_str(),
      cell(r.firstMs()).c_str(), cell(r.lastMs()).c_str(), cell(r.timeRatio()).c_str(),
      r.nodesStart, r.nodesEnd, cell(r.nodesRatio()).c_str(), r.unconverged,
      cell(r.residentFirst, "%.0f").c_str(), cell(r.peak, "%.0f").c_str(),
      cell(r.memoryRatio()).c_str(), cell(r.penetrationVoxels(), "%.3f").c_str(),
      cell(r.energyGain, "%.2g").c_str(), r.energyGainFrames, r.cutLinks,
      r.pieces, stage.c_str(), cell(grown, "%+.2f").c_str(),
      misses.empty() ? "met" : ("missed: " + misses).c_str());
  std::fflush(stdout);
}

}  // namespace

void addSoakBenchCommand(CLI::App& bench, SoakBenchOptions& opt) {
  CLI::App* cmd = bench.add_subcommand(
      "soak",
      "Long seeded session of random cuts and probe pokes on a model resting on a floor; logs "
      "every frame to OUT/MODEL-rRES-lLEVEL-sSEED.csv and summarises growth (first vs last 100 "
      "frames) per run to stdout and OUT/summary.csv; Ctrl-C or SIGTERM stops at the next frame "
      "boundary and still writes both (exit 130)");
  cmd->add_option("--model", opt.model,
                  "Model: bunny, liver, starfish (also box:LX,LY,LZ, sphere:R or a mesh file); "
                  "default bunny");
  cmd->add_option("--resolution", opt.resolution,
                  "Voxels along the model's longest side, padding included (default 64)")
      ->check(CLI::Range(4, 4096));
  cmd->add_option("--element-level", opt.elementLevel,
                  "Starting level of the deformation octree, 0..6 (default 3)")
      ->check(CLI::Range(0, 6));
  cmd->add_option("--finest-level", opt.finestLevel,
                  "Finest level a resting cut front is refined to, 0..element level (default: "
                  "element level - 2, at least 0)")
      ->check(CLI::Range(0, 6));
  cmd->add_option("--frames", opt.frames, "Frames per run, 4 ms each (default 600)")
      ->check(CLI::Range(1, 10000000));
  cmd->add_option("--seed", opt.seed, "Seed of the first run (default 1)");
  cmd->add_option("--seeds", opt.seeds, "Runs, one per seed: SEED, SEED+1, ... (default 1)")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--blades", opt.blades,
                  "Blades, 1..3 (default: 1 to 3, drawn from each seed); there is always one "
                  "probe")
      ->check(CLI::Range(1, 3));
  cmd->add_option("--threads", opt.threads, "Worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  cmd->add_option("--self-collision", opt.selfCollision,
                  "on or off: keep the body's surface out of its own material, cut faces and "
                  "fallen pieces included (default on)")
      ->check(CLI::IsMember({"on", "off"}));
  cmd->add_flag("--no-octree", opt.noOctree, "Baseline: every link active, no voxel octree");
  cmd->add_option("--out", opt.out,
                  "Output folder (default out/soak; created when missing); a summary.csv there "
                  "is replaced");
  addMaxMemoryOption(*cmd, opt.maxMemory);
  cmd->callback([&opt] { opt.selected = true; });
}

int runSoakBench(const SoakBenchOptions& opt) {
  if (opt.finestLevel > opt.elementLevel)
    throw InputError("--finest-level " + std::to_string(opt.finestLevel) +
                     ": must be at most --element-level (" + std::to_string(opt.elementLevel) +
                     ")");
  checkOutputFolder(opt.out, "--out");
  const std::size_t maxMemory = memoryLimit(opt.maxMemory);
  const ThreadLimit limit(opt.threads);
  const InterruptGuard interruptGuard;
  const Model model = loadModel(opt.model);
  SoakSetup setup{
      opt, fileSafe(model.name), {}, {}, {}, upAxis(model.name), isatty(STDERR_FILENO) != 0};
  setup.stem = setup.modelName + "-r" + std::to_string(opt.resolution) + "-l" +
               std::to_string(opt.elementLevel);
  Scene& scene = setup.scene;
  scene.source = "bench soak";
  scene.gravity = -9.81 * Vec3d::Unit(setup.upAxis);
  SceneBody body;
  body.model = bodySpec(opt.model);
  body.resolution = opt.resolution;
  body.elementLevel = opt.elementLevel;
  body.finestLevel = opt.finestLevel;
  body.materials = soakMaterials(model);
  scene.bodies.push_back(std::move(body));
  scene.contact.selfCollision = opt.selfCollision == "on";
  SceneBodiesParams bp;
  bp.maxMemory = maxMemory;
  bp.useOctree = !opt.noOctree;
  bp.progress = terminalProgress();
  setup.grid = std::move(voxelizeSceneBodies(scene, bp).front());

  std::error_code ec;
  fs::create_directories(opt.out, ec);
  if (ec) throw InputError("--out: cannot create folder '" + opt.out + "': " + ec.message());
  PendingFile summary((fs::path(opt.out) / "summary.csv").string(), "--out");
  summary.writeLine(summaryHeader());
  printTableHeader(setup);
  std::vector<SoakRun> runs;
  for (int k = 0; k < opt.seeds && !interruptRequested(); ++k) {
    runs.push_back(runSeed(setup, opt.seed + static_cast<std::uint64_t>(k)));
    summary.writeLine(summaryRow(setup, runs.back()));
    printTableRow(runs.back());
  }
  summary.commit();
  // A signal after the last frame of the last run stops nothing: the soak is complete.
  const bool interrupted =
      interruptRequested() && (static_cast<int>(runs.size()) < opt.seeds ||
                               (!runs.empty() && runs.back().status == "interrupted"));
  std::vector<std::string> missed;
  for (const SoakRun& r : runs)
    if (!r.misses().empty()) missed.push_back(r.name + " (" + r.misses() + ")");
  std::printf(
      "\nbar (last %d frames' mean <= %.0fx the first %d frames' and <= %.0f ms; nodes at the "
      "end <= %.0fx after the first frame; no unconverged frame; peak memory <= %.0fx that "
      "after the first frame): ",
      kWindow, kMaxTimeRatio, kWindow, kMaxLastMs, kMaxNodesRatio, kMaxMemoryRatio);
  if (missed.empty()) {
    std::printf("met by every run (%zu)\n", runs.size());
  } else {
    std::printf("missed by %zu of %zu runs:", missed.size(), runs.size());
    for (std::size_t i = 0; i < missed.size(); ++i)
      std::printf("%s %s", i == 0 ? "" : ",", missed[i].c_str());
    std::printf("\n");
  }
  if (interrupted) std::printf("interrupted after %zu of %d runs\n", runs.size(), opt.seeds);
  std::printf("CSVs in %s\n", opt.out.c_str());
  return interrupted ? kInterruptedStatus : 0;
}

}  // namespace voxcut::app
