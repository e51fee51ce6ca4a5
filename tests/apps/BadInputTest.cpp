// The bad-input matrix: for inputs from every category a user can get wrong (meshes, scenes,
// output paths, resources, flags, outputs), the real voxcut binary must exit with status 2
// and exactly one line on stderr starting "voxcut: error:", within 10 s, and leave no file
// behind. Each case runs in a fresh folder holding only its inputs.

#include <gtest/gtest.h>

#include <cctype>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "CliProcess.h"

namespace voxcut::cli {
namespace {

/// A small scene that runs in a blink.
std::string smallScene(const std::string& extra = "") {
  return R"({"frames": 2, "bodies": [{"model": "sphere:0.05", "resolution": 21}])" + extra + "}";
}

/// A binary STL that announces 100 triangles and holds one.
std::string truncatedStl() {
  std::string s(80, ' ');
  const std::uint32_t count = 100;
  s.append(reinterpret_cast<const char*>(&count), 4);
  s.append(50, '\0');
  return s;
}

struct BadInput {
  const char* category;
  const char* name;
  std::vector<std::pair<std::string, std::string>> files;  ///< inputs: name, bytes
  std::vector<std::string> args;                           ///< "@" becomes the folder
  std::string stdoutPath;                                  ///< empty: captured
  std::vector<std::string> folders = {};                   ///< input folders to create
};

/// Names the case in gtest's messages.
void PrintTo(const BadInput& c, std::ostream* os) {
  *os << c.category << " / " << c.name;
}

const std::string kTetrahedron = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";

std::vector<BadInput> badInputs() {
  const std::string deep =
      R"({"bodies": )" + std::string(100000, '[') + std::string(100000, ']') + "}";
  // clang-format off
  return {
      // meshes
      {"mesh", "missing file", {}, {"info", "@/missing.obj"}, ""},
      {"mesh", "directory", {}, {"info", "@/folder.obj"}, "", {"folder.obj"}},
      {"mesh", "empty file", {{"empty.obj", ""}}, {"info", "@/empty.obj"}, ""},
      {"mesh", "PLY without end_header", {{"head.ply", "ply\nformat ascii 1.0\n"}},
       {"info", "@/head.ply"}, ""},
      {"mesh", "truncated binary STL", {{"cut.stl", truncatedStl()}}, {"info", "@/cut.stl"}, ""},
      {"mesh", "OBJ index out of range",
       {{"index.obj", kTetrahedron + "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 9\n"}},
       {"info", "@/index.obj"}, ""},
      {"mesh", "NaN coordinate",
       {{"nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"}},
       {"info", "@/nan.obj"}, ""},
      // scenes
      {"scene", "missing", {}, {"run", "@/missing.json"}, ""},
      {"scene", "/dev/zero", {}, {"run", "/dev/zero"}, ""},
      {"scene", "bad JSON", {{"bad.json", R"({"bodies": [ )"}}, {"run", "@/bad.json"}, ""},
      {"scene", "deep nesting", {{"deep.json", deep}}, {"run", "@/deep.json"}, ""},
      {"scene", "unknown key", {{"key.json", smallScene(R"(, "gravitee": [0, 0, 0])")}},
       {"run", "@/key.json"}, ""},
      {"scene", "coordinate 1e308",
       {{"far.json", smallScene(R"(, "tools": [{"type": "blade", "keys": [{"t": 0, "a": [1e308, 0, 0], "b": [0, 0.1, 0]}]}])")}},
       {"run", "@/far.json"}, ""},
      // output paths
      {"paths", "export into a file", {{"s.json", smallScene()}, {"file", "x"}},
       {"run", "@/s.json", "--export", "@/file/frames"}, ""},
      {"paths", "export is a file", {{"s.json", smallScene()}, {"file", "x"}},
       {"run", "@/s.json", "--export", "@/file"}, ""},
      {"paths", "csv into a missing folder", {{"s.json", smallScene()}},
       {"run", "@/s.json", "--export", "@/frames", "--csv", "@/missing/run.csv"}, ""},
      {"paths", "csv is a folder", {{"s.json", smallScene()}}, {"run", "@/s.json", "--csv", "@/out"},
       "", {"out"}},
      {"paths", "surface into a missing folder", {},
       {"surface", "sphere:0.05", "--resolution", "21", "-o", "@/missing/s.obj"}, ""},
      {"paths", "bench csv into a missing folder", {},
       {"bench", "single-frame", "--models", "bunny", "--csv", "@/missing/b.csv"}, ""},
      // resources
      {"resources", "resolution 1024 box", {},
       {"info", "box:0.1,0.1,0.1", "--resolution", "1024", "--max-memory", "16G"}, ""},
      {"resources", "scene over the limit",
       {{"big.json", R"({"bodies": [{"model": "sphere:0.05", "resolution": 400}]})"}},
       {"run", "@/big.json", "--max-memory", "100M"}, ""},
      {"resources", "cut over the limit", {},
       {"cut", "bunny", "--resolution", "600", "--max-memory", "1G"}, ""},
      // flags
      {"flags", "threads 0", {}, {"info", "bunny", "--threads", "0"}, ""},
      {"flags", "bad max-memory", {}, {"info", "bunny", "--max-memory", "lots"}, ""},
      {"flags", "zero max-memory", {{"s.json", smallScene()}}, {"run", "@/s.json", "--max-memory", "0"}, ""},
      {"flags", "unknown flag", {}, {"info", "bunny", "--frobnicate"}, ""},
      {"flags", "frames 0", {{"s.json", smallScene()}}, {"run", "@/s.json", "--frames", "0"}, ""},
      // outputs
      {"outputs", "info to /dev/full", {}, {"info", "sphere:0.05", "--resolution", "21"}, "/dev/full"},
      {"outputs", "info --json to /dev/full", {},
       {"info", "sphere:0.05", "--resolution", "21", "--json"}, "/dev/full"},
      {"outputs", "run --json to /dev/full", {{"s.json", smallScene()}}, {"run", "@/s.json", "--json"},
       "/dev/full"},
      {"outputs", "run to a closed pipe", {{"s.json", smallScene()}}, {"run", "@/s.json"}, kBrokenPipe},
      {"outputs", "info with stdout closed", {}, {"info", "sphere:0.05", "--resolution", "21"},
       kClosedStdout},
      {"outputs", "run --csv with stdout closed", {{"s.json", smallScene()}},
       {"run", "@/s.json", "--csv", "@/run.csv"}, kClosedStdout},
  };
  // clang-format on
}

class BadInputMatrix : public ::testing::TestWithParam<BadInput> {};

TEST_P(BadInputMatrix, ExitsTwoWithOneLineAndLeavesNothing) {
  const BadInput& c = GetParam();
  // Without the address-space cap (sanitizer builds) a reader that does not bound its input
  // would take the machine's memory before the time limit.
  if (kRunawayLimit == 0 && std::string(c.name) == "/dev/zero")
    GTEST_SKIP() << "no memory cap in sanitizer builds";
  const TempFolder folder("badinput");
  for (const auto& [name, bytes] : c.files) folder.write(name, bytes);
  for (const auto& name : c.folders) fs::create_directories(folder.path() / name);
  const std::vector<std::string> before = folder.entries();
  std::vector<std::string> args;
  for (std::string a : c.args) {
    if (a.rfind('@', 0) == 0) a = folder.path().string() + a.substr(1);
    args.push_back(a);
  }
  ProcessOptions options;
  options.workingFolder = folder.path().string();
  options.stdoutPath = c.stdoutPath;
  options.timeLimitSeconds = 10;
  // A runaway allocation fails at once instead of taking the machine's memory.
  options.addressSpaceLimit = kRunawayLimit;
  const ProcessResult r = runVoxcut(args, options);
  const std::string what = std::string(c.category) + " / " + c.name + "\n" + describe(args, r);
  EXPECT_FALSE(r.timedOut) << what;
  EXPECT_LT(r.seconds, 10.0) << what;
  EXPECT_EQ(r.status, 2) << what;
  EXPECT_EQ(r.err.rfind("voxcut: error:", 0), 0u) << what;
  EXPECT_TRUE(!r.err.empty() && r.err.find('\n') == r.err.size() - 1)
      << "stderr must be exactly one line\n"
      << what;
  EXPECT_TRUE(r.out.empty()) << what;
  EXPECT_EQ(folder.entries(), before) << "files left behind\n" << what;
}

std::string caseName(const ::testing::TestParamInfo<BadInput>& info) {
  std::string name = std::string(info.param.category) + "_" + info.param.name;
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Cli, BadInputMatrix, ::testing::ValuesIn(badInputs()), caseName);

}  // namespace
}  // namespace voxcut::cli
