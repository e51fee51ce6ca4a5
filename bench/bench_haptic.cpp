// The haptic call beside running frames (docs/algorithms.md, "Forces at haptic rate"): a
// device thread calls World::hapticForce at 1 kHz while the simulation thread runs the
// bunny-poke scene's frames at 250 Hz of wall-clock time, each frame moving the probe to where
// the device is. The device follows the scene's probe keys, over and over. Prints the call's
// median and 99.9th percentile time, and how much the force jumps between consecutive calls,
// beside what a loop that held each frame's force would feel.
//
//   build/release/bench/bench_haptic [SCENE] [--seconds S] [--dump FILE.csv]
//
// --dump writes every call's and every frame's force with its wall-clock time.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "voxcut/core/Error.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"

namespace voxcut {
namespace {

using Clock = std::chrono::steady_clock;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(k, v.size() - 1)];
}

/// Relative jumps |F_k - F_{k-1}| / |F_{k-1}| between consecutive samples that both push,
/// leaving out the samples within `settle` after a contact begins (the first contact).
std::vector<double> jumps(const std::vector<Vec3d>& force, std::size_t settle) {
  std::vector<double> out;
  std::size_t since = 0;  // samples since the contact began
  for (std::size_t k = 1; k < force.size(); ++k) {
    const bool push = force[k] != Vec3d::Zero(), pushed = force[k - 1] != Vec3d::Zero();
    since = push && pushed ? since + 1 : 0;
    if (push && pushed && since > settle)
      out.push_back((force[k] - force[k - 1]).norm() / force[k - 1].norm());
  }
  return out;
}

void report(const char* what, const std::vector<double>& j) {
  const double over =
      static_cast<double>(std::count_if(j.begin(), j.end(), [](double x) { return x > 0.1; }));
  std::printf("%-34s median %.4f, p99 %.4f, max %.4f, above 10%%: %.0f of %zu\n", what,
              percentile(j, 0.5), percentile(j, 0.99), j.empty() ? 0.0 : percentile(j, 1.0), over,
              j.size());
}

/// Where the jumps above 10 % of the force happen: the force then, as a fraction of the peak;
/// and the largest jump relative to the peak.
void whereJumps(const char* what, const std::vector<Vec3d>& force, double peak) {
  std::size_t above = 0, small = 0;
  double largest = 0.0;
  for (std::size_t k = 1; k < force.size(); ++k) {
    const double before = force[k - 1].norm(), jump = (force[k] - force[k - 1]).norm();
    largest = std::max(largest, jump / peak);
    if (before > 0.0 && force[k] != Vec3d::Zero() && jump > 0.1 * before) {
      ++above;
      if (before < 0.1 * peak) ++small;
    }
  }
  std::printf(
      "%-34s %zu jumps above 10%% (contact onsets included), %zu of them where the "
      "force is below 10%% of its peak; largest jump %.4f of the peak\n",
      what, above, small, largest);
}

int run(const std::string& scenePath, double seconds, const std::string& dump) {
  const Scene scene = readScene(scenePath);
  std::size_t probe = scene.tools.size();
  for (std::size_t t = 0; t < scene.tools.size(); ++t)
    if (scene.tools[t].kind == ToolKind::Probe) probe = t;
  if (probe == scene.tools.size()) throw InputError(scenePath + ": the scene has no probe");
  const std::vector<ToolKey>& path = scene.tools[probe].keys;
  const double period = path.back().t + 0.2;  // a pause after each stroke
  auto device = [&](double t) { return bladePoseAt(path, std::fmod(t, period)); };
  World world = World::fromScene(scene, voxelizeSceneBodies(scene));
  const ToolId probeId = world.tools()[probe];  // the world's tools are the scene's, in order
  const double dt = scene.timeStep;

  std::atomic<bool> done{false};
  const Clock::time_point start = Clock::now();
  auto wall = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  std::vector<double> callMs;
  std::vector<Vec3d> hapticForces;
  std::vector<double> callTimes;
  std::thread haptic([&] {
    for (int k = 0; !done.load(); ++k) {
      std::this_thread::sleep_until(start + std::chrono::microseconds(1000 * k));
      const BladePose pose = device(wall());
      const Clock::time_point t0 = Clock::now();
      const ToolReaction r = world.hapticForce(probeId, pose).reaction;
      callMs.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      hapticForces.push_back(r.force);
      callTimes.push_back(wall());
    }
  });
  std::vector<Vec3d> frameForces;
  std::vector<double> frameMs, frameTimes;
  int late = 0;
  for (int f = 0; f * dt < seconds; ++f) {
    // Frame f ends at wall time (f + 1) dt: it starts when its start time has come.
    const Clock::time_point due =
        start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(f * dt));
    if (Clock::now() > due + std::chrono::duration<double>(dt)) ++late;
    std::this_thread::sleep_until(due);
    world.setToolPose(probeId, device((f + 1) * dt));
    const FrameReport r = world.step();
    frameMs.push_back(r.totalMs);
    frameForces.push_back(world.toolReaction(probeId).force);
    frameTimes.push_back(wall());
  }
  done = true;
  haptic.join();

  std::printf(
      "scene %s, %.1f s: %zu frames at %.0f Hz (frame mean %.2f ms, p95 %.2f ms, %d "
      "started late), %zu haptic calls at 1 kHz\n",
      scenePath.c_str(), seconds, frameMs.size(), 1.0 / dt,
      frameMs.empty() ? 0.0 : percentile(frameMs, 0.5), percentile(frameMs, 0.95), late,
      callMs.size());
  std::printf("haptic call (ms)                   median %.5f, p99.9 %.5f, max %.5f\n",
              percentile(callMs, 0.5), percentile(callMs, 0.999), percentile(callMs, 1.0));
  double peak = 0.0;
  for (const Vec3d& f : hapticForces) peak = std::max(peak, f.norm());
  std::printf("haptic force peak %.3f N\n", peak);
  // The first contact: the calls of the two frames a contact needs before the model has a
  // slope (8 calls at 1 kHz beside 250 Hz frames), and the first frame's change when held.
  const auto perFrame = static_cast<std::size_t>(std::lround(dt * 1000.0));
  report("force jump, haptic model", jumps(hapticForces, 2 * perFrame));
  report("force jump, frame force held", jumps(frameForces, 2));
  whereJumps("haptic model:", hapticForces, peak);
  whereJumps("frame force held:", frameForces, peak);
  // Of the calls' jumps above 10 %, those where the frames themselves change faster than 10 %
  // of the force per millisecond (the tissue's own response, as fast unloading): a loop that
  // followed the frames exactly would jump as much.
  {
    std::size_t above = 0, physical = 0;
    std::size_t f = 0;
    for (std::size_t k = 1; k < hapticForces.size(); ++k) {
      const double before = hapticForces[k - 1].norm();
      if (!(before > 0.0) || hapticForces[k] == Vec3d::Zero() ||
          !((hapticForces[k] - hapticForces[k - 1]).norm() > 0.1 * before))
        continue;
      ++above;
      while (f + 1 < frameTimes.size() && frameTimes[f + 1] < callTimes[k]) ++f;
      if (f + 1 >= frameTimes.size() || f == 0) continue;
      const double rate = (frameForces[f + 1] - frameForces[f - 1]).norm() /
                          (1000.0 * (frameTimes[f + 1] - frameTimes[f - 1]));  // N per ms
      if (rate > 0.1 * before) ++physical;
    }
    std::printf(
        "%-34s %zu of the %zu jumps above 10%% are where the frames' force changes by "
        "more than 10%% of itself per ms\n",
        "haptic model:", physical, above);
  }
  if (!dump.empty()) {
    // One row per haptic call and per frame end: wall time (s), which, force (N).
    std::FILE* out = std::fopen(dump.c_str(), "w");
    if (out == nullptr) throw InputError(dump + ": cannot write");
    std::fprintf(out, "t,source,fx,fy,fz\n");
    for (std::size_t k = 0; k < hapticForces.size(); ++k)
      std::fprintf(out, "%.6f,call,%.6g,%.6g,%.6g\n", callTimes[k], hapticForces[k].x(),
                   hapticForces[k].y(), hapticForces[k].z());
    for (std::size_t k = 0; k < frameForces.size(); ++k)
      std::fprintf(out, "%.6f,frame,%.6g,%.6g,%.6g\n", frameTimes[k], frameForces[k].x(),
                   frameForces[k].y(), frameForces[k].z());
    std::fclose(out);
  }
  return 0;
}

}  // namespace
}  // namespace voxcut

int main(int argc, char** argv) {
  std::string scene = std::string(VOXCUT_SOURCE_DIR) + "/scenes/bunny-poke.json";
  double seconds = 6.0;
  std::string dump;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--seconds") == 0 && i + 1 < argc)
      seconds = std::atof(argv[++i]);
    else if (std::strcmp(argv[i], "--dump") == 0 && i + 1 < argc)
      dump = argv[++i];
    else
      scene = argv[i];
  }
  try {
    return voxcut::run(scene, seconds, dump);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_haptic: error: %s\n", e.what());
    return 1;
  }
}
