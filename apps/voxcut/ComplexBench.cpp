#include "ComplexBench.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <thread>

#include "Interrupt.h"
#include "ModelOptions.h"
#include "OutputFiles.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"

extern char** environ;

namespace voxcut::app {
namespace {

namespace fs = std::filesystem;

/// Frames of a moving blade in material less than this far apart (s) belong to one cutting
/// period.
constexpr double kCutGapSeconds = 0.1;
constexpr int kLevelThreads = 2;  // the thread count of the maximum-level runs
const std::vector<int> kThreadCounts{1, 2, 3};
const std::vector<int> kLevels{1, 2, 3, 4};
const char* const kDefaultScenes[] = {"scenes/complex-bunny.json", "scenes/complex-liver.json",
                                      "scenes/complex-starfish.json"};
const char* const kPlotScript = "scripts/plot_complex.py";

/// A file of the repository: `relative` to the current folder when it is there (the README's
/// commands run from the repository root), else to the source tree this binary was built from.
std::string repositoryFile(const std::string& relative) {
  std::error_code ec;
  if (fs::exists(relative, ec)) return relative;
#ifdef VOXCUT_SOURCE_DIR
  const fs::path built = fs::path(VOXCUT_SOURCE_DIR) / relative;
  if (fs::exists(built, ec)) return built.string();
#endif
  return relative;
}

// ---- runs ----------------------------------------------------------------------------------

/// One configuration of a scene's world.
struct RunConfig {
  std::string name;  ///< file stem: octree-t2, baseline-t1, octree-t2-L1 ...
  int threads = 1;
  bool octree = true;
  int levelOverride = -1;  ///< every material's max_internal_level; -1: the scene's own
};

/// What one run did: its frames and its cut set.
struct RunRecord {
  RunConfig config;
  int level = -1;  ///< the max_internal_level all materials have in the run; -1: they differ
  std::vector<FrameReport> frames;
  std::uint64_t hash = 0;
};

/// A scene as read, and the frames it runs for.
struct LoadedScene {
  std::string path, name;
  Scene scene;
  int frames = 0;
};

/// The scene with every material of every body at max_internal_level `level` (-1: as it is).
Scene withLevel(const Scene& scene, const std::vector<VoxelGrid>& grids, int level) {
  if (level < 0) return scene;
  Scene s = scene;
  for (std::size_t b = 0; b < s.bodies.size(); ++b) {
    std::vector<SceneMaterial> materials;
    for (const std::string& name : grids[b].materialNames()) {
      SceneMaterial m = sceneMaterial(s.bodies[b], name);
      m.maxInternalLevel = level;
      materials.push_back(m);
    }
    s.bodies[b].materials = std::move(materials);
  }
  return s;
}

/// The max_internal_level shared by every material of the scene's bodies, or -1.
int uniformLevel(const Scene& scene, const std::vector<VoxelGrid>& grids) {
  int level = -2;
  for (std::size_t b = 0; b < scene.bodies.size(); ++b)
    for (const std::string& name : grids[b].materialNames()) {
      const int l = sceneMaterial(scene.bodies[b], name).maxInternalLevel;
      if (level == -2) level = l;
      if (l != level) return -1;
    }
  return level < 0 ? -1 : level;
}

std::string threadName(int threads) {
  return "t" + std::to_string(threads);
}

/// The runs of a scene whose own level is `sceneLevel`, in groups that share a thread count:
/// each group's worlds step in turn, frame by frame, so that the octree and the baseline see
/// the same spells of a noisy machine. A level run equal to the scene's octree run is not
/// repeated.
std::vector<std::vector<RunConfig>> runGroups(int sceneLevel) {
  std::vector<std::vector<RunConfig>> groups;
  for (int t : kThreadCounts) {
    std::vector<RunConfig> g{{"octree-" + threadName(t), t, true, -1},
                             {"baseline-" + threadName(t), t, false, -1}};
    if (t == kLevelThreads)
      for (int l : kLevels)
        if (l != sceneLevel)
          g.push_back({"octree-" + threadName(t) + "-L" + std::to_string(l), t, true, l});
    groups.push_back(std::move(g));
  }
  return groups;
}

/// Progress of the runs on stderr, on a terminal only.
class ProgressLine {
 public:
  ProgressLine() : terminal_(isatty(STDERR_FILENO) != 0) {}
  void show(const std::string& what, int frame, int frames) const {
    if (!terminal_) return;
    std::fprintf(stderr, "\r%s: frame %d/%d\033[K", what.c_str(), frame, frames);
    std::fflush(stderr);
  }
  void clear() const {
    if (terminal_) std::fprintf(stderr, "\r\033[K");
  }

 private:
  bool terminal_;
};

/// Runs one group of configurations in turn, frame by frame, the order rotating every frame.
std::vector<RunRecord> runGroup(const LoadedScene& ls, const std::vector<VoxelGrid>& grids,
                                const std::vector<RunConfig>& group, const std::string& label,
                                const ProgressLine& progress) {
  const ThreadLimit limit(group.front().threads);
  std::vector<World> worlds;
  std::vector<RunRecord> records;
  for (const RunConfig& c : group) {
    WorldSettings ws;
    ws.useOctree = c.octree;
    const Scene s = withLevel(ls.scene, grids, c.levelOverride);
    worlds.push_back(World::fromScene(s, std::vector<VoxelGrid>(grids), ws));
    records.push_back({c, uniformLevel(s, grids), {}, 0});
    records.back().frames.reserve(static_cast<std::size_t>(ls.frames));
  }
  const std::size_t n = worlds.size();
  for (int f = 0; f < ls.frames; ++f) {
    if (interruptRequested()) throw Interrupted();
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = (static_cast<std::size_t>(f) + k) % n;
      records[i].frames.push_back(worlds[i].step());
    }
    progress.show(label, f + 1, ls.frames);
  }
  for (std::size_t i = 0; i < n; ++i) records[i].hash = worlds[i].cutSetHash();
  return records;
}

// ---- periods -------------------------------------------------------------------------------

/// Where a frame lies: before the first cutting period, between two, in one, after the last.
enum class Phase { Start, Between, Cutting, End };

struct Periods {
  std::vector<Phase> phase;                ///< per frame
  std::vector<std::pair<int, int>> spans;  ///< cutting periods, first and last frame
  [[nodiscard]] int count(Phase p) const {
    return static_cast<int>(std::count(phase.begin(), phase.end(), p));
  }
};

/// Whether the blade moved through material in the frame of an octree run: it cut links, or
/// the octree's deferred updates ran, which they do after cuts and when the blade's edge or
/// tips moved inside the material (cubes the sweep's boundary reaches into are split; a blade
/// drawn back along its own cut cuts nothing new but still works through the material).
bool bladeInMaterial(const FrameReport& r) {
  static const std::size_t deferred = static_cast<std::size_t>(
      std::find(frameStageNames().begin(), frameStageNames().end(), "deferred_updates") -
      frameStageNames().begin());
  return r.cutLinks > 0 || (deferred < r.stageMs.size() && r.stageMs[deferred] > 0.0);
}

/// The cutting periods of an octree run: frames in which the blade moved through material,
/// joined where they are less than kCutGapSeconds apart (the frames between count too).
Periods cuttingPeriods(const RunRecord& run, double timeStep) {
  const int frames = static_cast<int>(run.frames.size());
  const int gap = std::max(1, static_cast<int>(kCutGapSeconds / timeStep + 0.5));
  Periods p;
  for (int f = 0; f < frames; ++f) {
    if (!bladeInMaterial(run.frames[f])) continue;
    if (!p.spans.empty() && f - p.spans.back().second <= gap)
      p.spans.back().second = f;
    else
      p.spans.emplace_back(f, f);
  }
  p.phase.assign(frames, Phase::Start);
  for (std::size_t s = 0; s < p.spans.size(); ++s) {
    const auto [first, last] = p.spans[s];
    for (int f = first; f <= last; ++f) p.phase[f] = Phase::Cutting;
    const int next = s + 1 < p.spans.size() ? p.spans[s + 1].first : frames;
    for (int f = last + 1; f < next; ++f)
      p.phase[f] = s + 1 < p.spans.size() ? Phase::Between : Phase::End;
  }
  return p;
}

/// Mean of `value(frame)` over the frames in `phases` (NaN when there are none).
template <class Value>
double phaseMean(const RunRecord& run, const Periods& p, const std::vector<Phase>& phases,
                 Value&& value) {
  double sum = 0.0;
  int n = 0;
  for (std::size_t f = 0; f < run.frames.size(); ++f)
    if (std::find(phases.begin(), phases.end(), p.phase[f]) != phases.end()) {
      sum += value(run.frames[f]);
      ++n;
    }
  return n > 0 ? sum / n : std::nan("");
}

double fps(const FrameReport& r) {
  return r.totalMs > 0 ? 1000.0 / r.totalMs : 0.0;
}

double frameMs(const FrameReport& r) {
  return r.totalMs;
}

const std::vector<Phase> kAllPhases{Phase::Start, Phase::Between, Phase::Cutting, Phase::End};

/// Frames per second over the frames in `phases`: their count over their wall-clock time (not
/// the mean of each frame's FPS, which a few fast frames would inflate).
double periodFps(const RunRecord& run, const Periods& p, const std::vector<Phase>& phases) {
  return 1000.0 / phaseMean(run, p, phases, frameMs);
}

double toolForce(const FrameReport& r) {
  double f = 0.0;
  for (const ToolReaction& t : r.toolReactions) f = std::max(f, t.force.norm());
  return f;
}

// ---- outputs -------------------------------------------------------------------------------

std::string hex(std::uint64_t h) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, h);
  return buf;
}

std::string csvHeader() {
  std::string h = "frame,time_s,frame_ms,fps";
  for (const std::string& s : frameStageNames()) h += "," + s + "_ms";
  return h + ",cut_links,cutting,contacts,tool_force_N,solver_iterations";
}

void writeRunCsv(const RunRecord& run, const Periods& p, const std::string& path) {
  PendingFile csv(path, "--out");
  csv.writeLine(csvHeader());
  for (std::size_t f = 0; f < run.frames.size(); ++f) {
    const FrameReport& r = run.frames[f];
    std::ostringstream row;
    row << r.frame << ',' << r.time << ',' << r.totalMs << ',' << fps(r);
    for (double ms : r.stageMs) row << ',' << ms;
    row << ',' << r.cutLinks << ',' << (p.phase[f] == Phase::Cutting ? 1 : 0) << ',' << r.contacts
        << ',' << toolForce(r) << ',' << r.solverIterations;
    csv.writeLine(row.str());
  }
  csv.commit();
}

/// A number for the tables, "-" for NaN (a period with no frames).
std::string cell(double v, const char* format = "%.2f") {
  if (std::isnan(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

const RunRecord& findRun(const std::vector<RunRecord>& runs, const std::string& name) {
  for (const RunRecord& r : runs)
    if (r.config.name == name) return r;
  throw std::logic_error("no run " + name);
}

/// Octree / baseline FPS ratios of a scene at one thread count, per kind of period.
struct Ratios {
  double start = NAN, end = NAN, nonCutting = NAN, cutting = NAN;
};

Ratios fpsRatios(const RunRecord& octree, const RunRecord& baseline, const Periods& p) {
  auto ratio = [&](const std::vector<Phase>& phases) {
    return periodFps(octree, p, phases) / periodFps(baseline, p, phases);
  };
  return {ratio({Phase::Start}), ratio({Phase::End}),
          ratio({Phase::Start, Phase::Between, Phase::End}), ratio({Phase::Cutting})};
}

void printSceneSummary(const LoadedScene& ls, const std::vector<RunRecord>& runs,
                       const Periods& p) {
  const double dt = ls.scene.timeStep;
  std::printf("## %s (%s): %d frames of %.4g s\n\n", ls.name.c_str(), ls.path.c_str(), ls.frames,
              dt);
  std::printf("cutting periods (the blade moves through material):");
  for (const auto& [first, last] : p.spans)
    std::printf(" %.3f-%.3f s", first * dt, (last + 1) * dt);
  if (p.spans.empty()) std::printf(" none");
  std::printf(
      "; frames: %d before the first cut (start), %d between cuts, %d cutting, %d after "
      "the last cut (end)\n\n",
      p.count(Phase::Start), p.count(Phase::Between), p.count(Phase::Cutting), p.count(Phase::End));
  std::printf("| run | threads | max level | mean FPS | cut links | cut_set_hash |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (const RunRecord& r : runs) {
    std::size_t cuts = 0;
    for (const FrameReport& f : r.frames) cuts += f.cutLinks;
    std::printf("| %s | %d | %s | %.1f | %zu | %s |\n", r.config.name.c_str(), r.config.threads,
                !r.config.octree ? "-"
                : r.level < 0    ? "mixed"
                                 : std::to_string(r.level).c_str(),
                periodFps(r, p, kAllPhases), cuts, hex(r.hash).c_str());
  }
  std::printf(
      "\noctree / baseline FPS (frames over their wall-clock time) in each kind of period:\n\n");
  std::printf("| threads | non-cutting, start | non-cutting, end | non-cutting, all | cutting |\n");
  std::printf("|---|---|---|---|---|\n");
  for (int t : kThreadCounts) {
    const Ratios q = fpsRatios(findRun(runs, "octree-" + threadName(t)),
                               findRun(runs, "baseline-" + threadName(t)), p);
    std::printf("| %d | %s | %s | %s | %s |\n", t, cell(q.start).c_str(), cell(q.end).c_str(),
                cell(q.nonCutting).c_str(), cell(q.cutting).c_str());
  }
  const RunRecord& baseline = findRun(runs, "baseline-" + threadName(kLevelThreads));
  std::printf("\nmaximum internal level, %d threads: FPS over the baseline's:\n\n", kLevelThreads);
  std::printf(
      "| max level | non-cutting, start | non-cutting, end | cutting |\n|---|---|---|---|\n");
  for (int l : kLevels)
    for (const RunRecord& r : runs)
      if (r.config.octree && r.config.threads == kLevelThreads && r.level == l) {
        const Ratios q = fpsRatios(r, baseline, p);
        std::printf("| %d | %s | %s | %s |\n", l, cell(q.start).c_str(), cell(q.end).c_str(),
                    cell(q.cutting).c_str());
      }
  const RunRecord& octree = findRun(runs, "octree-" + threadName(kLevelThreads));
  std::printf("\nmean ms per stage, %d threads, octree / baseline:\n\n", kLevelThreads);
  std::printf("| stage | non-cutting, start | non-cutting, end | cutting |\n|---|---|---|---|\n");
  const std::vector<std::string>& stages = frameStageNames();
  const std::vector<std::vector<Phase>> kinds{{Phase::Start}, {Phase::End}, {Phase::Cutting}};
  for (std::size_t s = 0; s <= stages.size(); ++s) {
    auto value = [s, &stages](const FrameReport& r) {
      return s < stages.size() ? r.stageMs[s] : r.totalMs;
    };
    std::printf("| %s |", s < stages.size() ? stages[s].c_str() : "**frame**");
    for (const auto& kind : kinds)
      std::printf(" %s / %s |", cell(phaseMean(octree, p, kind, value), "%.3f").c_str(),
                  cell(phaseMean(baseline, p, kind, value), "%.3f").c_str());
    std::printf("\n");
  }
  std::printf("\n");
}

// ---- plots ---------------------------------------------------------------------------------

/// Runs `args` (args[0] looked up on PATH) and returns its exit status, or -1 when it could
/// not be started. With `quiet`, its output goes to /dev/null.
int runProgram(const std::vector<std::string>& args, bool quiet) {
  std::vector<std::string> store(args);
  std::vector<char*> argv;
  for (std::string& a : store) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (quiet) {
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  }
  std::fflush(stdout);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return -1;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/// A Python 3 that imports matplotlib: python3 on PATH, else Debian's /usr/bin/python3 (where
/// python3-matplotlib installs it, when PATH leads to another Python first). Empty when none.
std::string findPlotPython() {
  for (const char* python : {"python3", "/usr/bin/python3"})
    if (runProgram({python, "-c", "import matplotlib"}, true) == 0) return python;
  return {};
}

/// Draws the figures; returns the exit status part of the command (0 when fine or skipped).
int plot(const ComplexBenchOptions& opt) {
  const std::string python = findPlotPython();
  if (python.empty()) {
    std::fprintf(stderr,
                 "voxcut: %s: no python3 with matplotlib found, figures not drawn (install it: "
                 "sudo apt-get install python3-matplotlib; the CSVs are in %s)\n",
                 opt.plot ? "error" : "note", opt.out.c_str());
    return opt.plot ? 2 : 0;
  }
  const std::string script = repositoryFile(kPlotScript);
  const int status = runProgram({python, script, opt.out}, false);
  if (status != 0) {
    std::fprintf(stderr, "voxcut: error: %s %s %s failed (status %d)\n", python.c_str(),
                 script.c_str(), opt.out.c_str(), status);
    return 2;
  }
  return 0;
}

}  // namespace

void addComplexBenchCommand(CLI::App& bench, ComplexBenchOptions& opt) {
  CLI::App* cmd = bench.add_subcommand(
      "complex",
      "Paper figures 6-8: recorded poking and cutting scenes run with the octree at 1, 2 and 3 "
      "threads, at maximum internal levels 1-4, and without it; CSVs, summary, figures");
  cmd->add_option("--scenes", opt.scenes,
                  "Scene files (default: scenes/complex-bunny.json complex-liver.json "
                  "complex-starfish.json)");
  cmd->add_option("--out", opt.out, "Output folder (default out/complex; created when missing)");
  cmd->add_option("--frames", opt.frames, "At most this many frames per scene (default: all)")
      ->check(CLI::Range(1, 10000000));
  auto* noPlot = cmd->add_flag("--no-plot", opt.noPlot, "Write the CSVs and summary only");
  cmd->add_flag("--plot", opt.plot, "Fail when the figures cannot be drawn (no matplotlib)")
      ->excludes(noPlot);
  cmd->callback([&opt] { opt.selected = true; });
}

int runComplexBench(const ComplexBenchOptions& opt) {
  checkOutputFolder(opt.out, "--out");
  const InterruptGuard interruptGuard;
  std::vector<LoadedScene> scenes;
  std::vector<std::string> paths(opt.scenes);
  if (paths.empty())
    for (const char* s : kDefaultScenes) paths.push_back(repositoryFile(s));
  // Every scene is read (and so checked) before the first run starts.
  for (const std::string& path : paths) {
    LoadedScene ls{path, fs::path(path).stem().string(), readScene(path), 0};
    for (const LoadedScene& other : scenes)
      if (other.name == ls.name)
        throw InputError("--scenes: two scenes are named '" + ls.name + "' (" + other.path + ", " +
                         path + "); their outputs would collide");
    ls.frames = ls.scene.frames.value_or(100);
    if (opt.frames > 0) ls.frames = std::min(ls.frames, opt.frames);
    scenes.push_back(std::move(ls));
  }
  std::error_code ec;
  fs::create_directories(opt.out, ec);
  if (ec) throw InputError("--out: cannot create folder '" + opt.out + "': " + ec.message());
  PendingFile index((fs::path(opt.out) / "runs.csv").string(), "--out");
  index.writeLine(
      "scene,run,csv,threads,octree,max_internal_level,frames,time_step,cut_links,cut_set_hash,"
      "mean_fps");
  const ProgressLine progress;
  std::printf("# Complex scenario (paper §4.2): octree / baseline\n\n");
  std::printf(
      "%u hardware threads; the worlds of one thread count step in turn, frame by frame\n\n",
      std::thread::hardware_concurrency());
  std::vector<std::pair<std::string, Ratios>> overview;
  std::vector<std::string> mismatches;
  for (const LoadedScene& ls : scenes) {
    SceneBodiesParams bp;
    bp.useOctree = false;  // the baseline keeps more per voxel
    bp.maxMemory = memoryLimit("");
    bp.progress = terminalProgress();
    const std::vector<VoxelGrid> grids = voxelizeSceneBodies(ls.scene, bp);
    std::vector<RunRecord> runs;
    const std::vector<std::vector<RunConfig>> groups = runGroups(uniformLevel(ls.scene, grids));
    for (std::size_t g = 0; g < groups.size(); ++g) {
      // e.g. "complex-bunny 2/3, 2 threads: octree baseline L1 L2 L3"
      std::string label = ls.name + " " + std::to_string(g + 1) + "/" +
                          std::to_string(groups.size()) + ", " +
                          std::to_string(groups[g].front().threads) +
                          (groups[g].front().threads == 1 ? " thread:" : " threads:");
      for (const RunConfig& c : groups[g])
        label += c.levelOverride >= 0 ? " L" + std::to_string(c.levelOverride)
                 : c.octree           ? " octree"
                                      : " baseline";
      for (RunRecord& r : runGroup(ls, grids, groups[g], label, progress))
        runs.push_back(std::move(r));
    }
    progress.clear();
    // The cuts must not depend on the thread count, the octree or its levels, frame by frame.
    for (const RunRecord& r : runs) {
      bool same = r.hash == runs.front().hash;
      for (std::size_t f = 0; same && f < r.frames.size(); ++f)
        same = r.frames[f].cutLinks == runs.front().frames[f].cutLinks;
      if (!same)
        mismatches.push_back(ls.name + ": " + r.config.name + " cuts " + hex(r.hash) + ", " +
                             runs.front().config.name + " " + hex(runs.front().hash));
    }
    // Every octree run of the scene's levels moves the blade through the same material.
    const Periods p =
        cuttingPeriods(findRun(runs, "octree-" + threadName(kLevelThreads)), ls.scene.timeStep);
    const fs::path folder = fs::path(opt.out) / ls.name;
    fs::create_directories(folder, ec);
    if (ec)
      throw InputError("--out: cannot create folder '" + folder.string() + "': " + ec.message());
    for (const RunRecord& r : runs) {
      const std::string csv = (folder / (r.config.name + ".csv")).string();
      writeRunCsv(r, p, csv);
      std::size_t cuts = 0;
      for (const FrameReport& f : r.frames) cuts += f.cutLinks;
      std::ostringstream row;
      row << ls.name << ',' << r.config.name << ',' << ls.name << '/' << r.config.name << ".csv,"
          << r.config.threads << ',' << (r.config.octree ? 1 : 0) << ','
          << (r.config.octree ? r.level : -1) << ',' << r.frames.size() << ',' << ls.scene.timeStep
          << ',' << cuts << ',' << hex(r.hash) << ',' << periodFps(r, p, kAllPhases);
      index.writeLine(row.str());
    }
    printSceneSummary(ls, runs, p);
    overview.emplace_back(ls.name,
                          fpsRatios(findRun(runs, "octree-" + threadName(kLevelThreads)),
                                    findRun(runs, "baseline-" + threadName(kLevelThreads)), p));
    std::fflush(stdout);
  }
  index.commit();
  std::printf(
      "## Octree / baseline FPS, %d threads (the paper, 3 threads: bunny 1.43 at the "
      "start, 1.17 at the end; liver 1.24, 1.29; starfish 1.15, 1.07; about 1 when "
      "cutting)\n\n",
      kLevelThreads);
  std::printf("| scene | non-cutting, start | non-cutting, end | cutting |\n|---|---|---|---|\n");
  for (const auto& [name, q] : overview)
    std::printf("| %s | %s | %s | %s |\n", name.c_str(), cell(q.start).c_str(), cell(q.end).c_str(),
                cell(q.cutting).c_str());
  std::printf("\nCSVs in %s\n", opt.out.c_str());
  if (!mismatches.empty()) {
    for (const std::string& m : mismatches)
      std::fprintf(stderr, "voxcut: error: the runs cut different links: %s\n", m.c_str());
    return 2;
  }
  if (opt.noPlot) return 0;
  return plot(opt);
}

}  // namespace voxcut::app
