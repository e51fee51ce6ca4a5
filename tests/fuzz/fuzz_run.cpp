/// @file fuzz_run.cpp
/// libFuzzer harness of one `voxcut run` on a fuzzed scene: the input is a scene file's text,
/// parsed with parseScene, made tiny, then driven as `voxcut run` drives it (apps/voxcut/
/// RunCommand.cpp): its bodies voxelized, a World built and stepped, the pieces, the
/// largest displacement and the deformed surfaces queried. Everything runs on one thread.
///
/// Made tiny: at most kMaxBodies bodies (more: the input is skipped), resolution at most
/// kMaxResolution (missing: kMaxResolution), at most kMaxFrames frames, at most
/// kMaxIterations solver iterations. The built-in models (bunny, starfish, liver) become boxes
/// of their size, the liver's material "liver" the box's "default"; the box and sphere
/// primitives stay. A mesh-file model becomes the tetrahedron written at start-up into the
/// folder that relative paths resolve against ("tet.obj" names it), so that no file outside
/// the harness is read.
///
/// InputError is the expected answer to bad input; any other exception, a crash, a sanitizer
/// report, a leak or a timeout is a finding.

#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "JsonMutator.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"

// libFuzzer's built-in mutator, for the custom one below.
extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t maxSize);

namespace {

constexpr std::size_t kMaxBodies = 2;
constexpr int kMaxResolution = 10;
constexpr int kMaxFrames = 3;
constexpr int kMaxIterations = 200;

// The folder relative mesh paths resolve against, holding tet.obj; removed at exit.
std::filesystem::path& meshDir() {
  static std::filesystem::path dir;
  return dir;
}

void removeMeshDir() {
  std::error_code ec;
  std::filesystem::remove_all(meshDir(), ec);
}

// Replaces the liver (two materials, 25k triangles to generate and voxelize) by a box of its
// size; the scene's "liver" material becomes the box's "default", "tumor" is dropped.
void useLiverBox(voxcut::SceneBody& body) {
  body.model = "box:0.2,0.124,0.176";
  std::vector<voxcut::SceneMaterial> kept;
  for (voxcut::SceneMaterial& m : body.materials) {
    if (m.name == "tumor") continue;
    if (m.name == "liver") m.name = "default";
    kept.push_back(std::move(m));
  }
  body.materials = std::move(kept);
}

// Rewrites `scene` in place into a tiny run; false when it cannot be made tiny.
bool makeTiny(voxcut::Scene& scene) {
  if (scene.bodies.size() > kMaxBodies) return false;
  const std::string tet = (meshDir() / "tet.obj").string();
  for (voxcut::SceneBody& body : scene.bodies) {
    if (body.model == "bunny")
      body.model = "box:0.158,0.154,0.123";
    else if (body.model == "starfish")
      body.model = "box:0.2,0.184,0.033";
    else if (body.model == "liver")
      useLiverBox(body);
    else if (!voxcut::isBuiltinModelSpec(body.model))
      body.model = tet;
    body.resolution = std::min(body.resolution.value_or(kMaxResolution), kMaxResolution);
  }
  scene.frames = std::min(scene.frames.value_or(kMaxFrames), kMaxFrames);
  scene.solver.maxIterations = std::min(scene.solver.maxIterations, kMaxIterations);
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // One thread: the run must not depend on the thread count, and the fuzzer runs faster
  // without a scheduler to wake.
  static voxcut::ThreadLimit oneThread(1);
  std::string pattern =
      (std::filesystem::temp_directory_path() / "voxcut-fuzz-run-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) std::abort();
  meshDir() = pattern;
  std::atexit(removeMeshDir);
  std::ofstream tet(meshDir() / "tet.obj");
  tet << "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  if (!tet.flush()) std::abort();
  return 0;
}

// Byte mutations nearly always break the JSON or misspell a key, and a scene that does not
// parse never reaches the simulation (fuzz_scene covers parse errors). So half the mutations
// edit values (JsonMutator.h); the other half are libFuzzer's own, kept only when the result is
// still JSON (tried a few times, the input left as it was otherwise).
extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size,
                                               std::size_t maxSize, unsigned int seed) {
  if ((seed & 1U) != 0) {
    const std::size_t edited = voxcut::fuzz::mutateJsonValues(data, size, maxSize, seed >> 1);
    if (edited > 0) return edited;
  }
  constexpr int kAttempts = 16;
  const std::vector<std::uint8_t> original(data, data + size);
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    const std::size_t mutated = LLVMFuzzerMutate(data, size, maxSize);
    if (nlohmann::json::accept(std::string_view(reinterpret_cast<const char*>(data), mutated)))
      return mutated;
    std::copy(original.begin(), original.end(), data);
  }
  return size;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    voxcut::Scene scene = voxcut::parseScene(text, "fuzz.json", meshDir());
    if (!makeTiny(scene)) return 0;
    const int frames = *scene.frames;
    std::vector<voxcut::VoxelGrid> grids = voxcut::voxelizeSceneBodies(scene, false);
    voxcut::WorldSettings params;
    params.threaded = false;
    voxcut::World sim = voxcut::World::fromScene(scene, std::move(grids), params);
    for (int f = 0; f < frames; ++f) (void)sim.step();
    for (const voxcut::BodyId b : sim.bodies()) {
      (void)sim.pieces(b);
      (void)sim.surfaceMesh(b);
    }
    (void)sim.maxDisplacement();
  } catch (const voxcut::InputError&) {
    // Bad input, reported as the library promises.
  }
  return 0;
}
