#include "RunCommand.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/io/SurfaceWriter.h"
#include "voxcut/sim/Simulation.h"

namespace voxcut::app {
namespace {

constexpr int kDefaultFrames = 100;

struct Summary {
  std::vector<double> stageSum, stageMax;
  std::vector<double> frameMs;
  std::size_t cutLinks = 0;
  long long iterations = 0;
  long long factorisations = 0;
  bool converged = true;
};

std::string exportPath(const std::string& dir, std::size_t body, std::size_t bodies, int frame) {
  char name[64];
  if (bodies == 1)
    std::snprintf(name, sizeof name, "frame_%05d.obj", frame);
  else
    std::snprintf(name, sizeof name, "body%zu_frame_%05d.obj", body, frame);
  return (std::filesystem::path(dir) / name).string();
}

void exportSurfaces(const Simulation& sim, const std::string& dir) {
  for (std::size_t b = 0; b < sim.bodies().size(); ++b)
    writeSurface(sim.deformedSurface(b), exportPath(dir, b, sim.bodies().size(), sim.frame()));
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

}  // namespace

void addRunCommand(CLI::App& app, RunOptions& opt, CLI::App*& cmd) {
  cmd = app.add_subcommand("run", "Run a scene: deformable bodies cut by key-framed blades, frame by frame");
  cmd->add_option("scene", opt.scene, "Scene file (JSON; format in docs/scenes.md)")->required();
  cmd->add_option("--frames", opt.frames, "Frames to run (default: the scene's \"frames\", else 100)")
      ->check(CLI::Range(1, 10000000));
  cmd->add_option("--threads", opt.threads, "Worker threads (default: all cores)")->check(CLI::Range(1, 1024));
  cmd->add_flag("--no-octree", opt.noOctree, "Baseline: every link active, no voxel octree");
  cmd->add_option("--export", opt.exportDir,
                  "Write the deformed surfaces to this folder as numbered OBJ files (frame_00000.obj "
                  "is the start; bodyN_ prefixes with several bodies)");
  cmd->add_option("--every", opt.every, "With --export: write every K-th frame (default 1)")
      ->check(CLI::Range(1, 10000000));
  cmd->add_option("--csv", opt.csv, "Write one row per frame with the time of each stage (ms)");
  cmd->add_flag("--json", opt.json, "Print one JSON summary object on stdout");
}

int runRun(const RunOptions& opt) {
  ThreadLimit limit(opt.threads);
  const Scene scene = readScene(opt.scene);
  const int frames = opt.frames > 0 ? opt.frames : scene.frames.value_or(kDefaultFrames);
  const bool terminal = isatty(STDERR_FILENO) != 0;
  ProgressCallback progress;
  if (terminal)
    progress = [](std::string_view stage, double f) {
      std::fprintf(stderr, "\r%.*s %3d%%", static_cast<int>(stage.size()), stage.data(),
                   static_cast<int>(std::lround(100 * f)));
      if (f >= 1.0) std::fprintf(stderr, "\r\033[K");
      std::fflush(stderr);
      return true;
    };
  std::vector<VoxelGrid> grids = voxelizeSceneBodies(scene, true, progress);
  SimulationParams sp;
  sp.useOctree = !opt.noOctree;
  Simulation sim(scene, std::move(grids), sp);

  std::vector<int> piecesBefore;
  for (std::size_t b = 0; b < sim.bodies().size(); ++b) piecesBefore.push_back(sim.pieces(b));
  if (!opt.exportDir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(opt.exportDir, ec);
    if (ec) throw InputError("--export: cannot create folder '" + opt.exportDir + "': " + ec.message());
    exportSurfaces(sim, opt.exportDir);
  }
  std::ofstream csv;
  const std::vector<std::string>& stages = frameStageNames();
  if (!opt.csv.empty()) {
    csv.open(opt.csv);
    if (!csv) throw InputError("--csv: cannot write '" + opt.csv + "'");
    csv << "frame,time_s";
    for (const std::string& s : stages) csv << "," << s << "_ms";
    csv << ",frame_ms,cut_links,solver_iterations,converged,solver_factorisations\n";
  }

  Summary sum;
  sum.stageSum.assign(stages.size(), 0.0);
  sum.stageMax.assign(stages.size(), 0.0);
  for (int f = 0; f < frames; ++f) {
    const FrameReport r = sim.step();
    for (std::size_t s = 0; s < stages.size(); ++s) {
      sum.stageSum[s] += r.stageMs[s];
      sum.stageMax[s] = std::max(sum.stageMax[s], r.stageMs[s]);
    }
    sum.frameMs.push_back(r.totalMs);
    sum.cutLinks += r.cutLinks;
    sum.iterations += r.solverIterations;
    sum.factorisations += r.solverFactorisations;
    sum.converged = sum.converged && r.converged;
    if (csv.is_open()) {
      csv << r.frame << "," << r.time;
      for (double ms : r.stageMs) csv << "," << ms;
      csv << "," << r.totalMs << "," << r.cutLinks << "," << r.solverIterations << ","
          << (r.converged ? 1 : 0) << "," << r.solverFactorisations << "\n";
    }
    if (!opt.exportDir.empty() && (f + 1) % opt.every == 0) exportSurfaces(sim, opt.exportDir);
    if (terminal) {
      std::fprintf(stderr, "\rframe %d/%d  %.1f ms  %zu links cut", f + 1, frames, r.totalMs, sum.cutLinks);
      std::fflush(stderr);
    }
  }
  if (terminal) std::fprintf(stderr, "\r\033[K");
  if (csv.is_open() && !(csv.flush())) throw InputError("--csv: cannot write '" + opt.csv + "'");

  int pieces = 0, piecesStart = 0;
  for (std::size_t b = 0; b < sim.bodies().size(); ++b) {
    pieces += sim.pieces(b);
    piecesStart += piecesBefore[b];
  }
  const double iterMean = static_cast<double>(sum.iterations) / static_cast<double>(std::max(frames, 1));
  if (opt.json) {
    nlohmann::json j;
    j["scene"] = opt.scene;
    j["frames"] = frames;
    j["time_step"] = scene.timeStep;
    j["threads"] = ThreadLimit::current();
    j["octree"] = !opt.noOctree;
    j["cut_links"] = sum.cutLinks;
    j["pieces_start"] = piecesStart;
    j["pieces"] = pieces;
    j["max_displacement"] = sim.maxDisplacement();
    j["solver_iterations_mean"] = iterMean;
    j["converged"] = sum.converged;
    j["solver_factorisations"] = sum.factorisations;
    nlohmann::json t = nlohmann::json::object();
    for (std::size_t s = 0; s < stages.size(); ++s)
      t[stages[s]] = {{"mean", sum.stageSum[s] / frames}, {"max", sum.stageMax[s]}};
    j["timings_ms"] = t;
    j["frame_ms"] = {{"mean", mean(sum.frameMs)},
                     {"p95", percentile(sum.frameMs, 0.95)},
                     {"max", percentile(sum.frameMs, 1.0)}};
    nlohmann::json bodies = nlohmann::json::array();
    for (const SimBody& b : sim.bodies())
      bodies.push_back({{"elements", b.cut.deformation.elementCount()},
                        {"nodes", b.cut.deformation.nodeCount()},
                        {"cut_links", b.cutLinks},
                        {"surface_vertices", b.surface.vertexCount()},
                        {"surface_triangles", b.surface.triangleCount()}});
    j["bodies"] = bodies;
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("scene               %s (%d frames of %.4g s, %d thread(s), %s)\n", opt.scene.c_str(),
                frames, scene.timeStep, ThreadLimit::current(),
                opt.noOctree ? "no octree" : "voxel octree");
    std::printf("cut links           %zu\n", sum.cutLinks);
    std::printf("pieces              %d (at the start %d)\n", pieces, piecesStart);
    std::printf("max displacement    %.6g m\n", sim.maxDisplacement());
    std::printf("solver              %.1f iterations per frame, %lld factorisations, %s\n", iterMean,
                sum.factorisations,
                sum.converged ? "converged every step" : "did NOT converge in some steps");
    std::printf("frame (ms)          mean %.2f, p95 %.2f, max %.2f\n", mean(sum.frameMs),
                percentile(sum.frameMs, 0.95), percentile(sum.frameMs, 1.0));
    std::printf("stages (ms)         mean / max\n");
    for (std::size_t s = 0; s < stages.size(); ++s)
      std::printf("  %-22s %8.3f / %8.3f\n", stages[s].c_str(), sum.stageSum[s] / frames, sum.stageMax[s]);
    if (!opt.exportDir.empty()) std::printf("surfaces written to %s\n", opt.exportDir.c_str());
  }
  return 0;
}

}  // namespace voxcut::app
