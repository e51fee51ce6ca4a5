#include "voxcut/io/SceneReader.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "voxcut/core/CoordinateRange.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/MeshReader.h"
#include "voxcut/io/StrictJson.h"
#include "voxcut/io/VolumeReader.h"
#include "voxcut/sim/WorldChecks.h"

namespace voxcut {
namespace {

// ordered_json keeps the file's key order, so materials come back in the order written and
// the first unknown key reported is the first one in the file.
using Json = nlohmann::ordered_json;
namespace fs = std::filesystem;

constexpr int kMaxResolution = 4096;
constexpr std::size_t kMaxShownChars = 60;
// The ranges of the physical parameters are the world API's (sim/WorldChecks.h).
// Chunk in which a scene file is read, so that only what the file holds is allocated.
constexpr std::size_t kReadChunk = 1 << 16;
// How far from 1 the length of a normalised vector can come out (about 1.5 ulps; 4 allowed).
constexpr double kUnitTolerance = 4.0 * std::numeric_limits<double>::epsilon();

/// The context of one parse: the scene's name for messages and the folder of mesh paths.
struct Reader {
  std::string source;
  fs::path baseDir;

  /// Throws "SOURCE: PATH: WHAT" (PATH "top level" for the root), control characters of keys
  /// escaped so that it stays one line.
  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw InputError(detail::oneLine(
        source + ": " + (path.empty() ? std::string("top level") : path) + ": " + what));
  }
};

std::string child(const std::string& path, std::string_view key) {
  return path.empty() ? std::string(key) : path + "." + std::string(key);
}

std::string element(const std::string& path, std::size_t i) {
  return path + "[" + std::to_string(i) + "]";
}

/// A value as the user wrote it (JSON text, cut short), for "got ..." in messages.
std::string shown(const Json& v) {
  std::string s = v.dump();
  if (s.size() > kMaxShownChars) s = s.substr(0, kMaxShownChars - 3) + "...";
  return s;
}

/// A number for messages: shortest round-trip form.
std::string shown(double x) {
  return Json(x).dump();
}

const char* kindOf(const Json& v) {
  if (v.is_object()) return "an object";
  if (v.is_array()) return "a list";
  if (v.is_string()) return "a string";
  if (v.is_boolean()) return "a boolean";
  if (v.is_null()) return "null";
  return "a number";
}

void expectObject(const Reader& r, const Json& v, const std::string& path) {
  if (!v.is_object()) r.fail(path, std::string("must be an object, got ") + kindOf(v));
}

/// Checks that `obj` holds only `allowed` keys.
void checkKeys(const Reader& r, const Json& obj, const std::string& path,
               std::initializer_list<std::string_view> allowed) {
  for (const auto& item : obj.items()) {
    if (std::find(allowed.begin(), allowed.end(), item.key()) != allowed.end()) continue;
    std::string list;
    for (std::string_view k : allowed) list += (list.empty() ? "" : ", ") + std::string(k);
    r.fail(child(path, item.key()), "unknown key (expected one of: " + list + ")");
  }
}

/// The member `key` of `obj`, which must be there.
const Json& required(const Reader& r, const Json& obj, const std::string& path,
                     std::string_view key) {
  const auto it = obj.find(std::string(key));
  if (it == obj.end()) r.fail(child(path, key), "missing (required)");
  return *it;
}

/// A finite number.
double number(const Reader& r, const Json& v, const std::string& path) {
  if (!v.is_number()) r.fail(path, std::string("must be a number, got ") + shown(v));
  const double x = v.get<double>();
  if (!std::isfinite(x)) r.fail(path, "must be finite, got " + shown(v));
  return x;
}

/// A number in (0, max]; `maxText` writes max with its unit for messages.
double positive(const Reader& r, const Json& v, const std::string& path, double max,
                const char* maxText) {
  const double x = number(r, v, path);
  if (!(x > 0.0)) r.fail(path, "must be > 0, got " + shown(v));
  if (!(x <= max)) r.fail(path, std::string("must be <= ") + maxText + ", got " + shown(v));
  return x;
}

/// A number in [0, max]; `maxText` writes max with its unit for messages.
double nonNegative(const Reader& r, const Json& v, const std::string& path, double max,
                   const char* maxText) {
  const double x = number(r, v, path);
  if (!(x >= 0.0)) r.fail(path, "must be >= 0, got " + shown(v));
  if (!(x <= max)) r.fail(path, std::string("must be <= ") + maxText + ", got " + shown(v));
  return x;
}

/// An integer in lo..hi (a JSON number with an integral value, e.g. 3 or 3.0).
int integer(const Reader& r, const Json& v, const std::string& path, long long lo, long long hi) {
  const std::string want =
      "must be an integer in " + std::to_string(lo) + ".." + std::to_string(hi) + ", got ";
  if (!v.is_number()) r.fail(path, want + shown(v));
  long long value = 0;
  if (v.is_number_unsigned()) {
    const auto u = v.get<unsigned long long>();
    if (u > static_cast<unsigned long long>(hi)) r.fail(path, want + shown(v));
    value = static_cast<long long>(u);
  } else if (v.is_number_integer()) {
    value = v.get<long long>();
  } else {
    const double x = v.get<double>();
    if (!(std::floor(x) == x) || x < static_cast<double>(lo) || x > static_cast<double>(hi))
      r.fail(path, want + shown(v));
    value = static_cast<long long>(x);
  }
  if (value < lo || value > hi) r.fail(path, want + shown(v));
  return static_cast<int>(value);
}

/// [x, y, z]: a list of three finite numbers.
Vec3d vec3(const Reader& r, const Json& v, const std::string& path) {
  if (!v.is_array() || v.size() != 3)
    r.fail(path, "must be a list of 3 numbers [x, y, z], got " + shown(v));
  return {number(r, v[0], element(path, 0)), number(r, v[1], element(path, 1)),
          number(r, v[2], element(path, 2))};
}

/// A position or translation [x, y, z] in metres, each within the coordinate range.
Vec3d point(const Reader& r, const Json& v, const std::string& path) {
  const Vec3d p = vec3(r, v, path);
  for (int i = 0; i < 3; ++i)  // the message's key path is built only when it is needed
    if (!isCoordinate(p[i])) requireCoordinate(p[i], r.source + ": " + element(path, i));
  return p;
}

/// A list (possibly empty).
const Json& list(const Reader& r, const Json& v, const std::string& path) {
  if (!v.is_array()) r.fail(path, std::string("must be a list, got ") + kindOf(v));
  return v;
}

SolverSettings readSolver(const Reader& r, const Json& v, const std::string& path) {
  expectObject(r, v, path);
  checkKeys(r, v, path, {"tolerance", "max_iterations", "preconditioner", "projection_history"});
  SolverSettings s;
  if (v.contains("preconditioner")) {
    const Json& p = v["preconditioner"];
    std::string names;
    bool found = false;
    for (SolverChoice kind : kSolverChoices) {
      names += std::string(names.empty() ? "" : ", ") + "\"" + solverChoiceName(kind) + "\"";
      if (p.is_string() && p.get<std::string>() == solverChoiceName(kind)) {
        s.preconditioner = kind;
        found = true;
      }
    }
    if (!found)
      r.fail(child(path, "preconditioner"),
             "unknown preconditioner " + shown(p) + " (expected one of: " + names + ")");
  }
  if (v.contains("tolerance"))
    s.tolerance = positive(r, v["tolerance"], child(path, "tolerance"), 1.0, "1");
  if (v.contains("max_iterations"))
    s.maxIterations = integer(r, v["max_iterations"], child(path, "max_iterations"), 1, 1000000);
  if (v.contains("projection_history"))
    s.projectionHistory =
        integer(r, v["projection_history"], child(path, "projection_history"), 0,
                kMaxProjectionHistory);
  return s;
}

SceneMaterial readMaterial(const Reader& r, const std::string& name, const Json& v,
                           const std::string& path) {
  expectObject(r, v, path);
  checkKeys(r, v, path,
            {"young_modulus", "poisson_ratio", "density", "damping", "max_internal_level",
             "max_boundary_level"});
  SceneMaterial m;
  m.name = name;
  if (v.contains("young_modulus"))
    m.youngModulus =
        positive(r, v["young_modulus"], child(path, "young_modulus"), kMaxYoungModulus, "1e12 Pa");
  if (v.contains("poisson_ratio")) {
    const std::string p = child(path, "poisson_ratio");
    m.poissonRatio = number(r, v["poisson_ratio"], p);
    if (!(m.poissonRatio >= 0.0 && m.poissonRatio < 0.5))
      r.fail(p, "must be in [0, 0.5), got " + shown(v["poisson_ratio"]));
  }
  if (v.contains("density"))
    m.density = positive(r, v["density"], child(path, "density"), kMaxDensity, "1e5 kg/m^3");
  if (v.contains("damping")) {
    const std::string p = child(path, "damping");
    const Json& d = v["damping"];
    if (!d.is_array() || d.size() != 2)
      r.fail(p,
             "must be a list of 2 numbers [alpha, beta] (Rayleigh mass and stiffness "
             "factors), got " +
                 shown(d));
    m.massDamping = nonNegative(r, d[0], element(p, 0), kMaxDamping, "1e6 1/s");
    m.stiffnessDamping = nonNegative(r, d[1], element(p, 1), kMaxDamping, "1e6 s");
  }
  if (v.contains("max_internal_level"))
    m.maxInternalLevel =
        integer(r, v["max_internal_level"], child(path, "max_internal_level"), 0, kMaxOctreeLevel);
  if (v.contains("max_boundary_level"))
    m.maxBoundaryLevel =
        integer(r, v["max_boundary_level"], child(path, "max_boundary_level"), 0, kMaxOctreeLevel);
  return m;
}

FixedBox readFixed(const Reader& r, const Json& v, const std::string& path) {
  expectObject(r, v, path);
  checkKeys(r, v, path, {"box"});
  const std::string p = child(path, "box");
  const Json& box = required(r, v, path, "box");
  if (!box.is_array() || box.size() != 2)
    r.fail(p, "must be [[x0, y0, z0], [x1, y1, z1]], got " + shown(box));
  FixedBox f{point(r, box[0], element(p, 0)), point(r, box[1], element(p, 1))};
  static constexpr const char* kAxes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a)
    if (!(f.lo[a] <= f.hi[a]))
      r.fail(p, std::string("must have ") + kAxes[a] + "0 <= " + kAxes[a] + "1, got " +
                    shown(f.lo[a]) + " > " + shown(f.hi[a]));
  return f;
}

/// The model spec: a built-in kept as written (primitives checked by loading them, which is
/// cheap), or a mesh path made absolute against the scene's folder and checked to exist.
std::string readModel(const Reader& r, const Json& v, const std::string& path) {
  if (!v.is_string()) r.fail(path, std::string("must be a string, got ") + kindOf(v));
  const std::string spec = v.get<std::string>();
  if (spec.empty()) r.fail(path, "must not be empty");
  if (isBuiltinModelSpec(spec)) {
    if (spec.starts_with("box") || spec.starts_with("sphere")) {
      try {
        (void)loadModel(spec);
      } catch (const InputError& e) {
        r.fail(path, e.what());
      }
    }
    return spec;
  }
  const fs::path given(spec);
  const fs::path resolved = fs::absolute(r.baseDir / given).lexically_normal();
  std::error_code ec;
  const auto status = fs::status(resolved, ec);
  if (ec || !fs::exists(status))
    r.fail(path, "no built-in model and no such mesh file '" + resolved.string() + "'" +
                     (given.is_relative() ? " (relative paths start at the scene's folder)" : ""));
  if (!fs::is_regular_file(status))
    r.fail(path, "'" + resolved.string() + "' is not a regular file");
  return resolved.string();
}

SceneBody readBody(const Reader& r, const Json& v, const std::string& path) {
  expectObject(r, v, path);
  checkKeys(r, v, path,
            {"model", "resolution", "element_level", "finest_level", "front_level",
             "surface_level", "materials", "fixed", "offset", "labels", "min_island",
             "label_names"});
  SceneBody b;
  b.model = readModel(r, required(r, v, path, "model"), child(path, "model"));
  if (v.contains("resolution"))
    b.resolution = integer(r, v["resolution"], child(path, "resolution"), 3, kMaxResolution);
  if (v.contains("element_level"))
    b.elementLevel =
        integer(r, v["element_level"], child(path, "element_level"), 0, kMaxElementLevel);
  // A level no coarser than the body's element_level.
  const auto finerLevel = [&](const char* key, int& out) {
    if (!v.contains(key)) return;
    const std::string p = child(path, key);
    out = integer(r, v[key], p, 0, kMaxElementLevel);
    if (out > b.elementLevel)
      r.fail(p, "must be <= element_level (" + std::to_string(b.elementLevel) + "), got " +
                    std::to_string(out));
  };
  finerLevel("finest_level", b.finestLevel);
  if (v.contains("front_level")) {
    int front = 0;
    finerLevel("front_level", front);
    if (front < b.finestLevel)
      r.fail(child(path, "front_level"), "must be >= finest_level (" +
                                            std::to_string(b.finestLevel) + "), got " +
                                            std::to_string(front));
    b.frontLevel = front;
  }
  finerLevel("surface_level", b.surfaceLevel);
  if (v.contains("materials")) {
    const std::string p = child(path, "materials");
    const Json& mats = v["materials"];
    expectObject(r, mats, p);
    for (const auto& item : mats.items()) {
      if (item.key().empty()) r.fail(p, "a material name must not be empty");
      b.materials.push_back(readMaterial(r, item.key(), item.value(), child(p, item.key())));
    }
  }
  if (v.contains("fixed")) {
    const std::string p = child(path, "fixed");
    const Json& fixed = list(r, v["fixed"], p);
    for (std::size_t i = 0; i < fixed.size(); ++i)
      b.fixed.push_back(readFixed(r, fixed[i], element(p, i)));
  }
  if (v.contains("offset")) b.offset = point(r, v["offset"], child(path, "offset"));
  const bool volume = isVolumePath(b.model);
  for (const char* key : {"labels", "min_island", "label_names"})
    if (v.contains(key) && !volume)
      r.fail(child(path, key), "applies to a label volume (.nii, .nii.gz, .nrrd, .nhdr, "
                               ".seg.nrrd, .mha, .mhd), not to this model");
  if (v.contains("labels")) {
    const std::string p = child(path, "labels");
    const Json& labels = v["labels"];
    if (labels.is_string()) {
      if (labels.get<std::string>() != "all")
        r.fail(p, "must be \"all\" or an object of label values to names, got " + shown(labels));
    } else {
      expectObject(r, labels, p);
      if (labels.empty()) r.fail(p, "must name at least one label");
      for (const auto& item : labels.items()) {
        const std::string ip = child(p, item.key());
        std::int64_t value = 0;
        const std::string& k = item.key();
        const auto [end, ec] = std::from_chars(k.data(), k.data() + k.size(), value);
        if (k.empty() || ec != std::errc() || end != k.data() + k.size())
          r.fail(ip, "a label value must be an integer");
        if (!item.value().is_string() || item.value().get<std::string>().empty())
          r.fail(ip, "must be a non-empty material name, got " + shown(item.value()));
        b.labels.push_back({value, item.value().get<std::string>()});
      }
    }
  }
  if (v.contains("min_island"))
    b.minIsland = integer(r, v["min_island"], child(path, "min_island"), 0, 1 << 30);
  if (v.contains("label_names")) {
    const std::string p = child(path, "label_names");
    const Json& names = v["label_names"];
    if (!names.is_string() || names.get<std::string>().empty())
      r.fail(p, "must be the path of a names file, got " + shown(names));
    const fs::path resolved =
        fs::absolute(r.baseDir / fs::path(names.get<std::string>())).lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(resolved, ec))
      r.fail(p, "no such file '" + resolved.string() + "'");
    b.labelNames = resolved.string();
  }
  return b;
}

/// The keys of a tool of kind `kind` (blade: "a" and "b"; probe: "p", or "a" and "b" for a
/// capsule, the same in every key).
std::vector<ToolKey> readKeys(const Reader& r, const Json& keys, const std::string& p,
                              ToolKind kind) {
  const bool blade = kind == ToolKind::Blade;
  if (!keys.is_array() || keys.empty())
    r.fail(p,
           std::string("must be a non-empty list of {\"t\": s, ") +
               (blade ? "\"a\": [x,y,z], \"b\": [x,y,z]}" : "\"p\": [x,y,z]} (or \"a\", \"b\")}") +
               ", got " + shown(keys));
  std::vector<ToolKey> out;
  bool sphere = false;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const std::string kp = element(p, i);
    const Json& k = keys[i];
    expectObject(r, k, kp);
    const bool hasP = !blade && k.contains("p");
    if (i == 0) sphere = hasP;
    if (!blade && hasP != sphere)
      r.fail(kp,
             "a probe's keys all give \"p\" (a sphere) or all give \"a\" and \"b\" (a "
             "capsule)");
    if (hasP)
      checkKeys(r, k, kp, {"t", "p", "jump"});
    else
      checkKeys(r, k, kp, {"t", "a", "b", "jump"});
    ToolKey key;
    if (k.contains("jump")) {
      if (!k["jump"].is_boolean())
        r.fail(child(kp, "jump"), "must be true or false, got " + shown(k["jump"]));
      key.jump = k["jump"].get<bool>();
    }
    const Json& t = required(r, k, kp, "t");
    key.t = number(r, t, child(kp, "t"));
    if (!(std::abs(key.t) <= kMaxKeyTime))
      r.fail(child(kp, "t"), "must be in [-1e9, 1e9] s, got " + shown(t));
    if (i > 0 && !(key.t > out.back().t || (key.jump && key.t == out.back().t)))
      r.fail(child(kp, "t"),
             std::string("key times must increase strictly (a jump key may repeat the previous "
                         "key's time): must be ") +
                 (key.jump ? ">= " : "> ") + shown(out.back().t) + " (the previous key's), got " +
                 shown(key.t));
    if (hasP) {
      key.pose.a = key.pose.b = point(r, k["p"], child(kp, "p"));
    } else {
      key.pose.a = point(r, required(r, k, kp, "a"), child(kp, "a"));
      key.pose.b = point(r, required(r, k, kp, "b"), child(kp, "b"));
      if (blade && key.pose.a == key.pose.b) r.fail(kp, "the blade's ends a and b must differ");
    }
    out.push_back(key);
  }
  return out;
}

ToolKind readToolKind(const Reader& r, const Json& v, const std::string& path) {
  const Json& type = required(r, v, path, "type");
  if (type.is_string() && type.get<std::string>() == "blade") return ToolKind::Blade;
  if (type.is_string() && type.get<std::string>() == "probe") return ToolKind::Probe;
  r.fail(child(path, "type"),
         "unknown tool type " + shown(type) + " (expected one of: \"blade\", \"probe\")");
}

/// The keys of tool `index` of the trajectory file `file` (a recording, docs/scenes.md,
/// "Recordings"), for a tool of kind `kind`; errors name the file and the key path there.
std::vector<ToolKey> readTrajectory(const Reader& r, const Json& file, const std::string& path,
                                    std::size_t index, ToolKind kind);

SceneTool readTool(const Reader& r, const Json& v, const std::string& path) {
  expectObject(r, v, path);
  SceneTool tool;
  tool.kind = readToolKind(r, v, path);
  if (tool.kind == ToolKind::Blade)
    checkKeys(r, v, path, {"type", "keys", "trajectory", "trajectory_tool"});
  else
    checkKeys(r, v, path, {"type", "radius", "friction", "keys", "trajectory", "trajectory_tool"});
  if (tool.kind == ToolKind::Probe) {
    tool.radius = positive(r, required(r, v, path, "radius"), child(path, "radius"), kMaxProbeRadius, "1e3 m");
    if (v.contains("friction"))
      tool.friction = nonNegative(r, v["friction"], child(path, "friction"), kMaxFriction, "100");
  }
  const bool keys = v.contains("keys"), trajectory = v.contains("trajectory");
  if (keys == trajectory) r.fail(path, "needs exactly one of \"keys\" and \"trajectory\"");
  if (v.contains("trajectory_tool") && !trajectory)
    r.fail(child(path, "trajectory_tool"), "only goes with \"trajectory\"");
  if (keys) {
    tool.keys = readKeys(r, v["keys"], child(path, "keys"), tool.kind);
  } else {
    const std::size_t index =
        v.contains("trajectory_tool")
            ? static_cast<std::size_t>(
                  integer(r, v["trajectory_tool"], child(path, "trajectory_tool"), 0, 1 << 20))
            : 0;
    tool.keys = readTrajectory(r, v["trajectory"], child(path, "trajectory"), index, tool.kind);
  }
  return tool;
}

std::vector<ToolKey> readTrajectory(const Reader& r, const Json& file, const std::string& path,
                                    std::size_t index, ToolKind kind) {
  if (!file.is_string() || file.get<std::string>().empty())
    r.fail(path, "must be the path of a recording (a non-empty string), got " + shown(file));
  const fs::path resolved = fs::absolute(r.baseDir / file.get<std::string>()).lexically_normal();
  std::string text;
  try {
    text = readSceneText(resolved.string());
  } catch (const InputError& e) {
    r.fail(path, e.what());
  }
  const Reader inner{resolved.string(), resolved.parent_path()};
  const Json top = detail::parseStrictJson(text, inner.source, kMaxSceneDepth);
  expectObject(inner, top, "");
  checkKeys(inner, top, "", {"description", "time_step", "tools"});
  const Json& tools = list(inner, required(inner, top, "", "tools"), "tools");
  if (index >= tools.size())
    r.fail(path, "the recording has " + std::to_string(tools.size()) + " tool(s); no tool " +
                     std::to_string(index));
  const std::string tp = element("tools", index);
  const Json& t = tools[index];
  expectObject(inner, t, tp);
  checkKeys(inner, t, tp, {"type", "radius", "keys"});
  if (readToolKind(inner, t, tp) != kind)
    r.fail(path, "tool " + std::to_string(index) + " of the recording is a " +
                     t["type"].get<std::string>() + ", not a " +
                     (kind == ToolKind::Blade ? "blade" : "probe"));
  return readKeys(inner, required(inner, t, tp, "keys"), child(tp, "keys"), kind);
}

/// A mesh obstacle: the mesh file at "path" (relative to the scene's folder), scaled by
/// "scale" about the origin, then moved by "translate"; its signed distance is built here.
Obstacle readMeshObstacle(const Reader& r, const Json& v, const std::string& path) {
  const std::string p = child(path, "path");
  const Json& file = required(r, v, path, "path");
  if (!file.is_string() || file.get<std::string>().empty())
    r.fail(p, "must be the path of a mesh file (a non-empty string), got " + shown(file));
  const fs::path given(file.get<std::string>());
  const fs::path resolved = fs::absolute(r.baseDir / given).lexically_normal();
  TriangleMesh mesh;
  try {
    mesh = readMesh(resolved.string());
  } catch (const InputError& e) {
    std::error_code ec;
    const bool missing = !fs::exists(resolved, ec);
    r.fail(p, std::string("cannot read: ") + e.what() +
                  (missing && given.is_relative() ? " (relative paths start at the scene's folder)"
                                                  : ""));
  }
  const double scale =
      v.contains("scale") ? positive(r, v["scale"], child(path, "scale"), 1e6, "1e6") : 1.0;
  const Vec3d translate = v.contains("translate")
                              ? point(r, v["translate"], child(path, "translate"))
                              : Vec3d(Vec3d::Zero());
  for (Vec3d& x : mesh.vertices) {
    x = scale * x + translate;
    if (!isCoordinate(x))
      r.fail(path, std::string("the mesh, scaled and translated, reaches outside the coordinate "
                               "range ") +
                       kCoordinateRangeText + " (a vertex at " + shown(x.x()) + ", " +
                       shown(x.y()) + ", " + shown(x.z()) + ")");
  }
  Obstacle o = meshObstacle(mesh);
  if (o.mesh->triangleCount() == 0)
    r.fail(p, "mesh file '" + resolved.string() + "' has no non-degenerate triangles");
  // The file names the obstacle only where it is the file's mesh as read: the scene writer
  // (io/SceneWriter.h) writes the path alone.
  if (scale == 1.0 && translate == Vec3d::Zero()) o.path = resolved.string();
  return o;
}

Obstacle readObstacle(const Reader& r, const Json& v, const std::string& path) {
  expectObject(r, v, path);
  const Json& type = required(r, v, path, "type");
  Obstacle o;
  if (type.is_string() && type.get<std::string>() == "plane") {
    checkKeys(r, v, path, {"type", "point", "normal", "friction"});
    o.type = ObstacleType::Plane;
    o.point = point(r, required(r, v, path, "point"), child(path, "point"));
    const std::string p = child(path, "normal");
    const Vec3d n = vec3(r, required(r, v, path, "normal"), p);
    const double length = n.norm();
    if (!(length > 1e-12) || !std::isfinite(length))
      r.fail(p, "must be a non-zero direction, got " + shown(v["normal"]));
    // A normal that is unit to rounding (one normalised before, as a written scene holds) is
    // kept as it is: dividing again could move it by an ulp.
    o.normal = std::abs(length - 1.0) <= kUnitTolerance ? n : Vec3d(n / length);
  } else if (type.is_string() && type.get<std::string>() == "box") {
    checkKeys(r, v, path, {"type", "lo", "hi", "friction"});
    o.type = ObstacleType::Box;
    o.lo = point(r, required(r, v, path, "lo"), child(path, "lo"));
    o.hi = point(r, required(r, v, path, "hi"), child(path, "hi"));
    static constexpr const char* kAxes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a)
      if (!(o.lo[a] < o.hi[a]))
        r.fail(path, std::string("must have lo < hi on every axis, got ") + kAxes[a] + " " +
                         shown(o.lo[a]) + " >= " + shown(o.hi[a]));
  } else if (type.is_string() && type.get<std::string>() == "mesh") {
    checkKeys(r, v, path, {"type", "path", "scale", "translate", "friction"});
    o = readMeshObstacle(r, v, path);
  } else {
    r.fail(child(path, "type"), "unknown obstacle type " + shown(type) +
                                    " (expected one of: \"plane\", \"box\", \"mesh\")");
  }
  if (v.contains("friction"))
    o.friction = nonNegative(r, v["friction"], child(path, "friction"), kMaxFriction, "100");
  return o;
}

Scene readTop(const Reader& r, const Json& v) {
  expectObject(r, v, "");
  checkKeys(r, v, "",
            {"description", "time_step", "gravity", "solver", "frames", "bodies", "tools",
             "obstacles", "contact", "view"});
  Scene scene;
  scene.source = r.source;
  if (v.contains("description") && !v["description"].is_string())
    r.fail("description", std::string("must be a string, got ") + kindOf(v["description"]));
  if (v.contains("time_step"))
    scene.timeStep = positive(r, v["time_step"], "time_step", kMaxTimeStep, "1e3 s");
  if (v.contains("gravity")) {
    scene.gravity = vec3(r, v["gravity"], "gravity");
    for (int i = 0; i < 3; ++i)
      if (!(std::abs(scene.gravity[i]) <= kMaxGravity))
        r.fail(element("gravity", i),
               "must be in [-1e4, 1e4] m/s^2, got " + shown(v["gravity"][i]));
  }
  if (v.contains("solver")) scene.solver = readSolver(r, v["solver"], "solver");
  if (v.contains("frames")) scene.frames = integer(r, v["frames"], "frames", 1, 100000000);
  if (v.contains("view")) {
    const Json& view = v["view"];
    if (!view.is_array() || view.size() != 2)
      r.fail("view", "must be [yaw, pitch] in degrees, got " + shown(view));
    const double yaw = number(r, view[0], element("view", 0));
    const double pitch = number(r, view[1], element("view", 1));
    if (!(std::abs(yaw) <= 360.0))
      r.fail(element("view", 0), "must be in [-360, 360] degrees, got " + shown(view[0]));
    if (!(std::abs(pitch) < 90.0))
      r.fail(element("view", 1), "must be in (-90, 90) degrees, got " + shown(view[1]));
    scene.view = std::array<double, 2>{yaw, pitch};
  }
  const Json& bodies = required(r, v, "", "bodies");
  if (!bodies.is_array() || bodies.empty())
    r.fail("bodies", std::string("must be a non-empty list of bodies, got ") + shown(bodies));
  for (std::size_t i = 0; i < bodies.size(); ++i)
    scene.bodies.push_back(readBody(r, bodies[i], element("bodies", i)));
  if (v.contains("tools")) {
    const Json& tools = list(r, v["tools"], "tools");
    for (std::size_t i = 0; i < tools.size(); ++i)
      scene.tools.push_back(readTool(r, tools[i], element("tools", i)));
  }
  if (v.contains("obstacles")) {
    const Json& obstacles = list(r, v["obstacles"], "obstacles");
    for (std::size_t i = 0; i < obstacles.size(); ++i)
      scene.obstacles.push_back(readObstacle(r, obstacles[i], element("obstacles", i)));
  }
  if (v.contains("contact")) {
    const Json& c = v["contact"];
    expectObject(r, c, "contact");
    checkKeys(r, c, "contact", {"stiffness", "self_collision", "friction"});
    if (c.contains("friction"))
      scene.contact.friction =
          nonNegative(r, c["friction"], child("contact", "friction"), kMaxFriction, "100");
    if (c.contains("stiffness"))
      scene.contact.stiffness =
          nonNegative(r, c["stiffness"], child("contact", "stiffness"), kMaxContactStiffness, "1e12 N/m");
    if (c.contains("self_collision")) {
      const Json& sc = c["self_collision"];
      if (!sc.is_boolean())
        r.fail(child("contact", "self_collision"), "must be true or false, got " + shown(sc));
      scene.contact.selfCollision = sc.get<bool>();
    }
  }
  return scene;
}

/// The model of a body whose label volume is given in memory: what loadModel makes of a
/// volume file (ModelSource.cpp), the volume checked as a reader checks what it read, named
/// by the names file when the body has one. Throws InputError without the key path.
Model memoryVolumeModel(const SceneBody& body) {
  const LabelVolume& volume = *body.volume;
  const std::string what = "label volume '" + body.model + "' (in memory)";
  checkLabelVolumePlacement(volume, what);
  if (volume.index.size() != volume.voxelCount())
    throw InputError(what + ": its index holds " + std::to_string(volume.index.size()) +
                     " voxels, its dims " + std::to_string(volume.voxelCount()));
  const std::size_t labels = volume.labels.size();
  if (std::any_of(volume.index.begin(), volume.index.end(),
                  [&](std::uint16_t i) { return i > labels; }))
    throw InputError(what + ": a voxel's index names no label (it has " +
                     std::to_string(labels) + ")");
  Model model;  // Model's defaults: the default resolution loadModel gives a volume
  model.name = body.model.empty() ? std::string("volume") : body.model;
  if (body.labelNames.empty()) {
    model.volume = body.volume;
  } else {
    LabelVolume named = volume;
    applyLabelNames(named, body.labelNames);
    model.volume = std::make_shared<const LabelVolume>(std::move(named));
  }
  return model;
}

}  // namespace

bool isBuiltinModelSpec(std::string_view model) {
  const auto names = builtinModelNames();
  if (std::find(names.begin(), names.end(), model) != names.end()) return true;
  return model == "box" || model == "sphere" || model.starts_with("box:") ||
         model.starts_with("sphere:");
}

Scene parseScene(std::string_view text, const std::string& source, const fs::path& baseDir) {
  const Reader reader{source, fs::absolute(baseDir)};
  return readTop(reader, detail::parseStrictJson(text, source, kMaxSceneDepth));
}

Scene readScene(const std::string& path) {
  return parseScene(readSceneText(path), path, fs::absolute(fs::path(path)).parent_path());
}

std::string readSceneText(const std::string& path) {
  const auto fail = [&](const std::string& what) {
    throw InputError(detail::oneLine(path + ": " + what));
  };
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status)) fail("no such file");
  if (fs::is_directory(status)) fail("is a directory, not a scene file");
  if (!fs::is_regular_file(status))
    fail("not a regular file (a device, FIFO or socket); a scene is read from a regular file");
  const std::string tooLarge =
      "larger than " + std::to_string(kMaxSceneFileBytes >> 20) + " MiB, the limit of a scene file";
  const auto size = fs::file_size(path, ec);
  if (!ec && size > kMaxSceneFileBytes) fail(tooLarge);
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(std::string("cannot open: ") + std::strerror(errno));
  // At most one byte more than the limit is read, whatever the file's size said: a file that
  // grows while it is read cannot exhaust memory.
  std::string text;
  std::vector<char> chunk(kReadChunk);
  while (in && text.size() <= kMaxSceneFileBytes) {
    const std::size_t want = std::min(chunk.size(), kMaxSceneFileBytes + 1 - text.size());
    in.read(chunk.data(), static_cast<std::streamsize>(want));
    text.append(chunk.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) fail(std::string("cannot read: ") + std::strerror(errno));
  if (text.size() > kMaxSceneFileBytes) fail(tooLarge);
  return text;
}

Model loadBodyModel(const Scene& scene, std::size_t bodyIndex) {
  VOXCUT_ASSERT(bodyIndex < scene.bodies.size(), "body index out of range");
  const SceneBody& body = scene.bodies[bodyIndex];
  Model model;
  try {
    if (body.volume) {
      model = memoryVolumeModel(body);
    } else {
      ModelLoadParams lp;
      lp.labelNames = body.labelNames;
      model = loadModel(body.model, lp);
    }
  } catch (const InputError& e) {
    throw InputError(detail::oneLine(scene.source + ": bodies[" + std::to_string(bodyIndex) +
                                     "].model: " + e.what()));
  }
  if (model.isVolume()) {
    model.labels = body.labels;
    model.minIsland = body.minIsland;
    const std::string where =
        scene.source + ": bodies[" + std::to_string(bodyIndex) + "].labels";
    try {
      checkLabelChoices(*model.volume,
                        model.labels.empty() ? defaultLabelChoices(*model.volume) : model.labels,
                        where);
    } catch (const InputError& e) {
      throw InputError(detail::oneLine(e.what()));
    }
    if (body.offset != Vec3d::Zero()) {
      LabelVolume moved = *model.volume;
      moved.origin += body.offset;
      model.volume = std::make_shared<const LabelVolume>(std::move(moved));
    }
  }
  if (!isBuiltinModelSpec(body.model) && !model.isVolume() && model.materials.size() == 1)
    model.materials.front().name = "default";
  for (MaterialMesh& m : model.materials)
    for (Vec3d& p : m.mesh.vertices) {
      p += body.offset;
      if (!isCoordinate(p))
        throw InputError(
            detail::oneLine(scene.source + ": bodies[" + std::to_string(bodyIndex) +
                            "]: the model, moved by offset, reaches outside the coordinate range " +
                            kCoordinateRangeText + " (a vertex at " + shown(p.x()) + ", " +
                            shown(p.y()) + ", " + shown(p.z()) + ")"));
    }
  const std::vector<std::string> names = model.materialNames();
  try {
    checkMaterialNames(scene, bodyIndex, names);
  } catch (const InputError& e) {
    throw InputError(detail::oneLine(e.what()));  // a material name may hold a newline
  }
  return model;
}

}  // namespace voxcut
