#include "voxcut/io/SceneWriter.h"

#include <cmath>
#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/io/StrictJson.h"
#include "voxcut/io/VolumeReader.h"

namespace voxcut {
namespace {

// ordered_json keeps keys in the order they are set: materials and labels must read back in
// their order. Its dump writes a double in the shortest form that reads back to it.
using Json = nlohmann::ordered_json;
namespace fs = std::filesystem;

// Columns a line may take before a list or object is broken over several lines.
constexpr std::size_t kWidth = 100;

// A SceneBody level that is not set (sim/Scene.h).
constexpr int kUnsetLevel = -1;

std::string child(const std::string& path, std::string_view key) {
  return path.empty() ? std::string(key) : path + "." + std::string(key);
}

std::string element(const std::string& path, std::size_t i) {
  return path + "[" + std::to_string(i) + "]";
}

/// The context of one write: the folder paths are written relative to.
struct Writer {
  fs::path base;  // absolute and normalised, without a trailing separator; empty: none

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw InputError(detail::oneLine("cannot write scene: " + path + ": " + what));
  }

  Json number(double x, const std::string& path) const {
    if (!std::isfinite(x))
      fail(path, std::string("must be finite, got ") +
                     (std::isnan(x) ? "nan" : (x > 0 ? "inf" : "-inf")));
    return Json(x);
  }

  Json vec(const Vec3d& v, const std::string& path) const {
    Json out = Json::array();
    for (int i = 0; i < 3; ++i) out.push_back(number(v[i], element(path, i)));
    return out;
  }

  /// A string, checked to be valid UTF-8 (JSON text holds nothing else).
  Json text(const std::string& s, const std::string& path) const {
    Json out(s);
    try {
      (void)out.dump();
    } catch (const Json::exception&) {
      fail(path, "is not valid UTF-8");
    }
    return out;
  }

  /// A file path: relative to `base` where it lies under it, else absolute. With `model`, a
  /// relative form that would read as a built-in model is written absolute.
  Json file(const std::string& given, const std::string& path, bool model) const {
    if (given.empty()) fail(path, "must not be empty");
    const fs::path absolute = fs::absolute(fs::path(given)).lexically_normal();
    std::string out = absolute.string();
    if (!base.empty()) {
      const fs::path relative = absolute.lexically_relative(base);
      if (!relative.empty() && *relative.begin() != ".." && relative != ".") {
        const std::string r = relative.string();
        if (!(model && isBuiltinModelSpec(r))) out = r;
      }
    }
    return text(out, path);
  }
};

Json solverJson(const Writer& w, const SolverSettings& s) {
  Json out;
  out["tolerance"] = w.number(s.tolerance, "solver.tolerance");
  out["max_iterations"] = s.maxIterations;
  out["preconditioner"] = solverChoiceName(s.preconditioner);
  out["projection_history"] = s.projectionHistory;
  return out;
}

Json materialJson(const Writer& w, const SceneMaterial& m, const std::string& path) {
  Json out = Json::object();
  out["young_modulus"] = w.number(m.youngModulus, child(path, "young_modulus"));
  out["poisson_ratio"] = w.number(m.poissonRatio, child(path, "poisson_ratio"));
  out["density"] = w.number(m.density, child(path, "density"));
  const std::string d = child(path, "damping");
  out["damping"] = Json::array(
      {w.number(m.massDamping, element(d, 0)), w.number(m.stiffnessDamping, element(d, 1))});
  out["max_internal_level"] = m.maxInternalLevel;
  out["max_boundary_level"] = m.maxBoundaryLevel;
  return out;
}

Json bodyJson(const Writer& w, const SceneBody& b, const std::string& path) {
  if (b.volume)
    w.fail(child(path, "model"),
           "holds a label volume in memory; write it to a file (writeNrrd) and name that file");
  Json out;
  const bool builtin = isBuiltinModelSpec(b.model);
  out["model"] = builtin ? w.text(b.model, child(path, "model"))
                         : w.file(b.model, child(path, "model"), /*model=*/true);
  if (b.resolution) out["resolution"] = *b.resolution;
  out["element_level"] = b.elementLevel;
  if (b.finestLevel != kUnsetLevel) out["finest_level"] = b.finestLevel;
  if (b.frontLevel != kUnsetLevel) out["front_level"] = b.frontLevel;
  if (b.surfaceLevel != kUnsetLevel) out["surface_level"] = b.surfaceLevel;
  if (!b.materials.empty()) {
    const std::string p = child(path, "materials");
    Json mats = Json::object();
    for (const SceneMaterial& m : b.materials) {
      const std::string mp = child(p, m.name);
      if (m.name.empty()) w.fail(p, "a material name must not be empty");
      (void)w.text(m.name, mp);
      if (mats.contains(m.name)) w.fail(mp, "is given twice");
      mats[m.name] = materialJson(w, m, mp);
    }
    out["materials"] = std::move(mats);
  }
  if (!b.fixed.empty()) {
    const std::string p = child(path, "fixed");
    Json list = Json::array();
    for (std::size_t i = 0; i < b.fixed.size(); ++i) {
      const std::string bp = child(element(p, i), "box");
      Json box = Json::array({w.vec(b.fixed[i].lo, element(bp, 0)),
                              w.vec(b.fixed[i].hi, element(bp, 1))});
      list.push_back(Json{{"box", std::move(box)}});
    }
    out["fixed"] = std::move(list);
  }
  if (b.offset != Vec3d::Zero()) out["offset"] = w.vec(b.offset, child(path, "offset"));
  // The reader takes these keys for a label volume's path only.
  const bool volume = !builtin && isVolumePath(b.model);
  if (!volume) {
    if (!b.labels.empty()) w.fail(child(path, "labels"), "applies to a label volume only");
    if (b.minIsland != SceneBody{}.minIsland)
      w.fail(child(path, "min_island"), "applies to a label volume only");
    if (!b.labelNames.empty()) w.fail(child(path, "label_names"), "applies to a label volume only");
    return out;
  }
  if (!b.labels.empty()) {
    const std::string p = child(path, "labels");
    Json labels = Json::object();
    for (const LabelChoice& l : b.labels) {
      const std::string key = std::to_string(l.value);
      if (labels.contains(key)) w.fail(child(p, key), "label value chosen twice");
      labels[key] = w.text(l.name, child(p, key));
    }
    out["labels"] = std::move(labels);
  }
  out["min_island"] = b.minIsland;
  if (!b.labelNames.empty())
    out["label_names"] = w.file(b.labelNames, child(path, "label_names"), /*model=*/false);
  return out;
}

Json toolJson(const Writer& w, const SceneTool& tool, const std::string& path) {
  const bool probe = tool.kind == ToolKind::Probe;
  Json out;
  out["type"] = probe ? "probe" : "blade";
  if (probe) {
    out["radius"] = w.number(tool.radius, child(path, "radius"));
    if (tool.friction >= 0.0) out["friction"] = w.number(tool.friction, child(path, "friction"));
  } else if (tool.radius != 0.0 || tool.friction >= 0.0) {
    w.fail(path, "a blade has no radius or friction");
  }
  // A probe's keys are all spheres ("p") or all capsules ("a", "b"): docs/scenes.md, "Tools".
  bool sphere = probe;
  for (const ToolKey& k : tool.keys) sphere = sphere && k.pose.a == k.pose.b;
  const std::string p = child(path, "keys");
  Json keys = Json::array();
  for (std::size_t i = 0; i < tool.keys.size(); ++i) {
    const ToolKey& k = tool.keys[i];
    const std::string kp = element(p, i);
    Json key;
    key["t"] = w.number(k.t, child(kp, "t"));
    if (sphere) {
      key["p"] = w.vec(k.pose.a, child(kp, "p"));
    } else {
      key["a"] = w.vec(k.pose.a, child(kp, "a"));
      key["b"] = w.vec(k.pose.b, child(kp, "b"));
    }
    if (k.jump) key["jump"] = true;
    keys.push_back(std::move(key));
  }
  out["keys"] = std::move(keys);
  return out;
}

Json obstacleJson(const Writer& w, const Obstacle& o, const std::string& path) {
  Json out;
  switch (o.type) {
    case ObstacleType::Plane:
      out["type"] = "plane";
      out["point"] = w.vec(o.point, child(path, "point"));
      out["normal"] = w.vec(o.normal, child(path, "normal"));
      break;
    case ObstacleType::Box:
      out["type"] = "box";
      out["lo"] = w.vec(o.lo, child(path, "lo"));
      out["hi"] = w.vec(o.hi, child(path, "hi"));
      break;
    case ObstacleType::Mesh:
      out["type"] = "mesh";
      if (o.path.empty())
        w.fail(child(path, "path"),
               "a mesh obstacle made in memory has no file to name (Obstacle::path is empty)");
      out["path"] = w.file(o.path, child(path, "path"), /*model=*/false);
      break;
  }
  if (o.friction >= 0.0) out["friction"] = w.number(o.friction, child(path, "friction"));
  return out;
}

Json sceneJson(const Writer& w, const Scene& scene) {
  Json top;
  top["time_step"] = w.number(scene.timeStep, "time_step");
  top["gravity"] = w.vec(scene.gravity, "gravity");
  top["solver"] = solverJson(w, scene.solver);
  if (scene.frames) top["frames"] = *scene.frames;
  if (scene.view)
    top["view"] = Json::array({w.number((*scene.view)[0], "view[0]"),
                               w.number((*scene.view)[1], "view[1]")});
  Json bodies = Json::array();
  for (std::size_t i = 0; i < scene.bodies.size(); ++i)
    bodies.push_back(bodyJson(w, scene.bodies[i], element("bodies", i)));
  top["bodies"] = std::move(bodies);
  if (!scene.tools.empty()) {
    Json tools = Json::array();
    for (std::size_t i = 0; i < scene.tools.size(); ++i)
      tools.push_back(toolJson(w, scene.tools[i], element("tools", i)));
    top["tools"] = std::move(tools);
  }
  if (!scene.obstacles.empty()) {
    Json obstacles = Json::array();
    for (std::size_t i = 0; i < scene.obstacles.size(); ++i)
      obstacles.push_back(obstacleJson(w, scene.obstacles[i], element("obstacles", i)));
    top["obstacles"] = std::move(obstacles);
  }
  const ContactSettings& c = scene.contact;
  if (!c.keepSelfCandidates)
    w.fail("contact", "keepSelfCandidates off has no key in the scene format");
  Json contact;
  contact["stiffness"] = w.number(c.stiffness, "contact.stiffness");
  contact["self_collision"] = c.selfCollision;
  contact["friction"] = w.number(c.friction, "contact.friction");
  top["contact"] = std::move(contact);
  return top;
}

// ---- layout: small lists and objects on one line, the rest one member a line ----

/// Whether `v` may go on one line: it holds no list or object that holds an object (so a
/// tool, which holds its keys, is broken up, and a key, a box or a vector is not).
bool fitsOneLine(const Json& v) {
  if (!v.is_structured()) return true;
  for (const Json& c : v)
    if (c.is_structured())
      for (const Json& g : c)
        if (g.is_object()) return false;
  return true;
}

std::string oneLineText(const Json& v) {
  if (!v.is_structured()) return v.dump();
  std::string out = v.is_object() ? "{" : "[";
  bool first = true;
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (!first) out += ", ";
    first = false;
    if (v.is_object()) out += Json(it.key()).dump() + ": ";
    out += oneLineText(it.value());
  }
  return out + (v.is_object() ? "}" : "]");
}

/// Appends `v` starting at column `column`, its members indented by `indent` + 2.
void layOut(const Json& v, std::size_t indent, std::size_t column, std::string& out) {
  if (fitsOneLine(v)) {
    const std::string line = oneLineText(v);
    if (!v.is_structured() || column + line.size() <= kWidth) {
      out += line;
      return;
    }
  }
  const bool object = v.is_object();
  out += object ? "{\n" : "[\n";
  bool first = true;
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (!first) out += ",\n";
    first = false;
    out.append(indent + 2, ' ');
    std::size_t at = indent + 2;
    if (object) {
      const std::string key = Json(it.key()).dump() + ": ";
      out += key;
      at += key.size();
    }
    layOut(it.value(), indent + 2, at, out);
  }
  out += "\n";
  out.append(indent, ' ');
  out += object ? "}" : "]";
}

}  // namespace

std::string sceneText(const Scene& scene, const fs::path& baseDir) {
  Writer w;
  if (!baseDir.empty()) {
    w.base = fs::absolute(baseDir).lexically_normal();
    // "/a/b/" normalises to itself; relative paths are taken against "/a/b".
    if (!w.base.has_filename() && w.base != w.base.root_path()) w.base = w.base.parent_path();
  }
  std::string out;
  layOut(sceneJson(w, scene), 0, 0, out);
  return out + "\n";
}

}  // namespace voxcut
