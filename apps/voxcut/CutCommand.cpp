#include "CutCommand.h"

#include <unistd.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "OutputFiles.h"
#include "voxcut/core/CoordinateRange.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/SurfaceWriter.h"
#include "voxcut/sim/SingleFrameCut.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut::app {
namespace {

BladePose parsePose(const std::string& text, const char* option) {
  const std::vector<double> v = parseNumberList(text, option, 6, "AX,AY,AZ,BX,BY,BZ");
  static constexpr const char* kNames[6] = {"AX", "AY", "AZ", "BX", "BY", "BZ"};
  for (std::size_t i = 0; i < v.size(); ++i)
    requireCoordinate(v[i], std::string(option) + " '" + text + "': " + kNames[i]);
  BladePose p{Vec3d(v[0], v[1], v[2]), Vec3d(v[3], v[4], v[5])};
  if ((p.a - p.b).norm() == 0)
    throw InputError(std::string(option) + ": the blade's two ends coincide");
  return p;
}

std::string hex(std::uint64_t h) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, h);
  return buf;
}

// Loads and voxelizes the model of the options; `name` receives its name. Refuses first when
// the memory estimate of what `use` builds exceeds `maxMemory` bytes.
VoxelGrid buildGrid(const ModelOptions& mo, std::string& name, MemoryEstimateParams use,
                    std::size_t maxMemory) {
  const Model model = loadFromOptions(mo, maxMemory);
  name = model.name;
  const VoxelizeParams vp = voxelizeParams(mo, model);
  use.resolution = vp.resolution;
  use.maxVoxels = vp.maxVoxels;
  checkMemory(estimateModelMemory(model, use), maxMemory, "model " + name);
  LabelResampleReport report;
  VoxelGrid grid = voxelizeModel(model, vp, nullptr, &report);
  printModelWarnings(model, report);
  requireVoxels(grid, modelSubject(mo, model));
  return grid;
}

// What a single-frame cut holds: the prepared body and the fresh copy each run cuts.
MemoryEstimateParams cutBodies(bool baseline) {
  MemoryEstimateParams use;
  use.cutting = true;
  use.allActive = baseline;
  use.copies = 2;
  return use;
}

// Prepares (and deforms) a body for cutting, with or without the octree.
CutBody prepareBody(VoxelGrid grid, const ModelOptions& mo, bool octree,
                    const std::string& deform) {
  CutBodyParams bp;
  bp.useOctree = octree;
  bp.octree = octreeParams(mo, grid.materialNames());
  CutBody body = makeCutBody(std::move(grid), bp);
  applyDeformation(body.deformation, parseDeformation(deform));
  return body;
}

}  // namespace

void addCutCommand(CLI::App& app, CutOptions& opt, CLI::App*& cmd) {
  cmd = app.add_subcommand("cut",
                           "Single-frame cutting test (paper §4.1): the blade crosses the model in "
                           "one frame; prints the cut and the time of each collision step");
  addModelOptions(*cmd, opt.model, /*cutPlanes=*/false);
  cmd->add_flag("--no-octree", opt.noOctree, "Baseline: every link active, no voxel octree");
  cmd->add_option("--repeat", opt.repeat, "Runs on a fresh copy of the model; timings are medians")
      ->check(CLI::Range(1, 1000));
  cmd->add_option("--deform", opt.deform,
                  "Prescribed deformation before the cut: none, rigid, bend, twist");
  auto* blade =
      cmd->add_option("--blade", opt.blade,
                      "Blade start pose AX,AY,AZ,BX,BY,BZ (metres; default: spanning the "
                      "model's longest side, sweeping across its thinnest through the middle)");
  auto* to = cmd->add_option("--to", opt.to, "Blade end pose AX,AY,AZ,BX,BY,BZ (with --blade)");
  blade->needs(to);
  to->needs(blade);
  cmd->add_option("-o,--output", opt.output, "Write the cut surface (rest frame), .obj or .ply");
}

int runCut(const CutOptions& opt) {
  ThreadLimit limit(opt.model.threads);
  const std::size_t maxMemory = memoryLimit(opt.model.maxMemory);
  if (!opt.output.empty()) checkSurfacePath(opt.output);
  std::string name;
  const CutBody body =
      prepareBody(buildGrid(opt.model, name, cutBodies(opt.noOctree), maxMemory), opt.model,
                  !opt.noOctree, opt.deform);
  BladeMotion motion = defaultBladeMotion(body);
  if (!opt.blade.empty()) motion = {parsePose(opt.blade, "--blade"), parsePose(opt.to, "--to")};
  SingleFrameParams sp;
  sp.repeat = opt.repeat;
  const SingleFrameResult r = runSingleFrameCut(body, motion, sp);
  if (!opt.output.empty()) writeSurface(r.surface, opt.output);
  const CutStepResult& s = r.step;
  if (opt.model.json) {
    nlohmann::json j;
    j["model"] = name;
    j["octree"] = !opt.noOctree;
    j["threads"] = ThreadLimit::current();
    j["repeat"] = opt.repeat;
    j["deform"] = opt.deform;
    j["blade"] = {{"from",
                   {motion.from.a.x(), motion.from.a.y(), motion.from.a.z(), motion.from.b.x(),
                    motion.from.b.y(), motion.from.b.z()}},
                  {"to",
                   {motion.to.a.x(), motion.to.a.y(), motion.to.a.z(), motion.to.b.x(),
                    motion.to.b.y(), motion.to.b.z()}}};
    j["cut_links"] = s.cuts.size();
    j["cut_set_hash"] = hex(r.cutHash);
    j["pieces"] = r.pieces;
    j["surface_closed"] = r.topology.closed;
    j["surface_vertices"] = r.surface.positions.size();
    j["surface_triangles"] = r.surface.triangles.size();
    j["active_voxels_before"] = r.activeVoxelsBefore;
    j["active_voxels_after"] = r.activeVoxelsAfter;
    j["marked_elements"] = s.markedElements;
    j["tested_links"] = s.testedLinks + s.subdivision.testedLinks;
    j["subdivision"] = {{"rounds", s.subdivision.rounds},
                        {"affected_cubes", s.subdivision.affectedCubes},
                        {"boundary_cubes", s.subdivision.boundaryCubes},
                        {"tested_links", s.subdivision.testedLinks},
                        {"cut_links", s.subdivision.cutLinks},
                        {"faces_ms", s.subdivision.facesMs},
                        {"split_ms", s.subdivision.splitMs},
                        {"bookkeeping_ms", s.subdivision.bookkeepingMs}};
    j["timings_ms"] = {{"voxel_position_update", s.positionUpdateMs},
                       {"intersection_test", s.intersectionMs},
                       {"octree_subdivision", s.subdivisionMs},
                       {"total", s.totalMs()},
                       {"deferred_updates", s.deferredMs}};
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::printf("model               %s (%s, %s)\n", name.c_str(),
              opt.noOctree ? "baseline, no octree" : "voxel octree", opt.deform.c_str());
  std::printf("cut links           %zu (hash %s)\n", s.cuts.size(), hex(r.cutHash).c_str());
  std::printf("pieces              %d, surface %s\n", r.pieces,
              r.topology.closed ? "closed" : "NOT closed");
  std::printf("active voxels       %zu before, %zu after\n", r.activeVoxelsBefore,
              r.activeVoxelsAfter);
  std::printf("time (ms, median of %d, %d threads)\n", opt.repeat, ThreadLimit::current());
  std::printf("  voxel position update   %8.3f\n", s.positionUpdateMs);
  std::printf("  intersection test       %8.3f\n", s.intersectionMs);
  std::printf("  octree subdivision      %8.3f\n", s.subdivisionMs);
  std::printf("  total                   %8.3f\n", s.totalMs());
  std::printf("  (deferred updates       %8.3f)\n", s.deferredMs);
  return 0;
}

void addBenchCommand(CLI::App& app, BenchOptions& opt, CLI::App*& cmd) {
  auto* bench = app.add_subcommand("bench", "Benchmarks");
  bench->require_subcommand(1);
  cmd = bench->add_subcommand("single-frame",
                              "Paper Tables 3 and 4: single-frame cutting test per step, at each "
                              "thread count, with and without the octree measured in the same run");
  cmd->add_option("--models", opt.models, "Models to run (default: bunny liver starfish)");
  cmd->add_option("--threads", opt.threads, "Thread counts (default: 1 2 3)")
      ->check(CLI::Range(1, 1024));
  cmd->add_option("--repeat", opt.repeat,
                  "Runs per configuration; the median is reported (default 10)")
      ->check(CLI::Range(1, 1000));
  cmd->add_option("--csv", opt.csv, "CSV output file (default single-frame.csv)");
  cmd->add_option("--deform", opt.deform, "Prescribed deformation: none, rigid, bend, twist");
  addMaxMemoryOption(*cmd, opt.maxMemory);
  addComplexBenchCommand(*bench, opt.complex);
  addSoakBenchCommand(*bench, opt.soak);
}

int runBench(const BenchOptions& opt) {
  struct Row {
    std::string model;
    int threads;
    bool octree;
    SingleFrameResult r;
  };
  std::vector<Row> rows;
  const std::size_t maxMemory = memoryLimit(opt.maxMemory);
  checkOutputFile(opt.csv, "--csv");
  const bool terminal = isatty(STDERR_FILENO) != 0;  // a progress line only there
  for (const std::string& m : opt.models) {
    ModelOptions mo;
    mo.model = m;
    std::string name;
    // One voxelization serves both bodies.
    const VoxelGrid grid = buildGrid(mo, name, cutBodies(true), maxMemory);
    const CutBody withOctree = prepareBody(grid, mo, true, opt.deform);
    const CutBody baseline = prepareBody(grid, mo, false, opt.deform);
    const BladeMotion motion = defaultBladeMotion(withOctree);
    for (int t : opt.threads) {
      ThreadLimit limit(t);
      SingleFrameParams sp;
      sp.repeat = opt.repeat;
      sp.contour = false;
      if (terminal) std::fprintf(stderr, "\r%s, %d thread(s) ...\033[K", m.c_str(), t);
      // Baseline and octree runs alternate, so that both see the same spells of the machine.
      std::vector<SingleFrameResult> pair =
          runSingleFrameCuts({&baseline, &withOctree}, motion, sp);
      if (pair[0].cutHash != pair[1].cutHash)
        throw std::runtime_error("octree and baseline cut sets differ for " + m);
      rows.push_back({m, t, false, std::move(pair[0])});
      rows.push_back({m, t, true, std::move(pair[1])});
    }
  }
  if (terminal) std::fprintf(stderr, "\r\033[K");
  auto find = [&](const std::string& m, int t, bool o) -> const CutStepResult& {
    for (const Row& r : rows)
      if (r.model == m && r.threads == t && r.octree == o) return r.r.step;
    throw std::logic_error("missing row");
  };
  std::printf(
      "## Table 3: single-frame cutting test with the voxel octree, median ms (speed-up vs 1 "
      "thread)\n\n");
  std::printf("| model | step |");
  for (int t : opt.threads) std::printf(" %d T |", t);
  std::printf("\n|---|---|");
  for (std::size_t i = 0; i < opt.threads.size(); ++i) std::printf("---|");
  std::printf("\n");
  for (const std::string& m : opt.models) {
    const char* steps[] = {"voxel position update", "intersection test", "octree subdivision",
                           "collision total"};
    for (int k = 0; k < 4; ++k) {
      std::printf("| %s | %s |", m.c_str(), steps[k]);
      auto pick = [&](const CutStepResult& s) {
        return k == 0   ? s.positionUpdateMs
               : k == 1 ? s.intersectionMs
               : k == 2 ? s.subdivisionMs
                        : s.totalMs();
      };
      const double one = pick(find(m, opt.threads.front(), true));
      for (int t : opt.threads) {
        const double v = pick(find(m, t, true));
        std::printf(" %.3f (%.2fx) |", v, v > 0 ? one / v : 0.0);
      }
      std::printf("\n");
    }
  }
  std::printf(
      "\n## Table 4: without vs with the voxel octree, median ms (ratio = without / with)\n\n");
  std::printf(
      "| model | threads | position update | intersection test | collision total | cut links |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (const std::string& m : opt.models)
    for (int t : opt.threads) {
      const CutStepResult &b = find(m, t, false), &o = find(m, t, true);
      auto cell = [](double without, double with) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.3f → %.3f (%.2f)", without, with,
                      with > 0 ? without / with : 0.0);
        return std::string(buf);
      };
      std::printf("| %s | %d | %s | %s | %s | %zu |\n", m.c_str(), t,
                  cell(b.positionUpdateMs, o.positionUpdateMs).c_str(),
                  cell(b.intersectionMs, o.intersectionMs).c_str(),
                  cell(b.totalMs(), o.totalMs()).c_str(), o.cuts.size());
    }
  std::ofstream csv(opt.csv);
  if (!csv) throw InputError("cannot write '" + opt.csv + "'");
  csv << "model,threads,octree,repeat,voxel_position_update_ms,intersection_test_ms,octree_"
         "subdivision_ms,total_ms,"
         "deferred_ms,cut_links,tested_links,marked_elements,active_voxels\n";
  for (const Row& r : rows) {
    const CutStepResult& s = r.r.step;
    csv << r.model << ',' << r.threads << ',' << (r.octree ? 1 : 0) << ',' << opt.repeat << ','
        << s.positionUpdateMs << ',' << s.intersectionMs << ',' << s.subdivisionMs << ','
        << s.totalMs() << ',' << s.deferredMs << ',' << s.cuts.size() << ',' << s.testedLinks << ','
        << s.markedElements << ',' << r.r.activeVoxelsBefore << '\n';
  }
  csv.close();
  if (!csv) throw InputError("--csv: writing '" + opt.csv + "' failed (disk full?)");
  std::printf("\nwrote %s\n", opt.csv.c_str());
  return 0;
}

}  // namespace voxcut::app
