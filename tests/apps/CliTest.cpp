// Tests of the voxcut command line: run the built binary as a user would, and check its exit
// status, stdout (text or JSON), stderr and the files it writes.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "CliProcess.h"
#include "voxcut/io/ModelSource.h"

extern char** environ;

namespace voxcut {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// A fresh directory per test, named after the test and the process; removed when done.
class ScratchDir {
 public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("voxcut_cli_") + info->test_suite_name() + "_" + info->name() +
                       "_" + std::to_string(::getpid());
    for (char& c : name)
      if (c == '/') c = '_';
    path_ = fs::temp_directory_path() / name;
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  [[nodiscard]] const fs::path& path() const { return path_; }
  [[nodiscard]] std::string file(const std::string& name) const { return (path_ / name).string(); }
  /// Writes `bytes` to `name` in the directory and returns its path.
  std::string write(const std::string& name, const std::string& bytes) const {
    const std::string p = file(name);
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }
  /// Names of the entries in the directory, sorted.
  [[nodiscard]] std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(path_)) names.push_back(e.path().filename());
    std::sort(names.begin(), names.end());
    return names;
  }

 private:
  fs::path path_;
};

/// What one run of the binary did.
struct RunResult {
  int status = -1;  ///< exit code, or 128 + signal when killed by a signal
  std::string out, err;
  double seconds = 0;
  long maxRssKiB = 0;  ///< peak resident memory of the child
};

/// Runs voxcut with `args` (stdin from /dev/null), capturing stdout and stderr through files.
RunResult voxcut(const std::vector<std::string>& args) {
  static int counter = 0;
  const fs::path base =
      fs::temp_directory_path() /
      ("voxcut_cli_run_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  const std::string outPath = base.string() + ".out", errPath = base.string() + ".err";

  std::vector<std::string> argStore{VOXCUT_EXE};
  argStore.insert(argStore.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argStore) argv.push_back(a.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, outPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0600);
  posix_spawn_file_actions_addopen(&actions, 2, errPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0600);

  RunResult r;
  const auto start = std::chrono::steady_clock::now();
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, VOXCUT_EXE, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    ADD_FAILURE() << "cannot start " << VOXCUT_EXE << ": " << std::strerror(rc);
    return r;
  }
  int wstatus = 0;
  rusage usage{};
  if (::wait4(pid, &wstatus, 0, &usage) != pid) {
    ADD_FAILURE() << "wait4 failed";
    return r;
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.maxRssKiB = usage.ru_maxrss;
  r.status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
  r.out = cli::readText(outPath);
  r.err = cli::readText(errPath);
  fs::remove(outPath);
  fs::remove(errPath);
  return r;
}

std::string describe(const std::vector<std::string>& args, const RunResult& r) {
  std::string s = "voxcut";
  for (const auto& a : args) s += " '" + a + "'";
  return s + "\n  status " + std::to_string(r.status) + "\n  stdout: " + r.out.substr(0, 500) +
         "\n  stderr: " + r.err.substr(0, 500);
}

/// Runs `voxcut COMMAND ARGS --json`, expects success and returns the parsed object.
json commandJson(const char* command, std::vector<std::string> args) {
  args.insert(args.begin(), command);
  args.emplace_back("--json");
  const RunResult r = voxcut(args);
  EXPECT_EQ(r.status, 0) << describe(args, r);
  try {
    return json::parse(r.out);
  } catch (const json::exception& e) {
    ADD_FAILURE() << "stdout is not JSON (" << e.what() << ")\n" << describe(args, r);
    return json::object();
  }
}

/// Runs `voxcut info ARGS --json`, expects success and returns the parsed object.
json infoJson(std::vector<std::string> args) {
  return commandJson("info", std::move(args));
}

/// Decimal text that reads back to the same double.
std::string num(double x) {
  std::ostringstream os;
  os.precision(17);
  os << x;
  return os.str();
}

/// The bounds {min, max} and enclosed volume of a model's meshes (all materials).
struct ModelGeometry {
  Vec3d lo, hi;
  double volume = 0;
};

ModelGeometry geometryOf(const std::string& spec) {
  const Model model = loadModel(spec);
  ModelGeometry g{Vec3d::Constant(INFINITY), Vec3d::Constant(-INFINITY), 0.0};
  for (const auto& m : model.materials) {
    const auto b = m.mesh.bounds();
    g.lo = g.lo.cwiseMin(b[0]);
    g.hi = g.hi.cwiseMax(b[1]);
  }
  // Later materials lie inside earlier ones, so the enclosed volume is that of the first.
  g.volume = model.materials.front().mesh.signedVolume();
  return g;
}

/// Checks the keys and types every `info --json` object must have (README, "Command line").
void expectInfoKeys(const json& j) {
  ASSERT_TRUE(j.is_object());
  ASSERT_TRUE(j.contains("grid") && j["grid"].is_array() && j["grid"].size() == 3u) << j.dump();
  for (const auto& n : j["grid"]) EXPECT_TRUE(n.is_number_integer() && n.get<int>() >= 3);
  for (const char* key :
       {"voxels", "links", "disconnected_links", "surface_vertices", "surface_triangles", "pieces"})
    EXPECT_TRUE(j.contains(key) && j[key].is_number_integer()) << key;
  EXPECT_TRUE(j.contains("voxel_size") && j["voxel_size"].is_number() &&
              j["voxel_size"].get<double>() > 0);
  EXPECT_TRUE(j.contains("surface_closed") && j["surface_closed"].is_boolean());
  ASSERT_TRUE(j.contains("timings_ms") && j["timings_ms"].is_object());
  EXPECT_FALSE(j["timings_ms"].empty());
  for (const auto& [stage, ms] : j["timings_ms"].items())
    EXPECT_TRUE(ms.is_number() && ms.get<double>() >= 0) << stage;
}

/// Expects a closed surface of `pieces` genus-0 pieces: Euler V - E + F = 2 * pieces with
/// E = 3F/2, so F = 2V - 4 * pieces.
void expectGenusZero(const json& j, long pieces) {
  EXPECT_TRUE(j["surface_closed"].get<bool>());
  EXPECT_EQ(j["surface_triangles"].get<long>(), 2 * j["surface_vertices"].get<long>() - 4 * pieces);
}

/// Voxel count against a volume in m^3: within `tolerance` (relative) of volume / h^3.
void expectVoxelVolume(const json& j, double volume, double tolerance) {
  const double h = j["voxel_size"].get<double>();
  const double expected = volume / (h * h * h);
  const double voxels = j["voxels"].get<double>();
  EXPECT_NEAR(voxels / expected, 1.0, tolerance)
      << "voxels " << voxels << ", volume / h^3 = " << expected;
}

/// Triangles of an OBJ written by `voxcut surface` (1-based `f a//a b//b c//c`), 0-based.
struct ObjMesh {
  std::vector<Vec3d> vertices;
  std::vector<std::array<long, 3>> faces;
};

ObjMesh readObj(const std::string& path) {
  ObjMesh m;
  std::istringstream in(cli::readText(path));
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v") {
      Vec3d p;
      ls >> p.x() >> p.y() >> p.z();
      m.vertices.push_back(p);
    } else if (tag == "f") {
      std::array<long, 3> f{};
      for (long& i : f) {
        std::string word;
        ls >> word;
        i = std::stol(word.substr(0, word.find('/'))) - 1;
      }
      m.faces.push_back(f);
    }
  }
  return m;
}

/// Checks, independently of voxcut's own report, that every directed edge of `m` occurs once
/// and its reverse once (closed, consistently oriented, edge-manifold), and returns the
/// enclosed signed volume.
double expectClosedOriented(const ObjMesh& m) {
  std::map<std::pair<long, long>, int> directed;
  for (const auto& f : m.faces)
    for (int k = 0; k < 3; ++k) {
      EXPECT_TRUE(f[k] >= 0 && f[k] < static_cast<long>(m.vertices.size()));
      ++directed[{f[k], f[(k + 1) % 3]}];
    }
  std::size_t bad = 0;
  for (const auto& [e, n] : directed) {
    const auto rev = directed.find({e.second, e.first});
    if (n != 1 || rev == directed.end() || rev->second != 1) ++bad;
  }
  EXPECT_EQ(bad, 0u) << "directed edges without exactly one opposite partner";
  double v = 0;
  for (const auto& f : m.faces)
    v += m.vertices[f[0]].dot(m.vertices[f[1]].cross(m.vertices[f[2]])) / 6.0;
  return v;
}

/// Expects a failed run reported cleanly (docs/architecture.md, "Invariants"): a status in
/// 1..127, nothing on stdout, and exactly one line on stderr starting with "voxcut: error:".
void expectCleanFailure(const std::vector<std::string>& args) {
  const RunResult r = voxcut(args);
  std::string problems;
  if (r.status < 1 || r.status > 127) problems += "exit status not in 1..127; ";
  if (!r.out.empty()) problems += "stdout not empty; ";
  if (r.err.rfind("voxcut: error:", 0) != 0) problems += "stderr does not start 'voxcut: error:'; ";
  if (r.err.empty() || r.err.find('\n') != r.err.size() - 1)
    problems += "stderr is not exactly one line; ";
  EXPECT_TRUE(problems.empty()) << problems << "\n" << describe(args, r);
}

// --- info on the built-in models -----------------------------------------------------------

TEST(Cli, InfoBunnyJson) {
  const json j = infoJson({"bunny"});
  expectInfoKeys(j);
  EXPECT_EQ(j["pieces"].get<int>(), 1);
  expectGenusZero(j, 1);
  EXPECT_GT(j["links"].get<long>(), 0);
  EXPECT_GT(j["disconnected_links"].get<long>(), 0);
  expectVoxelVolume(j, geometryOf("bunny").volume, 0.02);
}

TEST(Cli, InfoTextMentionsEveryCount) {
  const std::vector<std::string> args{"info", "bunny"};
  const RunResult r = voxcut(args);
  ASSERT_EQ(r.status, 0) << describe(args, r);
  for (const char* word :
       {"grid", "voxel size", "voxels", "links", "disconnected", "surface", "pieces", "time"})
    EXPECT_NE(r.out.find(word), std::string::npos) << word << "\n" << r.out;
}

TEST(Cli, SphereMatchesAnalyticVolume) {
  const double r = 0.05;
  const json j = infoJson({"sphere:0.05"});
  expectInfoKeys(j);
  EXPECT_EQ(j["pieces"].get<int>(), 1);
  expectGenusZero(j, 1);
  expectVoxelVolume(j, 4.0 / 3.0 * std::numbers::pi * r * r * r, 0.02);
}

TEST(Cli, BoxMatchesAnalyticVolume) {
  const json j = infoJson({"box:0.1,0.06,0.04"});
  expectInfoKeys(j);
  EXPECT_EQ(j["pieces"].get<int>(), 1);
  expectGenusZero(j, 1);
  expectVoxelVolume(j, 0.1 * 0.06 * 0.04, 0.02);
}

TEST(Cli, VoxelSizeOption) {
  const json j = infoJson({"box:0.1,0.06,0.04", "--voxel-size", "0.002"});
  expectInfoKeys(j);
  EXPECT_DOUBLE_EQ(j["voxel_size"].get<double>(), 0.002);
  expectGenusZero(j, 1);
  expectVoxelVolume(j, 0.1 * 0.06 * 0.04, 0.02);
}

TEST(Cli, ResolutionCountsPaddingAlongLongestSide) {
  const json j = infoJson({"sphere:0.05", "--resolution", "41"});
  ASSERT_TRUE(j.contains("grid"));
  EXPECT_EQ(j["grid"][0].get<int>(), 41);
  EXPECT_NEAR(j["voxel_size"].get<double>(), 0.1 / 39, 1e-3 * 0.1 / 39);
}

// --- planar cuts ---------------------------------------------------------------------------

TEST(Cli, CutPlaneThroughBunnyMiddleGivesTwoPieces) {
  const ModelGeometry g = geometryOf("bunny");
  const double dy = 0.5 * (g.lo.y() + g.hi.y());
  const json j = infoJson({"bunny", "--cut-plane", "0,1,0," + num(dy)});
  expectInfoKeys(j);
  EXPECT_EQ(j["pieces"].get<int>(), 2);
  EXPECT_TRUE(j["surface_closed"].get<bool>());
  ASSERT_TRUE(j.contains("disconnected_links_by_kind"));
  EXPECT_GT(j["disconnected_links_by_kind"]["cut"].get<long>(), 0);
}

TEST(Cli, TwoCrossingPlanesGiveFourPieces) {
  // A horizontal plane through the middle and a vertical one 1 cm off the middle: the exact
  // middle planes x = 0 and z = 0 each clip the tip off a curled ear as well (a true extra
  // piece of the bunny's geometry, not an artefact).
  const ModelGeometry g = geometryOf("bunny");
  const double dy = 0.5 * (g.lo.y() + g.hi.y());
  const double dx = 0.5 * (g.lo.x() + g.hi.x()) + 0.01;
  const json j =
      infoJson({"bunny", "--cut-plane", "0,1,0," + num(dy), "--cut-plane", "1,0,0," + num(dx)});
  expectInfoKeys(j);
  EXPECT_EQ(j["pieces"].get<int>(), 4);
  EXPECT_TRUE(j["surface_closed"].get<bool>());
}

TEST(Cli, CutSurfaceFileIsClosedAndOriented) {
  const ScratchDir dir;
  const ModelGeometry g = geometryOf("bunny");
  const std::string obj = dir.file("cut.obj");
  const std::vector<std::string> args{"surface",      "bunny",
                                      "--resolution", "61",
                                      "--cut-plane",  "0,1,0," + num(0.5 * (g.lo.y() + g.hi.y())),
                                      "-o",           obj};
  const RunResult r = voxcut(args);
  ASSERT_EQ(r.status, 0) << describe(args, r);
  const double volume = expectClosedOriented(readObj(obj));
  EXPECT_NEAR(volume / g.volume, 1.0, 0.05) << "enclosed volume of the written surface";
}

// --- materials -----------------------------------------------------------------------------

TEST(Cli, TwoMaterialsShareAnInterface) {
  const json j = infoJson({"--material", "outer=sphere:0.05", "--material", "inner=sphere:0.02"});
  expectInfoKeys(j);
  ASSERT_TRUE(j.contains("voxels_per_material") && j["voxels_per_material"].is_object());
  const json& per = j["voxels_per_material"];
  ASSERT_TRUE(per.contains("outer") && per.contains("inner")) << per.dump();
  const double h = j["voxel_size"].get<double>();
  const double innerExpected = 4.0 / 3.0 * std::numbers::pi * 0.02 * 0.02 * 0.02 / (h * h * h);
  EXPECT_NEAR(per["inner"].get<double>() / innerExpected, 1.0, 0.03);
  EXPECT_EQ(per["outer"].get<long>() + per["inner"].get<long>(), j["voxels"].get<long>());
  ASSERT_TRUE(j.contains("interface_links"));
  EXPECT_GT(j["interface_links"].get<long>(), 0);
  EXPECT_EQ(j["pieces"].get<int>(), 1);
  EXPECT_TRUE(j["surface_closed"].get<bool>());
}

// --- threads -------------------------------------------------------------------------------

/// `info --json` without the entries that may differ between thread counts.
json withoutThreadDependent(json j) {
  j.erase("timings_ms");
  j.erase("threads");
  return j;
}

TEST(Cli, InfoIdenticalWithOneAndTwoThreads) {
  const ModelGeometry g = geometryOf("bunny");
  const std::string cut = "0,1,0," + num(0.5 * (g.lo.y() + g.hi.y()));
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"bunny"}, std::vector<std::string>{"bunny", "--cut-plane", cut},
        std::vector<std::string>{"liver"}}) {
    auto one = args, two = args;
    one.insert(one.end(), {"--threads", "1"});
    two.insert(two.end(), {"--threads", "2"});
    const json j1 = infoJson(one), j2 = infoJson(two);
    EXPECT_EQ(j1.value("threads", 0), 1);
    EXPECT_EQ(withoutThreadDependent(j1), withoutThreadDependent(j2)) << args.front();
  }
}

TEST(Cli, SurfaceFilesIdenticalWithOneAndTwoThreads) {
  const ScratchDir dir;
  const ModelGeometry g = geometryOf("bunny");
  const std::string cut = "0,1,0," + num(0.5 * (g.lo.y() + g.hi.y()));
  for (const char* ext : {".obj", ".ply"}) {
    std::string files[2];
    for (int t = 1; t <= 2; ++t) {
      files[t - 1] = dir.file("bunny" + std::to_string(t) + ext);
      const std::vector<std::string> args{"surface", "bunny",     "--cut-plane",
                                          cut,       "--threads", std::to_string(t),
                                          "-o",      files[t - 1]};
      const RunResult r = voxcut(args);
      ASSERT_EQ(r.status, 0) << describe(args, r);
    }
    const std::string a = cli::readText(files[0]), b = cli::readText(files[1]);
    EXPECT_FALSE(a.empty());
    EXPECT_TRUE(a == b) << ext << " files differ between --threads 1 and --threads 2";
  }
}

// --- surface -------------------------------------------------------------------------------

TEST(Cli, SurfaceWritesObjAndPly) {
  const ScratchDir dir;
  const json info = infoJson({"bunny"});
  const long nv = info.value("surface_vertices", -1L), nt = info.value("surface_triangles", -1L);

  const std::string obj = dir.file("bunny.obj");
  const std::vector<std::string> objArgs{"surface", "bunny", "-o", obj};
  const RunResult r1 = voxcut(objArgs);
  ASSERT_EQ(r1.status, 0) << describe(objArgs, r1);
  ASSERT_TRUE(fs::is_regular_file(obj));
  const ObjMesh mesh = readObj(obj);
  EXPECT_EQ(static_cast<long>(mesh.vertices.size()), nv);
  EXPECT_EQ(static_cast<long>(mesh.faces.size()), nt);
  const double volume = expectClosedOriented(mesh);
  EXPECT_NEAR(volume / geometryOf("bunny").volume, 1.0, 0.05)
      << "enclosed volume of the written surface (negative: wound inwards)";

  const std::string ply = dir.file("bunny.ply");
  const std::vector<std::string> plyArgs{"surface", "bunny", "-o", ply};
  const RunResult r2 = voxcut(plyArgs);
  ASSERT_EQ(r2.status, 0) << describe(plyArgs, r2);
  ASSERT_TRUE(fs::is_regular_file(ply));
  const std::string bytes = cli::readText(ply);
  EXPECT_EQ(bytes.rfind("ply\n", 0), 0u);
  EXPECT_NE(bytes.find("element vertex " + std::to_string(nv) + "\n"), std::string::npos);
  EXPECT_NE(bytes.find("element face " + std::to_string(nt) + "\n"), std::string::npos);
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"bunny.obj", "bunny.ply"}))
      << "temporary files left behind";
}

TEST(Cli, SurfaceUnknownExtensionLeavesNothing) {
  const ScratchDir dir;
  const std::vector<std::string> args{"surface", "bunny", "-o", dir.file("X.xyz")};
  expectCleanFailure(args);
  EXPECT_TRUE(dir.entries().empty()) << "left behind: " << dir.entries().front();
}

TEST(Cli, SurfaceIntoMissingDirectoryFails) {
  const ScratchDir dir;
  expectCleanFailure(
      {"surface", "sphere:0.05", "--resolution", "21", "-o", dir.file("no/such/dir/x.obj")});
  EXPECT_TRUE(dir.entries().empty());
}

// --- bad input -----------------------------------------------------------------------------

TEST(Cli, BadModelFiles) {
  const ScratchDir dir;
  fs::create_directories(dir.path() / "folder.obj");
  const std::string empty = dir.write("empty.obj", "");
  const std::string noTriangles = dir.write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  const std::string nan = dir.write(
      "nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  for (const std::string& model :
       {dir.file("missing.obj"), dir.file("folder.obj"), empty, noTriangles, nan}) {
    expectCleanFailure({"info", model});
    expectCleanFailure({"info", model, "--json"});
  }
}

TEST(Cli, BadResolutionAndVoxelSize) {
  for (const char* n : {"0", "2", "-5", "1000000"})
    expectCleanFailure({"info", "bunny", "--resolution", n});
  for (const char* h : {"0", "-1", "nan"}) expectCleanFailure({"info", "bunny", "--voxel-size", h});
}

TEST(Cli, HugeResolutionFailsFastWithoutAllocating) {
  const std::vector<std::string> args{"info", "bunny", "--resolution", "1000000"};
  const RunResult r = voxcut(args);
  EXPECT_GE(r.status, 1) << describe(args, r);
  EXPECT_LE(r.status, 127) << describe(args, r);
  EXPECT_LT(r.seconds, 5.0);
  EXPECT_LT(r.maxRssKiB, 1024L * 1024L) << "peak memory, KiB";
  EXPECT_EQ(r.err.find("out of memory"), std::string::npos)
      << "must be refused before allocating, not by running out of memory\n"
      << r.err;
}

TEST(Cli, BadModelNames) {
  for (const char* model : {"dragon", "sphere:-1", "sphere:0", "sphere:", "box:1,2", "box:1,2,x"})
    expectCleanFailure({"info", model});
}

TEST(Cli, BadCutPlanes) {
  for (const char* plane : {"1,2,3", "a,b,c,d", "1,2,3,4,5", "0,0,0,1"})
    expectCleanFailure({"info", "sphere:0.05", "--resolution", "21", "--cut-plane", plane});
}

TEST(Cli, BadMaterials) {
  expectCleanFailure({"info", "--material", "liver"});
  expectCleanFailure({"info", "--material", "=liver"});
  expectCleanFailure({"info", "--material", "a=dragon"});
  expectCleanFailure({"info", "bunny", "--material", "a=sphere:0.05"});
  expectCleanFailure({"info", "--material", "a=sphere:0.05", "--material", "a=sphere:0.02"});
}

TEST(Cli, NoModelFails) {
  expectCleanFailure({"info"});
}

TEST(Cli, ParseErrorsExitBelow128) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"info", "bunny", "--frobnicate"},
        std::vector<std::string>{"frobnicate"}, std::vector<std::string>{},
        std::vector<std::string>{"surface", "bunny"},
        std::vector<std::string>{"info", "bunny", "--threads", "0"},
        std::vector<std::string>{"info", "bunny", "--resolution", "ten"},
        std::vector<std::string>{"info", "bunny", "--resolution", "21", "--voxel-size", "0.01"}}) {
    const RunResult r = voxcut(args);
    EXPECT_GE(r.status, 1) << describe(args, r);
    EXPECT_LE(r.status, 127) << describe(args, r);
    EXPECT_FALSE(r.err.empty()) << describe(args, r);
  }
}

// --- help ----------------------------------------------------------------------------------

TEST(Cli, HelpOfEachSubcommand) {
  for (const char* sub : {"info", "surface"}) {
    const std::vector<std::string> args{sub, "--help"};
    const RunResult r = voxcut(args);
    EXPECT_EQ(r.status, 0) << describe(args, r);
    for (const char* option :
         {"--resolution", "--voxel-size", "--cut-plane", "--material", "--threads", "--json"})
      EXPECT_NE(r.out.find(option), std::string::npos) << sub << " --help lacks " << option;
  }
}

// --- the voxel octree and the single-frame cut ---------------------------------------------

/// Runs `voxcut cut ARGS --json`, expects success and returns the parsed object.
json cutJson(std::vector<std::string> args) {
  return commandJson("cut", std::move(args));
}

TEST(Cli, InfoReportsBothOctrees) {
  const json j = infoJson({"bunny", "--max-level", "2"});
  ASSERT_TRUE(j.contains("octree_cubes"));
  ASSERT_EQ(j["octree_cubes"].size(), 2u);
  const json j1 = infoJson({"bunny", "--max-level", "1"});
  // Table 2's arithmetic: level-1 cubes at max 1 = level-1 + 8 x level-2 cubes at max 2.
  EXPECT_EQ(j1["octree_cubes"][0].get<long>(),
            j["octree_cubes"][0].get<long>() + 8 * j["octree_cubes"][1].get<long>());
  for (const char* k : {"active_voxels", "active_links"}) {
    ASSERT_TRUE(j.contains(k)) << k;
    EXPECT_GT(j[k].get<long>(), 0);
    EXPECT_LT(j[k].get<long>(), k[7] == 'v' ? j["voxels"].get<long>() : j["links"].get<long>());
  }
  ASSERT_TRUE(j.contains("deformation_elements"));
  ASSERT_TRUE(j.contains("deformation_nodes"));
  long elements = 0;
  for (const auto& n : j["deformation_elements"]) elements += n.get<long>();
  EXPECT_GT(elements, 100);
  const json liver = infoJson({"liver", "--max-level", "tumor=0", "--boundary-level", "1"});
  EXPECT_GT(liver["octree_cubes"][0].get<long>(), 0);
}

TEST(Cli, CutBunnyThroughTheMiddle) {
  const json o = cutJson({"bunny", "--threads", "2"});
  for (const char* k : {"octree", "threads", "repeat", "cut_links", "cut_set_hash", "pieces",
                        "surface_closed", "timings_ms"})
    ASSERT_TRUE(o.contains(k)) << k;
  for (const char* k :
       {"voxel_position_update", "intersection_test", "octree_subdivision", "total"})
    ASSERT_TRUE(o["timings_ms"].contains(k)) << k;
  EXPECT_TRUE(o["octree"].get<bool>());
  EXPECT_EQ(o["pieces"].get<int>(), 2);
  EXPECT_TRUE(o["surface_closed"].get<bool>());
  EXPECT_GT(o["cut_links"].get<long>(), 1000);
  EXPECT_EQ(o["cut_set_hash"].get<std::string>().size(), 16u);
  // The baseline cuts the same links, and thread counts do not matter.
  const json b = cutJson({"bunny", "--no-octree", "--threads", "1"});
  EXPECT_FALSE(b["octree"].get<bool>());
  EXPECT_EQ(b["cut_set_hash"], o["cut_set_hash"]);
  EXPECT_EQ(cutJson({"bunny", "--threads", "1"})["cut_set_hash"], o["cut_set_hash"]);
}

TEST(Cli, CutWithDeformationsAndExplicitBlade) {
  for (const char* d : {"rigid", "bend", "twist"}) {
    const json o = cutJson({"sphere:0.05", "--resolution", "40", "--deform", d});
    const json b = cutJson({"sphere:0.05", "--resolution", "40", "--deform", d, "--no-octree"});
    EXPECT_EQ(o["cut_set_hash"], b["cut_set_hash"]) << d;
    EXPECT_TRUE(o["surface_closed"].get<bool>()) << d;
  }
  ScratchDir dir;
  const std::string out = dir.file("cut.obj");
  const RunResult r =
      voxcut({"cut", "box:0.1,0.1,0.1", "--resolution", "30", "--blade", "-1,0.01,-1,1,0.01,-1",
              "--to", "-1,0.01,1,1,0.01,1", "-o", out, "--json"});
  ASSERT_EQ(r.status, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_EQ(j["pieces"].get<int>(), 2);
  const double vol = expectClosedOriented(readObj(out));
  EXPECT_NEAR(vol, 1e-3, 1e-4);
}

TEST(Cli, CutBadInput) {
  expectCleanFailure({"cut", "bunny", "--deform", "wobble"});
  expectCleanFailure({"cut", "bunny", "--blade", "1,2,3", "--to", "1,2,3,4,5,6"});
  expectCleanFailure({"cut", "bunny", "--blade", "0,0,0,0,0,0", "--to", "1,2,3,4,5,6"});
  expectCleanFailure({"cut", "bunny", "--blade", "0,0,0,1,1,1"});
  expectCleanFailure({"cut", "bunny", "--max-level", "-1"});
  expectCleanFailure({"cut", "bunny", "--max-level", "liver=2"});
  expectCleanFailure({"cut", "bunny", "--repeat", "0"});
  expectCleanFailure({"info", "bunny", "--boundary-level", "x"});
}

// --- run ---------------------------------------------------------------------------------------

/// Writes `text` to a fresh scene file in the temporary folder and returns its path.
std::string writeScene(const std::string& name, const std::string& text) {
  const fs::path path =
      fs::temp_directory_path() / ("voxcut_cli_" + std::to_string(::getpid()) + "_" + name);
  std::ofstream(path) << text;
  return path.string();
}

TEST(Cli, RunCutsASphereInTwoAndReportsEveryKey) {
  // No gravity: a blade sweeps across the whole sphere in 20 frames.
  const std::string scene = writeScene("sphere.json", R"({
    "time_step": 0.004, "gravity": [0, 0, 0],
    "bodies": [{"model": "sphere:0.02", "resolution": 24, "element_level": 2}],
    "tools": [{"type": "blade", "keys": [
      {"t": 0.0, "a": [-0.05, 0.003, -0.03], "b": [0.05, 0.003, -0.03]},
      {"t": 0.08, "a": [-0.05, 0.003, 0.03], "b": [0.05, 0.003, 0.03]}]}]})");
  const fs::path dir =
      fs::temp_directory_path() / ("voxcut_cli_export_" + std::to_string(::getpid()));
  const std::string csv = dir.string() + ".csv";
  fs::remove_all(dir);
  const json j = commandJson(
      "run", {scene, "--frames", "30", "--csv", csv, "--export", dir.string(), "--every", "10"});
  for (const char* key :
       {"frames", "cut_links", "pieces", "max_displacement", "solver_iterations_mean",
        "solver_solves_mean", "converged", "solver_factorisations", "timings_ms", "frame_ms"})
    ASSERT_TRUE(j.contains(key)) << key;  // a const json's [] must not meet a missing key
  EXPECT_EQ(j["frames"], 30);
  EXPECT_EQ(j["solver_solves_mean"], 1.0);  // one body, nothing to touch: one solve a frame
  EXPECT_GT(j["cut_links"].get<long>(), 0);
  EXPECT_GE(j["solver_factorisations"].get<long>(), 1);  // the default Cholesky preconditioner
  EXPECT_EQ(j["pieces"], 2);
  for (const char* stage :
       {"voxel_position_update", "intersection_test", "octree_subdivision", "deformation"}) {
    ASSERT_TRUE(j["timings_ms"].contains(stage)) << stage;
    EXPECT_TRUE(j["timings_ms"][stage].contains("mean")) << stage;
    EXPECT_TRUE(j["timings_ms"][stage].contains("max")) << stage;
  }
  for (const char* k : {"mean", "p95", "max"}) EXPECT_TRUE(j["frame_ms"].contains(k)) << k;
  // One CSV row per frame after the header; surfaces at frames 0, 10, 20 and 30, closed.
  const std::string rows = cli::readText(csv);
  EXPECT_EQ(std::count(rows.begin(), rows.end(), '\n'), 31);
  const std::string header = rows.substr(0, rows.find('\n'));
  EXPECT_NE(header.find(",solver_iterations,converged,solver_factorisations"),
            std::string::npos);
  EXPECT_EQ(header.substr(header.rfind(',') + 1), "solver_solves");
  // Every row ends with its frame's solves: 1 here.
  std::istringstream lines(rows.substr(header.size() + 1));
  for (std::string line; std::getline(lines, line);)
    EXPECT_EQ(line.substr(line.rfind(',') + 1), "1") << line;
  for (const char* f :
       {"frame_00000.obj", "frame_00010.obj", "frame_00020.obj", "frame_00030.obj"}) {
    ASSERT_TRUE(fs::exists(dir / f)) << f;
    expectClosedOriented(readObj((dir / f).string()));
  }
  fs::remove_all(dir);
  fs::remove(csv);
  fs::remove(scene);
}

TEST(Cli, RunRecordPlaysBackToTheSameCuts) {
  // A blade crossing a sphere and a probe pressing it: recorded, then played back from the
  // recording; the cuts (cut_set_hash) and the probe's force come out the same.
  const std::string scene = writeScene("record.json", R"({
    "time_step": 0.004, "gravity": [0, 0, 0],
    "bodies": [{"model": "sphere:0.02", "resolution": 24, "element_level": 2}],
    "tools": [{"type": "blade", "keys": [
      {"t": 0.0, "a": [-0.05, 0.003, -0.03], "b": [0.05, 0.003, -0.03]},
      {"t": 0.05, "a": [-0.05, 0.005, 0.0], "b": [0.05, 0.001, 0.0]},
      {"t": 0.08, "a": [-0.05, 0.003, 0.03], "b": [0.05, 0.003, 0.03]}]},
      {"type": "probe", "radius": 0.005, "keys": [{"t": 0, "p": [0, -0.03, 0]},
                                                  {"t": 0.1, "p": [0, -0.018, 0]}]}]})");
  const std::string record = scene + ".rec.json";
  const json j = commandJson("run", {scene, "--frames", "30", "--record", record});
  ASSERT_TRUE(j.contains("cut_set_hash") && j.contains("tool_forces") && j.contains("contact"));
  EXPECT_GT(j["cut_links"].get<long>(), 0);
  ASSERT_EQ(j["tool_forces"].size(), 2u);
  EXPECT_EQ(j["tool_forces"][0]["max"].get<double>(), 0.0);  // a blade pushes nothing
  EXPECT_GT(j["tool_forces"][1]["max"].get<double>(), 0.0);
  EXPECT_EQ(j["tool_forces"][1]["final"].size(), 3u);
  const std::string playback = writeScene("playback.json", R"({
    "time_step": 0.004, "gravity": [0, 0, 0],
    "bodies": [{"model": "sphere:0.02", "resolution": 24, "element_level": 2}],
    "tools": [{"type": "blade", "trajectory": ")" + fs::path(record).filename().string() +
                                                               R"("},
      {"type": "probe", "radius": 0.005, "trajectory": ")" + fs::path(record).filename().string() +
                                                               R"(", "trajectory_tool": 1}]})");
  const json p = commandJson("run", {playback, "--frames", "30"});
  EXPECT_EQ(p["cut_set_hash"], j["cut_set_hash"]);
  EXPECT_EQ(p["cut_links"], j["cut_links"]);
  EXPECT_EQ(p["tool_forces"], j["tool_forces"]);
  fs::remove(record);
  fs::remove(scene);
  fs::remove(playback);
}

TEST(Cli, RunBadScenesFailCleanly) {
  expectCleanFailure({"run", "/nonexistent/scene.json"});
  const std::string bad = writeScene(
      "bad.json",
      R"({"bodies": [{"model": "bunny", "materials": {"default": {"poisson_ratio": 0.7}}}]})");
  expectCleanFailure({"run", bad});
  const std::string unknown =
      writeScene("unknown.json", R"({"bodies": [{"model": "bunny"}], "gravitee": [0, 0, 0]})");
  expectCleanFailure({"run", unknown});
  const std::string broken = writeScene("broken.json", R"({"bodies": [ )");
  expectCleanFailure({"run", broken});
  expectCleanFailure({"run", bad, "--frames", "0"});
  for (const std::string& p : {bad, unknown, broken}) fs::remove(p);
}

TEST(Cli, HostileScenesBladesAndEmptyModelsExitTwo) {
  const ScratchDir dir;
  const std::string flat =
      dir.write("flat.obj", "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0.1 0.1 0\nf 1 2 3\nf 2 4 3\n");
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases{
      {{"run", "/dev/zero"}, "/dev/zero: not a regular file"},
      {{"run", dir.path().string()}, "is a directory"},
      {{"cut", "box:0.1,0.1,0.1", "--resolution", "16", "--blade", "1e308,0,0,0,0,0.1", "--to",
        "0,0.1,0,0,0.1,0.1"},
       "AX: must be in [-1e6, 1e6] m, got 1e+308"},
      {{"cut", "box:0.1,0.1,0.1", "--resolution", "16", "--blade", "-1,0,0,1,0,0", "--to",
        "-1e155,0.1,0,1e155,0.1,0"},
       "--to '-1e155,0.1,0,1e155,0.1,0': AX: must be in [-1e6, 1e6] m, got -1e+155"},
      {{"info", flat}, "model '" + flat + "': voxelizes to no voxels at resolution 101"},
      {{"cut", flat}, "model '" + flat + "': voxelizes to no voxels"},
  };
  for (const auto& [args, message] : cases) {
    const RunResult r = voxcut(args);
    EXPECT_EQ(r.status, 2) << describe(args, r);
    EXPECT_TRUE(r.out.empty()) << describe(args, r);
    EXPECT_EQ(r.err.rfind("voxcut: error: ", 0), 0u) << describe(args, r);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << describe(args, r);
    EXPECT_NE(r.err.find(message), std::string::npos) << describe(args, r);
    EXPECT_LT(r.seconds, 10.0) << describe(args, r);
  }
}

}  // namespace
}  // namespace voxcut
