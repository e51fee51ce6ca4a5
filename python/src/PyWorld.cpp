#include "PyWorld.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "voxcut/core/Error.h"
#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/io/SceneWriter.h"
#include "voxcut/io/VolumeWriter.h"
#include "voxcut/voxel/LabelResample.h"

namespace voxcut::python {

PyWorld::PyWorld(const WorldSettings& settings) : world(settings) {}

std::shared_ptr<PyWorld> PyWorld::fromScene(const std::string& path, const WorldSettings& base) {
  const Scene scene = readScene(path);
  SceneBodiesParams params;
  params.threaded = base.threaded;
  params.useOctree = base.useOctree;
  std::vector<VoxelGrid> grids = voxelizeSceneBodies(scene, params);
  auto w = std::make_shared<PyWorld>(WorldSettings{});
  w->world = World::fromScene(scene, std::move(grids), base);
  const std::vector<BodyId> ids = w->world.bodies();
  for (std::size_t i = 0; i < ids.size(); ++i) w->bodies_.emplace_back(ids[i], scene.bodies[i]);
  const std::vector<ToolId> tools = w->world.tools();
  for (std::size_t i = 0; i < tools.size(); ++i)
    w->frictions_.emplace_back(tools[i], scene.tools[i].friction);
  w->sceneSource_ = path;
  return w;
}

PyWorld::Guard::Guard(PyWorld& w) : lock_(w.mutex_, std::try_to_lock) {
  if (!lock_.owns_lock())
    throw BusyError("the world is busy: another thread is stepping it (one call at a time)");
}

PyWorld::ToolEdit::ToolEdit(PyWorld& w) : guard_(w), tools_(w.tools_) {}

void PyWorld::refuseWhileViewed(const char* what) const {
  const int n = views_.load();
  if (n > 0)
    throw BusyError(std::string(what) + ": refused while " + std::to_string(n) +
                    " zero-copy surface view(s) of this world are alive (delete the view and "
                    "its arrays first, or read copies)");
}

void PyWorld::check(BodyId id) const {
  if (!world.contains(id)) throw StaleHandleError("the body handle names no body of this world "
                                                  "(it was removed, or restored away)");
}
void PyWorld::check(ToolId id) const {
  if (!world.contains(id)) throw StaleHandleError("the tool handle names no tool of this world "
                                                  "(it was removed, or restored away)");
}
void PyWorld::check(ObstacleId id) const {
  if (!world.contains(id))
    throw StaleHandleError("the obstacle handle names no obstacle of this world (it was "
                           "removed, or restored away)");
}

void PyWorld::notReplayable(const std::string& why) {
  if (recording_ && notReplayable_.empty()) notReplayable_ = why;
}

BodyId PyWorld::addBody(SceneBody spec) {
  refuseWhileViewed("add_body");
  Scene scene;
  scene.source = "add_body";
  scene.bodies.push_back(spec);
  SceneBodiesParams params;
  params.threaded = world.settings().threaded;
  params.useOctree = world.settings().useOctree;
  std::vector<VoxelGrid> grids = voxelizeSceneBodies(scene, params);
  const BodyId id = world.addBody(std::move(grids.front()), bodySettings(spec));
  bodies_.emplace_back(id, std::move(spec));
  notReplayable("a body was added after recording started");
  return id;
}

void PyWorld::removeBody(BodyId id) {
  check(id);
  refuseWhileViewed("remove");
  world.removeBody(id);
  std::erase_if(bodies_, [&](const auto& b) { return b.first == id; });
  notReplayable("a body was removed after recording started");
}

SceneMaterial PyWorld::material(BodyId id, const std::string& name) const {
  return sceneMaterial(bodySpec(id).materials, name);
}

void PyWorld::setMaterial(BodyId id, const SceneMaterial& material) {
  check(id);
  refuseWhileViewed("set_material");
  // The voxel octree's levels are fixed when the body is built (World::setMaterial): a
  // change would not take effect, and a saved scene would then build another body.
  const SceneMaterial now = this->material(id, material.name);
  if (material.maxInternalLevel != now.maxInternalLevel ||
      material.maxBoundaryLevel != now.maxBoundaryLevel)
    throw InputError("set_material('" + material.name +
                     "'): max_internal_level and max_boundary_level are fixed when the body is "
                     "added (it has " + std::to_string(now.maxInternalLevel) + " and " +
                     std::to_string(now.maxBoundaryLevel) + ")");
  world.setMaterial(id, material);
  for (auto& [bid, spec] : bodies_) {
    if (bid != id) continue;
    std::erase_if(spec.materials, [&](const SceneMaterial& m) { return m.name == material.name; });
    spec.materials.push_back(material);
  }
  notReplayable("a material was changed after recording started");
}

void PyWorld::setFixed(BodyId id, std::vector<FixedBox> fixed) {
  check(id);
  refuseWhileViewed("fixed");
  world.setFixed(id, fixed);
  for (auto& [bid, spec] : bodies_)
    if (bid == id) spec.fixed = std::move(fixed);
  notReplayable("fixed boxes were changed after recording started");
}

ToolId PyWorld::addBlade(const BladePose& pose) {
  const ToolId id = world.addBlade(pose);
  notReplayable("a tool was added after recording started");
  return id;
}

ToolId PyWorld::addProbe(double radius, const BladePose& pose, double friction) {
  const ToolId id = world.addProbe(radius, pose, friction);
  frictions_.emplace_back(id, friction);
  notReplayable("a tool was added after recording started");
  return id;
}

void PyWorld::removeTool(ToolId id) {
  check(id);
  world.removeTool(id);
  notReplayable("a tool was removed after recording started");
}

ObstacleId PyWorld::addObstacle(const Obstacle& obstacle) {
  const ObstacleId id = world.addObstacle(obstacle);
  notReplayable("an obstacle was added after recording started");
  return id;
}

void PyWorld::removeObstacle(ObstacleId id) {
  check(id);
  world.removeObstacle(id);
  notReplayable("an obstacle was removed after recording started");
}

void PyWorld::setToolTrajectory(ToolId id, std::vector<ToolKey> keys) {
  check(id);
  world.setToolTrajectory(id, std::move(keys));
}

FrameReport PyWorld::step(int frames) {
  refuseWhileViewed("step");
  if (frames < 1) throw InputError("step: n must be at least 1, got " + std::to_string(frames));
  FrameReport report;
  for (int f = 0; f < frames; ++f) report = world.step();
  return report;
}

HapticAnswer PyWorld::haptic(ToolId id, const BladePose& pose, bool& busy) const noexcept {
  std::shared_lock<std::shared_mutex> lock(tools_, std::try_to_lock);
  busy = !lock.owns_lock();
  if (busy) return {};
  return world.hapticForce(id, pose);
}

PySnapshot PyWorld::snapshot() {
  PySnapshot s;
  s.snapshot = world.snapshot();
  s.bodies = bodies_;
  s.owner = this;
  return s;
}

void PyWorld::restore(const PySnapshot& snapshot) {
  refuseWhileViewed("restore");
  world.restore(snapshot.snapshot);
  bodies_ = snapshot.bodies;
  notReplayable("the world was restored after recording started");
}

void PyWorld::setRecording(bool on) {
  world.setRecording(on);
  recording_ = on;
  recordingStart = world.frame();
  notReplayable_.clear();
}

const SceneBody& PyWorld::bodySpec(BodyId id) const {
  check(id);
  for (const auto& [bid, spec] : bodies_)
    if (bid == id) return spec;
  throw StaleHandleError("the body handle names no body of this world");
}

double PyWorld::toolFriction(ToolId id) const {
  for (const auto& [tid, f] : frictions_)
    if (tid == id) return f;
  return -1.0;
}

void PyWorld::saveScene(const std::string& path, int frames) const {
  const std::string what = "save_scene('" + path + "')";
  if (!recording_)
    throw InputError(what + ": nothing recorded: call start_recording() before the first step");
  if (recordingStart != 0)
    throw InputError(what + ": recording started at frame " + std::to_string(recordingStart) +
                     ", not at the start: a scene replays a run from frame 0");
  if (!notReplayable_.empty())
    throw InputError(what + ": the run cannot be replayed from a scene: " + notReplayable_);
  const std::filesystem::path target = std::filesystem::absolute(path);
  const std::filesystem::path dir = target.parent_path();
  const WorldSettings& s = world.settings();
  Scene scene;
  scene.source = path;
  scene.timeStep = s.timeStep;
  scene.gravity = s.gravity;
  scene.solver = s.solver;
  scene.contact = s.contact;
  if (frames > 0) scene.frames = frames;
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    SceneBody b = bodies_[i].second;
    if (b.volume) {
      // The application's own volume goes beside the scene, as a file the scene names.
      const std::filesystem::path file =
          dir / (target.stem().string() + ".body" + std::to_string(i) + ".nrrd");
      writeNrrd(*b.volume, file.string());
      // The file keeps values, not names: the scene names the labels as the body has them.
      if (b.labels.empty()) b.labels = defaultLabelChoices(*b.volume);
      b.model = file.lexically_normal().string();
      b.volume.reset();
    }
    scene.bodies.push_back(std::move(b));
  }
  for (const ToolId t : world.tools()) {
    SceneTool tool;
    tool.kind = world.toolKind(t);
    tool.radius = world.toolRadius(t);
    if (tool.kind == ToolKind::Probe) tool.friction = toolFriction(t);
    tool.keys = world.recording(t);
    if (tool.keys.empty()) tool.keys.push_back({world.time(), world.toolPose(t), false});
    scene.tools.push_back(std::move(tool));
  }
  for (const ObstacleId o : world.obstacles()) scene.obstacles.push_back(world.obstacle(o));
  const std::string text = sceneText(scene, dir);
  const std::string tmp = target.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw InputError(what + ": cannot write " + tmp);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, target, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw InputError(what + ": cannot write the scene: " + ec.message());
  }
}

}  // namespace voxcut::python
