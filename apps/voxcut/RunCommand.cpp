#include "RunCommand.h"

#include <unistd.h>

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "Interrupt.h"
#include "ModelOptions.h"
#include "OutputFiles.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/Recording.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/io/SurfaceWriter.h"
#include "voxcut/sim/World.h"
// The viewer's renderer, for --screenshots.
#include "Camera.h"
#include "DrawData.h"
#include "GlContext.h"
#include "Renderer.h"

namespace voxcut::app {
namespace {

constexpr int kDefaultFrames = 100;

struct Summary {
  std::vector<double> stageSum, stageMax;
  std::vector<double> frameMs;
  std::size_t cutLinks = 0;
  long long iterations = 0;
  long long solves = 0;  ///< implicit steps solved (re-solves of a changed contact set too)
  long long factorisations = 0;
  bool converged = true;
  std::size_t contacts = 0;           ///< point contacts, summed over the frames
  double maxPenetration = 0.0;        ///< over the frames (m)
  std::vector<double> toolForceMax;   ///< per tool, the largest reaction force (N)
  std::vector<Vec3d> toolForceFinal;  ///< per tool, the reaction force of the last frame (N)

  void add(const FrameReport& r) {
    stageSum.resize(r.stageMs.size(), 0.0);
    stageMax.resize(r.stageMs.size(), 0.0);
    for (std::size_t s = 0; s < r.stageMs.size(); ++s) {
      stageSum[s] += r.stageMs[s];
      stageMax[s] = std::max(stageMax[s], r.stageMs[s]);
    }
    frameMs.push_back(r.totalMs);
    cutLinks += r.cutLinks;
    iterations += r.solverIterations;
    solves += r.solverSolves;
    factorisations += r.solverFactorisations;
    converged = converged && r.converged;
    contacts += r.contacts;
    maxPenetration = std::max(maxPenetration, r.maxPenetration);
    toolForceMax.resize(r.toolReactions.size(), 0.0);
    toolForceFinal.resize(r.toolReactions.size(), Vec3d::Zero());
    for (std::size_t t = 0; t < r.toolReactions.size(); ++t) {
      toolForceMax[t] = std::max(toolForceMax[t], r.toolReactions[t].force.norm());
      toolForceFinal[t] = r.toolReactions[t].force;
    }
  }
  [[nodiscard]] int frames() const { return static_cast<int>(frameMs.size()); }
  [[nodiscard]] double stageMean(std::size_t s) const {
    return s < stageSum.size() && frames() > 0 ? stageSum[s] / frames() : 0.0;
  }
  [[nodiscard]] double stageMaximum(std::size_t s) const {
    return s < stageMax.size() ? stageMax[s] : 0.0;
  }
};

/// A folder of the files a run writes frame by frame (--export, --screenshots): created at the
/// first file; the files this run wrote are removed again unless keep() is called (a run that
/// fails leaves none). Each file is written whole by its writer.
class OutputFolder {
 public:
  OutputFolder(std::string dir, std::string option)
      : dir_(std::move(dir)), option_(std::move(option)) {}
  ~OutputFolder() {
    if (keep_) return;
    std::error_code ec;
    for (const std::string& f : written_) std::filesystem::remove(f, ec);
  }
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  [[nodiscard]] bool used() const { return !dir_.empty(); }
  /// The path of file `name` in the folder (created now if need be), counted as this run's.
  std::string file(const std::string& name) {
    if (!created_) {
      std::error_code ec;
      std::filesystem::create_directories(dir_, ec);
      if (ec) throw InputError(option_ + ": cannot create folder '" + dir_ + "': " + ec.message());
      created_ = true;
    }
    written_.push_back((std::filesystem::path(dir_) / name).string());
    return written_.back();
  }
  void keep() { keep_ = true; }

 private:
  std::string dir_, option_;
  std::vector<std::string> written_;
  bool created_ = false, keep_ = false;
};

/// The surfaces of --export: frame_NNNNN.obj, or bodyB_frame_NNNNN.obj with several bodies.
class Exporter {
 public:
  explicit Exporter(std::string dir) : folder_(std::move(dir), "--export") {}
  void write(const World& sim) {
    if (!folder_.used()) return;
    for (std::size_t b = 0; b < sim.bodyCount(); ++b) {
      char name[64];
      if (sim.bodyCount() == 1)
        std::snprintf(name, sizeof name, "frame_%05d.obj", sim.frame());
      else
        std::snprintf(name, sizeof name, "body%zu_frame_%05d.obj", b, sim.frame());
      const std::string path = folder_.file(name);
      // writeSurface writes beside the file first; a forced end must not leave that behind.
      const TemporaryFileGuard temporary(path + ".tmp");
      writeSurface(sim.surfaceMesh(sim.bodies()[b]), path);
    }
  }
  void keep() { folder_.keep(); }

 private:
  OutputFolder folder_;
};

/// The pictures of --screenshots, frame_NNNNN.png: drawn by the viewer's renderer in a hidden
/// window (so a display is needed: xvfb-run on a machine without one), the camera fitted to
/// the bodies at the start and kept.
class Pictures {
 public:
  Pictures(std::string dir, const std::string& size) : folder_(std::move(dir), "--screenshots") {
    if (!folder_.used()) return;
    view::parseViewSize(size, "--size", camera_.width, camera_.height);
    context_.emplace(camera_.width, camera_.height, false, "voxcut run");
    renderer_.emplace();
  }

  void write(World& sim, const Scene& scene) {
    if (!folder_.used()) return;
    const view::DrawData data = view::buildDrawData(sim, scene.obstacles, {});
    if (!fitted_) {
      // As the viewer starts: up against gravity, from the scene's view when it has one.
      camera_.upAgainst(scene.gravity);
      if (scene.view) {
        camera_.yaw = (*scene.view)[0] * std::numbers::pi / 180.0;
        camera_.pitch = (*scene.view)[1] * std::numbers::pi / 180.0;
      }
      camera_.fit(data.bodyBounds);
      fitted_ = true;
    }
    char name[64];
    std::snprintf(name, sizeof name, "frame_%05d.png", sim.frame());
    const std::string path = folder_.file(name);
    const TemporaryFileGuard temporary(path + ".part.png");  // writePng's temporary
    view::writePng(renderer_->capture(data, camera_, false), path);
  }
  void keep() { folder_.keep(); }

 private:
  OutputFolder folder_;
  std::optional<view::GlContext> context_;
  std::optional<view::Renderer> renderer_;
  view::Camera camera_;
  bool fitted_ = false;
};

std::string csvHeader() {
  std::string h = "frame,time_s";
  for (const std::string& s : frameStageNames()) h += "," + s + "_ms";
  return h +
         ",frame_ms,cut_links,solver_iterations,converged,solver_factorisations,contacts,"
         "solver_solves";
}

std::string csvRow(const FrameReport& r) {
  std::ostringstream row;
  row << r.frame << "," << r.time;
  for (double ms : r.stageMs) row << "," << ms;
  row << "," << r.totalMs << "," << r.cutLinks << "," << r.solverIterations << ","
      << (r.converged ? 1 : 0) << "," << r.solverFactorisations << "," << r.contacts << ","
      << r.solverSolves;
  return row.str();
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1;
  return v[std::min(k, v.size() - 1)];
}

double mean(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

/// What the summary reports besides the frames' sums.
struct RunFacts {
  const RunOptions& opt;
  const Scene& scene;
  const World& sim;
  int framesAsked = 0;
  int piecesStart = 0;
  bool interrupted = false;
};

void printJson(const RunFacts& f, const Summary& sum) {
  const std::vector<std::string>& stages = frameStageNames();
  int pieces = 0;
  for (const BodyId b : f.sim.bodies()) pieces += f.sim.pieces(b);
  char hash[32];
  std::snprintf(hash, sizeof hash, "%016" PRIx64, f.sim.cutSetHash());
  nlohmann::json j;
  j["scene"] = f.opt.scene;
  j["frames"] = sum.frames();
  j["interrupted"] = f.interrupted;
  j["time_step"] = f.scene.timeStep;
  j["threads"] = ThreadLimit::current();
  j["octree"] = !f.opt.noOctree;
  j["cut_links"] = sum.cutLinks;
  j["cut_set_hash"] = hash;
  j["pieces_start"] = f.piecesStart;
  j["pieces"] = pieces;
  j["max_displacement"] = f.sim.maxDisplacement();
  j["solver_iterations_mean"] =
      static_cast<double>(sum.iterations) / static_cast<double>(std::max(sum.frames(), 1));
  j["solver_solves_mean"] =
      static_cast<double>(sum.solves) / static_cast<double>(std::max(sum.frames(), 1));
  j["converged"] = sum.converged;
  j["solver_factorisations"] = sum.factorisations;
  j["contact"] = {{"max_penetration", sum.maxPenetration},
                  {"mean_contacts", static_cast<double>(sum.contacts) /
                                        static_cast<double>(std::max(sum.frames(), 1))}};
  nlohmann::json forces = nlohmann::json::array();
  for (std::size_t t = 0; t < f.sim.toolCount(); ++t) {
    const double max = t < sum.toolForceMax.size() ? sum.toolForceMax[t] : 0.0;
    const Vec3d last = t < sum.toolForceFinal.size() ? sum.toolForceFinal[t] : Vec3d::Zero();
    forces.push_back({{"max", max}, {"final", {last.x(), last.y(), last.z()}}});
  }
  j["tool_forces"] = forces;
  nlohmann::json t = nlohmann::json::object();
  for (std::size_t s = 0; s < stages.size(); ++s)
    t[stages[s]] = {{"mean", sum.stageMean(s)}, {"max", sum.stageMaximum(s)}};
  j["timings_ms"] = t;
  j["frame_ms"] = {{"mean", mean(sum.frameMs)},
                   {"p95", percentile(sum.frameMs, 0.95)},
                   {"max", percentile(sum.frameMs, 1.0)}};
  nlohmann::json bodies = nlohmann::json::array();
  for (const BodyId b : f.sim.bodies()) {
    const BodyInfo info = f.sim.bodyInfo(b);
    bodies.push_back({{"elements", info.elements},
                      {"nodes", info.nodes},
                      {"cut_links", info.cutLinks},
                      {"surface_vertices", info.surfaceVertices},
                      {"surface_triangles", info.surfaceTriangles},
                      {"solver", solverChoiceName(info.solver)}});
  }
  j["bodies"] = bodies;
  std::cout << j.dump(2) << "\n";
}

void printText(const RunFacts& f, const Summary& sum) {
  const std::vector<std::string>& stages = frameStageNames();
  int pieces = 0;
  for (const BodyId b : f.sim.bodies()) pieces += f.sim.pieces(b);
  std::printf("scene               %s (%d frames of %.4g s, %d thread(s), %s)\n",
              f.opt.scene.c_str(), sum.frames(), f.scene.timeStep, ThreadLimit::current(),
              f.opt.noOctree ? "no octree" : "voxel octree");
  if (f.interrupted)
    std::printf("interrupted         after %d of %d frames\n", sum.frames(), f.framesAsked);
  std::printf("cut links           %zu\n", sum.cutLinks);
  std::printf("pieces              %d (at the start %d)\n", pieces, f.piecesStart);
  std::printf("max displacement    %.6g m\n", f.sim.maxDisplacement());
  std::printf("solver              %.1f iterations per frame, %lld factorisations, %s\n",
              static_cast<double>(sum.iterations) / static_cast<double>(std::max(sum.frames(), 1)),
              sum.factorisations,
              sum.converged ? "converged every step" : "did NOT converge in some steps");
  if (!f.scene.obstacles.empty() || sum.contacts > 0)
    std::printf("contact             %.1f points per frame, deepest %.3g m\n",
                static_cast<double>(sum.contacts) / static_cast<double>(std::max(sum.frames(), 1)),
                sum.maxPenetration);
  for (std::size_t t = 0; t < f.sim.toolCount(); ++t)
    if (f.sim.toolKind(f.sim.tools()[t]) == ToolKind::Probe && t < sum.toolForceMax.size())
      std::printf("probe %-13zu force max %.4g N, final %.4g N\n", t, sum.toolForceMax[t],
                  sum.toolForceFinal[t].norm());
  std::printf("frame (ms)          mean %.2f, p95 %.2f, max %.2f\n", mean(sum.frameMs),
              percentile(sum.frameMs, 0.95), percentile(sum.frameMs, 1.0));
  std::printf("stages (ms)         mean / max\n");
  for (std::size_t s = 0; s < stages.size(); ++s)
    std::printf("  %-22s %8.3f / %8.3f\n", stages[s].c_str(), sum.stageMean(s),
                sum.stageMaximum(s));
  if (!f.opt.exportDir.empty()) std::printf("surfaces written to %s\n", f.opt.exportDir.c_str());
  if (!f.opt.screenshotDir.empty())
    std::printf("pictures written to %s\n", f.opt.screenshotDir.c_str());
}

}  // namespace

void addRunCommand(CLI::App& app, RunOptions& opt, CLI::App*& cmd) {
  cmd = app.add_subcommand(
      "run",
      "Run a scene: deformable bodies cut by key-framed blades and pushed by probes and "
      "obstacles, frame by frame; Ctrl-C or "
      "SIGTERM stops it at the next frame boundary with a summary of the frames run (exit 130); "
      "a third signal ends it at once");
  cmd->add_option("scene", opt.scene, "Scene file (JSON; format in docs/scenes.md)")->required();
  cmd->add_option("--frames", opt.frames,
                  "Frames to run (default: the scene's \"frames\", else 100)")
      ->check(CLI::Range(1, 10000000));
  cmd->add_option("--threads", opt.threads, "Worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  cmd->add_flag("--no-octree", opt.noOctree, "Baseline: every link active, no voxel octree");
  cmd->add_option(
      "--export", opt.exportDir,
      "Write the deformed surfaces to this folder as numbered OBJ files (frame_00000.obj "
      "is the start; bodyN_ prefixes with several bodies; created when missing)");
  cmd->add_option("--screenshots", opt.screenshotDir,
                  "Draw the start and every K-th frame (--every) to this folder as PNG "
                  "(frame_00000.png, ...) with the viewer's renderer; needs a display (on a "
                  "machine without one: xvfb-run -a voxcut run ...)");
  cmd->add_option("--size", opt.size, "With --screenshots: picture size WxH (default 640x480)");
  cmd->add_option("--every", opt.every,
                  "With --export or --screenshots: every K-th frame (default 1)")
      ->check(CLI::Range(1, 10000000));
  cmd->add_option(
      "--csv", opt.csv,
      "Write one row per frame with the time of each stage (ms); the folder must exist");
  cmd->add_option("--record", opt.record,
                  "Write every tool's pose, once per frame, to this file (JSON; a scene tool's "
                  "\"trajectory\" plays it back, docs/scenes.md); the folder must exist");
  cmd->add_flag("--json", opt.json, "Print one JSON summary object on stdout");
  addMaxMemoryOption(*cmd, opt.maxMemory);
}

int runRun(const RunOptions& opt) {
  ThreadLimit limit(opt.threads);
  const std::size_t maxMemory = memoryLimit(opt.maxMemory);
  if (!opt.csv.empty()) checkOutputFile(opt.csv, "--csv");
  if (!opt.record.empty()) checkOutputFile(opt.record, "--record");
  if (!opt.exportDir.empty()) checkOutputFolder(opt.exportDir, "--export");
  if (!opt.screenshotDir.empty()) checkOutputFolder(opt.screenshotDir, "--screenshots");
  // The window for pictures first: without a display, the run stops before any work.
  Pictures pictures(opt.screenshotDir, opt.size);
  const InterruptGuard interruptGuard;
  const Scene scene = readScene(opt.scene);
  const int frames = opt.frames > 0 ? opt.frames : scene.frames.value_or(kDefaultFrames);
  const bool terminal = isatty(STDERR_FILENO) != 0;
  SceneBodiesParams bp;
  bp.maxMemory = maxMemory;
  bp.useOctree = !opt.noOctree;
  // The voxelizer asks between its stages whether to go on; a signal stops it there.
  bp.progress = terminalProgress();
  std::vector<VoxelGrid> grids = voxelizeSceneBodies(scene, bp);
  WorldSettings ws;
  ws.useOctree = !opt.noOctree;
  World sim = World::fromScene(scene, std::move(grids), ws);
  if (!opt.record.empty()) sim.setRecording(true);

  RunFacts facts{opt, scene, sim, frames};
  for (const BodyId b : sim.bodies()) facts.piecesStart += sim.pieces(b);
  Exporter exporter(opt.exportDir);
  std::optional<PendingFile> csv;
  if (!opt.csv.empty()) {
    csv.emplace(opt.csv, "--csv");
    csv->writeLine(csvHeader());
  }
  if (!interruptRequested()) {
    exporter.write(sim);
    pictures.write(sim, scene);
  }

  Summary sum;
  for (int f = 0; f < frames && !interruptRequested(); ++f) {
    const FrameReport r = sim.step();
    sum.add(r);
    if (csv) csv->writeLine(csvRow(r));
    if ((f + 1) % opt.every == 0) {
      exporter.write(sim);
      pictures.write(sim, scene);
    }
    if (terminal) {
      std::fprintf(stderr, "\rframe %d/%d  %.1f ms  %zu links cut", f + 1, frames, r.totalMs,
                   sum.cutLinks);
      std::fflush(stderr);
    }
  }
  if (terminal) std::fprintf(stderr, "\r\033[K");
  // A signal after the last frame stops nothing: the run is complete.
  facts.interrupted = interruptRequested() && sum.frames() < frames;
  if (csv) csv->commit();
  if (!opt.record.empty()) {
    PendingFile record(opt.record, "--record");
    std::string text = recordingText(sim);
    if (!text.empty() && text.back() == '\n') text.pop_back();
    record.writeLine(text);
    record.commit();
  }
  exporter.keep();
  pictures.keep();
  if (opt.json)
    printJson(facts, sum);
  else
    printText(facts, sum);
  return facts.interrupted ? kInterruptedStatus : 0;
}

}  // namespace voxcut::app
