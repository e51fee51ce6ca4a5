// What a snapshot and a restore cost against a frame of the same world (docs/architecture.md,
// "Snapshots"; docs/performance.md, "Snapshots"): bunny-ear in the middle of its cut,
// liver-tumor in the middle of its cut, and the bunny-ear scene with the bunny at resolution 303
// before the blade arrives. Per world: the median of `--repeats` frames (each frame's
// FrameReport::totalMs); the first snapshot (World::snapshot, into fresh memory) and the median
// of later ones (each dropped before the next, so the world copies into memory it kept);
// restores (World::restore, each after a frame has moved the world on); their ratios to the
// frame; and the memory a snapshot holds (resident set growth over three held at once).
//
//   build/release/bench/bench_snapshot [--repeats R] [--threads T] [--quick]
//
// --quick leaves out the resolution-303 bunny (about 2 GiB and a minute to build).

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"

namespace voxcut {
namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// Resident set size of this process (bytes), from /proc/self/statm.
double residentBytes() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (f == nullptr) return 0.0;
  unsigned long size = 0, resident = 0;
  const int read = std::fscanf(f, "%lu %lu", &size, &resident);
  std::fclose(f);
  return read == 2 ? static_cast<double>(resident) * 4096.0 : 0.0;
}

struct Case {
  std::string name;
  std::string scene;
  int resolution = 0;  ///< 0: the scene's
  int warmFrames = 0;  ///< frames run before measuring
};

void measure(const Case& c, int repeats) {
  Scene scene = readScene(std::string(VOXCUT_SOURCE_DIR) + "/scenes/" + c.scene);
  if (c.resolution > 0) scene.bodies.at(0).resolution = c.resolution;
  Timer build;
  World w = World::fromScene(scene, voxelizeSceneBodies(scene));
  const double buildMs = build.ms();
  for (int f = 0; f < c.warmFrames; ++f) (void)w.step();
  std::vector<double> frame, snap, restore;
  for (int k = 0; k < repeats; ++k) frame.push_back(w.step().totalMs);
  // The first snapshot goes into fresh memory (its page faults); later ones, each dropped before
  // the next is taken, into memory the world kept.
  Timer first;
  WorldSnapshot s = w.snapshot();
  const double firstMs = first.ms();
  for (int k = 0; k < repeats; ++k) {
    s = WorldSnapshot{};
    Timer t;
    s = w.snapshot();
    snap.push_back(t.ms());
  }
  for (int k = 0; k < repeats; ++k) {
    (void)w.step();
    Timer t;
    w.restore(s);
    restore.push_back(t.ms());
  }
  // Memory: three more snapshots held at once, each in fresh memory (after one that may take
  // memory the world kept).
  std::vector<WorldSnapshot> held{w.snapshot()};
  const double before = residentBytes();
  for (int k = 0; k < 3; ++k) held.push_back(w.snapshot());
  const double perSnapshot = (residentBytes() - before) / 3.0;
  const double fm = median(frame), sm = median(snap), rm = median(restore);
  std::size_t nodes = 0;
  for (const BodyId b : w.bodies()) nodes += w.bodyInfo(b).nodes;
  std::printf("%-12s %7zu %8.0f %8.2f %9.1f %6.2f %8.2f %6.2f %8.2f %6.2f %8.1f\n",
              c.name.c_str(), nodes, buildMs, fm, firstMs, firstMs / fm, sm, sm / fm, rm, rm / fm,
              perSnapshot / (1 << 20));
  std::fflush(stdout);
}

int run(int argc, char** argv) {
  int repeats = 7;
  int threads = 2;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--repeats" && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--threads" && i + 1 < argc) {
      threads = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--quick") {
      quick = true;
    } else {
      std::fprintf(stderr, "usage: bench_snapshot [--repeats R] [--threads T] [--quick]\n");
      return 2;
    }
  }
  const ThreadLimit limit(threads);
  std::printf("snapshot and restore against a frame (medians of %d, %d threads)\n", repeats,
              threads);
  std::printf("%-12s %7s %8s %8s %9s %6s %8s %6s %8s %6s %8s\n", "world", "nodes", "build ms",
              "frame ms", "1st snap", "/frame", "snap ms", "/frame", "restore", "/frame",
              "MiB/snap");
  std::vector<Case> cases = {{"bunny-ear", "bunny-ear.json", 0, 150},
                             {"liver-tumor", "liver-tumor.json", 0, 60}};
  if (!quick) cases.push_back({"bunny-303", "bunny-ear.json", 303, 2});
  for (const Case& c : cases) measure(c, repeats);
  return 0;
}

}  // namespace
}  // namespace voxcut

int main(int argc, char** argv) {
  try {
    return voxcut::run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_snapshot: error: %s\n", e.what());
    return 2;
  }
}
