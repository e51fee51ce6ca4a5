#include "Session.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "voxcut/core/Error.h"
#include "voxcut/io/Recording.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"

namespace voxcut::view {
namespace fs = std::filesystem;
namespace {

nlohmann::ordered_json vec(const Vec3d& v) {
  return nlohmann::ordered_json::array({v.x(), v.y(), v.z()});
}

/// The occupied voxels' bounds over every grid.
Eigen::AlignedBox3d occupiedBounds(const std::vector<VoxelGrid>& grids) {
  Eigen::AlignedBox3d box;
  for (const VoxelGrid& g : grids)
    for (std::size_t v = 0; v < g.voxelCount(); ++v)
      if (g.occupied(v)) box.extend(g.position(v));
  return box;
}

}  // namespace

Session Session::open(const std::string& what, const OpenOptions& options) {
  if (what.empty()) throw InputError("nothing to open: give a scene (.json), a model or a mesh");
  Session s;
  s.source_ = what;
  s.useOctree_ = options.useOctree;
  SceneBodiesParams bodies;
  bodies.progress = options.progress;
  bodies.useOctree = options.useOctree;
  if (fs::path(what).extension() == ".json") {
    const std::string text = readSceneText(what);
    const fs::path dir = fs::absolute(fs::path(what)).parent_path();
    s.scene_ = parseScene(text, what, dir);
    s.json_ = nlohmann::ordered_json::parse(text);
    // Paths made absolute, so that a saved recording works from anywhere.
    for (std::size_t b = 0; b < s.scene_.bodies.size(); ++b) {
      s.json_["bodies"][b]["model"] = s.scene_.bodies[b].model;
      if (!s.scene_.bodies[b].labelNames.empty())
        s.json_["bodies"][b]["label_names"] = s.scene_.bodies[b].labelNames;
    }
    if (s.json_.contains("obstacles"))
      for (auto& o : s.json_["obstacles"])
        if (o["type"] == "mesh")
          o["path"] = fs::absolute(dir / o["path"].get<std::string>()).lexically_normal().string();
    s.grids_ = voxelizeSceneBodies(s.scene_, bodies);
    s.bounds_ = occupiedBounds(s.grids_);
  } else {
    // A model alone: held at its lowest tenth, on a floor, under gravity.
    std::string spec = what;
    if (!isBuiltinModelSpec(spec) && fs::exists(spec)) spec = fs::absolute(spec).string();
    nlohmann::ordered_json j;
    j["description"] = "voxcut-view: " + what;
    j["time_step"] = 0.004;
    j["gravity"] = vec(Vec3d(0, -9.81, 0));
    j["bodies"] = nlohmann::ordered_json::array();
    nlohmann::ordered_json body;
    body["model"] = spec;
    body["resolution"] = options.resolution;
    j["bodies"].push_back(body);
    const Scene first = parseScene(j.dump(), what, fs::current_path());
    s.grids_ = voxelizeSceneBodies(first, bodies);
    s.bounds_ = occupiedBounds(s.grids_);
    const Vec3d lo = s.bounds_.min(), hi = s.bounds_.max();
    const double pad = s.bounds_.diagonal().norm();
    const double base = lo.y() + 0.1 * (hi.y() - lo.y());
    nlohmann::ordered_json fixed;
    fixed["box"] = nlohmann::ordered_json::array(
        {vec(lo - Vec3d::Constant(pad)), vec(Vec3d(hi.x() + pad, base, hi.z() + pad))});
    j["bodies"][0]["fixed"] = nlohmann::ordered_json::array();
    j["bodies"][0]["fixed"].push_back(fixed);
    const double h = 0.5 * s.grids_[0].voxelSize();
    nlohmann::ordered_json floor;
    floor["type"] = "plane";
    floor["point"] = vec(Vec3d(s.bounds_.center().x(), lo.y() - h, s.bounds_.center().z()));
    floor["normal"] = vec(Vec3d::UnitY());
    j["obstacles"] = nlohmann::ordered_json::array();
    j["obstacles"].push_back(floor);
    s.json_ = j;
    s.scene_ = parseScene(j.dump(), what, fs::current_path());
  }
  if (s.bounds_.isEmpty()) throw InputError(what + ": no material to simulate");
  const double size = std::max(s.bounds_.diagonal().norm(), 1e-3);
  s.bladeLength_ = 0.6 * size;
  // Driving the scene's own blade, the mouse keeps its length: a blade's cut front is sampled
  // by the longest its trajectory makes it, and a replay of the recording must sample the
  // same way.
  for (const SceneTool& t : s.scene_.tools)
    if (t.kind == ToolKind::Blade) {
      double longest = 0.0;
      for (const ToolKey& k : t.keys) longest = std::max(longest, (k.pose.b - k.pose.a).norm());
      s.bladeLength_ = longest;
      break;
    }
  s.probeRadius_ = 0.04 * size;
  const Vec3d c = s.bounds_.center();
  // Far enough above that a view of the bodies does not show them.
  const double above = s.bounds_.max().y() + 20.0 * size;
  s.bladePark_ = {Vec3d(c.x() - 0.5 * s.bladeLength_, above, c.z()),
                  Vec3d(c.x() + 0.5 * s.bladeLength_, above, c.z())};
  s.probePark_.a = s.probePark_.b = Vec3d(c.x() + size, above, c.z());
  s.sceneTools_ = s.scene_.tools.size();
  s.addBlade_ = std::none_of(s.scene_.tools.begin(), s.scene_.tools.end(),
                             [](const SceneTool& t) { return t.kind == ToolKind::Blade; });
  s.addProbe_ = std::none_of(s.scene_.tools.begin(), s.scene_.tools.end(),
                             [](const SceneTool& t) { return t.kind == ToolKind::Probe; });
  s.build();
  return s;
}

void Session::build() {
  WorldSettings base;
  base.useOctree = useOctree_;
  world_ = World::fromScene(scene_, grids_, base);
  blade_ = probe_ = ToolId{};
  for (const ToolId t : world_.tools()) {
    if (world_.toolKind(t) == ToolKind::Blade && !blade_.valid()) blade_ = t;
    if (world_.toolKind(t) == ToolKind::Probe && !probe_.valid()) probe_ = t;
  }
  if (addBlade_) blade_ = world_.addBlade(bladePark_);
  if (addProbe_) probe_ = world_.addProbe(probeRadius_, probePark_);
  world_.setRecording(true);
  recent_ = undo_ = WorldSnapshot{};
  cutting_ = false;
}

void Session::apply(const std::vector<ToolCommand>& commands) {
  for (const ToolCommand& c : commands) {
    if (!world_.contains(c.tool)) continue;
    if (c.place)
      world_.placeTool(c.tool, c.pose);
    else
      world_.setToolPose(c.tool, c.pose);
  }
}

FrameReport Session::step() {
  if (!cutting_ && (recent_.empty() || world_.frame() - recent_.frame() >= kUndoEvery)) {
    // Let go first: the world then copies into the memory it held (no page faults).
    recent_ = WorldSnapshot{};
    recent_ = world_.snapshot();
  }
  FrameReport report = world_.step();
  const bool cut = report.cutLinks > 0;
  if (cut && !cutting_) undo_ = recent_;
  cutting_ = cut;
  return report;
}

bool Session::undoCut() {
  if (undo_.empty()) return false;
  world_.restore(undo_);
  recent_ = undo_;
  undo_ = WorldSnapshot{};
  cutting_ = false;
  return true;
}

void Session::reset() {
  build();
}

void Session::setUseOctree(bool on) {
  useOctree_ = on;
  world_.setUseOctree(on);
}

std::string Session::recordedScene() const {
  nlohmann::ordered_json j = json_;
  const nlohmann::ordered_json recording = nlohmann::ordered_json::parse(recordingText(world_));
  nlohmann::ordered_json tools = recording["tools"];
  // What the recording does not hold of the scene's own tools.
  for (std::size_t t = 0; t < sceneTools_ && t < tools.size(); ++t)
    if (json_["tools"][t].contains("friction"))
      tools[t]["friction"] = json_["tools"][t]["friction"];
  j["tools"] = tools;
  if (world_.frame() > 0)
    j["frames"] = world_.frame();
  else
    j.erase("frames");
  const std::string what = j.contains("description") ? j["description"].get<std::string>() : "";
  j["description"] = what + (what.empty() ? "" : " ") + "(tools as recorded in voxcut-view)";
  return j.dump(1) + "\n";
}

void Session::saveRecordedScene(const std::string& path) const {
  const std::string text = recordedScene();
  const std::string temp = path + ".part";
  {
    std::ofstream out(temp, std::ios::binary);
    out << text;
    out.close();
    if (!out) {
      std::error_code ec;
      fs::remove(temp, ec);
      throw InputError(path + ": cannot write");
    }
  }
  std::error_code ec;
  fs::rename(temp, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw InputError(path + ": cannot write (" + ec.message() + ")");
  }
}

}  // namespace voxcut::view
