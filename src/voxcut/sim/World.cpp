/// @file World.cpp
/// The world's facade (sim/World.h): construction, bodies, tools and obstacles by handle, and
/// the frame as the list of its stages.

#include "voxcut/sim/World.h"

#include <algorithm>
#include <string>

#include "voxcut/sim/WorldChecks.h"
#include "voxcut/sim/WorldImpl.h"
#include "voxcut/voxel/Pieces.h"

namespace voxcut {

World::World(const WorldSettings& settings) : impl_(std::make_unique<Impl>()) {
  checkWorldSettings(settings);
  impl_->settings = settings;
}

World::~World() = default;

World::World(World&&) noexcept = default;

World& World::operator=(World&&) noexcept = default;

World World::fromScene(const Scene& scene, std::vector<VoxelGrid> grids,
                       const WorldSettings& base) {
  if (grids.size() != scene.bodies.size())
    throw InputError(scene.source + ": " + std::to_string(scene.bodies.size()) + " bodies but " +
                     std::to_string(grids.size()) + " voxel grids");
  WorldSettings s = base;
  s.timeStep = scene.timeStep;
  s.gravity = scene.gravity;
  s.solver = scene.solver;
  s.contact = scene.contact;
  World w;
  w.impl_->source = scene.source;
  w.impl_->check([&] { checkWorldSettings(s); });
  w.impl_->settings = s;
  // Tools first, so that each body sizes its fronts once.
  for (std::size_t i = 0; i < scene.tools.size(); ++i) {
    const SceneTool& t = scene.tools[i];
    w.impl_->check([&] { checkKeys(t.keys, "tools[" + std::to_string(i) + "].keys"); });
    const ToolId id = t.kind == ToolKind::Blade
                          ? w.addBlade(t.keys.front().pose)
                          : w.addProbe(t.radius, t.keys.front().pose, t.friction);
    w.setToolTrajectory(id, t.keys);
  }
  for (const Obstacle& o : scene.obstacles) w.addObstacle(o);
  for (std::size_t i = 0; i < grids.size(); ++i) {
    const SceneBody& sb = scene.bodies[i];
    BodySettings bs;
    bs.elementLevel = sb.elementLevel;
    bs.finestLevel = sb.finestLevel;
    bs.frontLevel = sb.frontLevel;
    bs.surfaceLevel = sb.surfaceLevel;
    bs.materials = sb.materials;
    bs.fixed = sb.fixed;
    w.addBody(std::move(grids[i]), bs);
  }
  return w;
}

const WorldSettings& World::settings() const {
  return impl_->settings;
}

int World::frame() const {
  return impl_->frame;
}

double World::time() const {
  return impl_->time();
}

// ---- bodies ----

BodyId World::addBody(VoxelGrid grid, const BodySettings& settings) {
  impl_->edited();
  Impl& w = *impl_;
  const WorldSettings& ws = w.settings;
  impl_->check([&] { checkBodySettings(settings); });
  impl_->check([&] { checkGrid(grid, "grid"); });
  SimBody& b = w.bodies.emplace_back();
  try {
    CutBodyParams cp;
    cp.useOctree = ws.useOctree;
    cp.octree = voxelOctreeParams(settings, grid);
    cp.deformation.startLevel = settings.elementLevel;
    cp.deformation.maxLevel = std::min(settings.elementLevel + 1, 7);
    cp.deformation.surfaceLevel = settings.surfaceLevel;
    b.settings = settings;
    b.elastic = elasticMaterials(settings, grid);
    b.cut = makeCutBody(std::move(grid), cp, ws.threaded);
    ImplicitEulerParams solver;
    solver.timeStep = ws.timeStep;
    solver.gravity = ws.gravity;
    solver.tolerance = ws.solver.tolerance;
    solver.maxIterations = ws.solver.maxIterations;
    solver.projectionHistory = ws.solver.projectionHistory;
    b.solverChoice = resolveSolver(ws.solver.preconditioner);
    solver.preconditioner = preconditionerOf(b.solverChoice);
    b.solver = ImplicitEuler(solver);
    w.rebuildModel(b);
    double stiffest = 0.0;
    for (const ElasticMaterial& m : b.elastic) stiffest = std::max(stiffest, m.youngModulus);
    b.contactStiffness = ws.contact.stiffness > 0.0 ? ws.contact.stiffness
                                                    : 10.0 * stiffest * b.cut.grid.voxelSize();
    b.fronts.resize(w.tools.size());
    b.frontSegments.assign(w.tools.size(), 0);
    DualContourParams dc;
    dc.threaded = ws.threaded;
    b.surface = ContouredSurface::build(b.cut.grid, dc);
    b.restDistance.build(b.cut.grid, kRestDistanceBand);
    w.embedVertices(b, nullptr);
    w.updateVertexPositions(b);
  } catch (...) {
    w.bodies.pop_back();
    throw;
  }
  return w.bodySlots.add();
}

void World::removeBody(BodyId body) {
  impl_->edited();
  Impl& w = *impl_;
  const std::size_t p = w.bodyAt(body);
  w.bodies.erase(w.bodies.begin() + static_cast<std::ptrdiff_t>(p));
  w.bodySlots.removeAt(p);
}

std::size_t World::bodyCount() const {
  return impl_->bodies.size();
}

std::vector<BodyId> World::bodies() const {
  return impl_->bodySlots.all();
}

bool World::contains(BodyId body) const {
  return impl_->bodySlots.find(body).has_value();
}

void World::setFixed(BodyId body, std::vector<FixedBox> fixed) {
  impl_->edited();
  SimBody& b = impl_->body(body);
  impl_->check([&] { checkFixedBoxes(fixed, "fixed"); });
  const bool had = !b.settings.fixed.empty();
  b.settings.fixed = std::move(fixed);
  if (had || !b.settings.fixed.empty())
    b.model.setFixed(b.settings.fixed.empty() ? std::vector<std::uint8_t>{} : Impl::fixedFlags(b));
}

void World::setMaterial(BodyId body, const SceneMaterial& material) {
  impl_->edited();
  SimBody& b = impl_->body(body);
  impl_->check([&] { checkMaterial(material, "material"); });
  const std::vector<std::string>& names = b.cut.grid.materialNames();
  const auto it = std::find(names.begin(), names.end(), material.name);
  if (it == names.end()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    throw InputError(impl_->prefix() + "material.name: the body has no material '" +
                     material.name + "' (it has: " + list + ")");
  }
  std::erase_if(b.settings.materials,
                [&](const SceneMaterial& m) { return m.name == material.name; });
  b.settings.materials.push_back(material);
  b.elastic = elasticMaterials(b.settings, b.cut.grid);
  impl_->rebuildModel(b);
}

BodyInfo World::bodyInfo(BodyId body) const {
  const SimBody& b = impl_->body(body);
  BodyInfo info;
  info.elements = b.cut.deformation.elementCount();
  info.nodes = b.cut.deformation.nodeCount();
  info.cutLinks = b.cutLinks;
  info.surfaceVertices = b.surface.vertexCount();
  info.surfaceTriangles = b.surface.triangleCount();
  info.voxelSize = b.cut.grid.voxelSize();
  info.materialNames = b.cut.grid.materialNames();
  info.solver = b.solverChoice;
  info.selfCandidateQueries = b.selfCandidates.queries;
  return info;
}

void World::setUseOctree(bool on) {
  impl_->edited();
  impl_->settings.useOctree = on;
  for (SimBody& b : impl_->bodies)
    setActivity(b.cut, on, voxelOctreeParams(b.settings, b.cut.grid), impl_->settings.threaded);
}

int World::pieces(BodyId body) const {
  return findPieces(impl_->body(body).cut.grid).count;
}

ToolId World::Impl::addTool(WorldTool t) {
  edited();
  t.longest = (t.pose.b - t.pose.a).norm();
  t.slot = std::make_shared<HapticSlot>();
  t.haptic.centre = t.slot->model.centre = 0.5 * (t.pose.a + t.pose.b);
  if (recording) t.recorded.push_back({time(), t.pose});
  tools.push_back(std::move(t));
  for (SimBody& b : bodies) {
    b.fronts.resize(tools.size());
    b.frontSegments.resize(tools.size(), 0);
  }
  return toolSlots.add();
}

ToolId World::addBlade(const BladePose& pose) {
  impl_->check([&] { checkBladePose(pose, "pose"); });
  WorldTool t;
  t.kind = ToolKind::Blade;
  t.pose = pose;
  return impl_->addTool(std::move(t));
}

ToolId World::addProbe(double radius, const BladePose& pose, double friction) {
  impl_->check([&] { checkRadius(radius, "radius"); });
  impl_->check([&] { checkPose(pose, "pose"); });
  impl_->check([&] { checkFriction(friction, "friction", true); });
  WorldTool t;
  t.kind = ToolKind::Probe;
  t.radius = radius;
  t.friction = friction;
  t.pose = pose;
  return impl_->addTool(std::move(t));
}

void World::removeTool(ToolId tool) {
  impl_->edited();
  Impl& w = *impl_;
  const std::size_t p = w.toolAt(tool);
  const auto at = static_cast<std::ptrdiff_t>(p);
  w.tools.erase(w.tools.begin() + at);
  for (SimBody& b : w.bodies) {
    b.fronts.erase(b.fronts.begin() + at);
    b.frontSegments.erase(b.frontSegments.begin() + at);
  }
  w.toolSlots.removeAt(p);
}

std::size_t World::toolCount() const {
  return impl_->tools.size();
}

std::vector<ToolId> World::tools() const {
  return impl_->toolSlots.all();
}

bool World::contains(ToolId tool) const {
  return impl_->toolSlots.find(tool).has_value();
}

ToolKind World::toolKind(ToolId tool) const {
  return impl_->tool(tool).kind;
}

double World::toolRadius(ToolId tool) const {
  return impl_->tool(tool).radius;
}

BladePose World::toolPose(ToolId tool) const {
  return impl_->tool(tool).pose;
}

ToolReaction World::toolReaction(ToolId tool) const {
  return impl_->tool(tool).reaction;
}

void World::setToolPose(ToolId tool, const BladePose& pose) {
  WorldTool& t = impl_->tool(tool);
  impl_->check([&] { (t.kind == ToolKind::Blade ? checkBladePose : checkPose)(pose, "pose"); });
  if (!t.keys.empty()) impl_->edited();  // a trajectory stopped: not a logged control
  t.keys.clear();
  t.target = pose;
  t.longest = std::max(t.longest, (pose.b - pose.a).norm());
}

void World::Impl::place(std::size_t ti, const BladePose& pose) {
  edited();
  WorldTool& t = tools[ti];
  t.pose = pose;
  t.longest = std::max(t.longest, (pose.b - pose.a).norm());
  t.reaction = ToolReaction{};
  // A blade's cut fronts start afresh from here, as for a new blade.
  for (SimBody& b : bodies) b.fronts[ti] = BladeFront{};
  // A probe's force model forgets the contact it had; the haptic call starts from nothing.
  t.haptic = HapticModel{};
  t.haptic.centre = 0.5 * (pose.a + pose.b);
  t.haptic.radius = t.radius;
  {
    const std::lock_guard<std::mutex> lock(t.slot->mutex);
    t.slot->model = t.haptic;
    t.slot->offset = Vec3d::Zero();
    t.slot->fade = 0.0;
    t.slot->wasAsked = false;
  }
  if (recording) {
    ToolKey& last = t.recorded.back();
    if (last.jump && last.t == time())
      last.pose = pose;
    else
      t.recorded.push_back({time(), pose, true});
  }
}

void World::placeTool(ToolId tool, const BladePose& pose) {
  const std::size_t ti = impl_->toolAt(tool);
  impl_->check([&] {
    (impl_->tools[ti].kind == ToolKind::Blade ? checkBladePose : checkPose)(pose, "pose");
  });
  WorldTool& t = impl_->tools[ti];
  t.keys.clear();
  t.target.reset();
  impl_->place(ti, pose);
}

void World::setToolTrajectory(ToolId tool, std::vector<ToolKey> keys) {
  impl_->edited();
  WorldTool& t = impl_->tool(tool);
  impl_->check([&] {
    checkKeys(keys, "keys");
    if (t.kind == ToolKind::Blade)
      for (std::size_t k = 0; k < keys.size(); ++k)
        checkBladePose(keys[k].pose, "keys[" + std::to_string(k) + "].pose");
  });
  for (const ToolKey& k : keys) t.longest = std::max(t.longest, (k.pose.b - k.pose.a).norm());
  t.keys = std::move(keys);
  t.target.reset();
  t.pose = bladePoseAt(t.keys, impl_->time());
}

void World::setRecording(bool on) {
  impl_->edited();
  impl_->recording = on;
  if (!on) return;
  for (WorldTool& t : impl_->tools) t.recorded.assign(1, ToolKey{impl_->time(), t.pose});
}

const std::vector<ToolKey>& World::recording(ToolId tool) const {
  return impl_->tool(tool).recorded;
}

// ---- obstacles ----

ObstacleId World::addObstacle(const Obstacle& obstacle) {
  impl_->edited();
  impl_->check([&] { checkObstacle(obstacle, "obstacle"); });
  impl_->obstacles.push_back(obstacle);
  return impl_->obstacleSlots.add();
}

void World::removeObstacle(ObstacleId obstacle) {
  impl_->edited();
  Impl& w = *impl_;
  const std::size_t p = w.obstacleAt(obstacle);
  w.obstacles.erase(w.obstacles.begin() + static_cast<std::ptrdiff_t>(p));
  w.obstacleSlots.removeAt(p);
}

std::size_t World::obstacleCount() const {
  return impl_->obstacles.size();
}

std::vector<ObstacleId> World::obstacles() const {
  return impl_->obstacleSlots.all();
}

bool World::contains(ObstacleId obstacle) const {
  return impl_->obstacleSlots.find(obstacle).has_value();
}

const Obstacle& World::obstacle(ObstacleId obstacle) const {
  return impl_->obstacles[impl_->obstacleAt(obstacle)];
}

// ---- the frame ----

// Where each tool goes this frame: its trajectory's pose at the frame's end, or the pose the
// application set, or where it is; and what the bodies are pressed against (the obstacles,
// then the probes at their end pose).
World::Impl::Motion World::Impl::frameMotion(ContactShapes& shapes) {
  const double t1 = (frame + 1) * settings.timeStep;
  Motion motion;
  shapes.obstacles = &obstacles;
  const double mu = settings.contact.friction;
  for (const Obstacle& o : obstacles) {
    shapes.friction.push_back(o.friction >= 0.0 ? o.friction : mu);
    shapes.velocity.push_back(Vec3d::Zero());
  }
  for (std::size_t ti = 0; ti < tools.size(); ++ti) {
    // A trajectory's jump in this frame's span places the tool at its start.
    if (const ToolKey* jump =
            tools[ti].keys.empty() ? nullptr : jumpIn(tools[ti].keys, time(), t1))
      place(ti, jump->pose);
    const WorldTool& t = tools[ti];
    motion.from.push_back(t.pose);
    motion.to.push_back(!t.keys.empty() ? bladePoseBefore(t.keys, t1) : t.target.value_or(t.pose));
    if (t.kind == ToolKind::Probe) {
      shapes.probes.push_back({motion.to.back().a, motion.to.back().b, t.radius});
      shapes.probeTool.push_back(ti);
      shapes.friction.push_back(t.friction >= 0.0 ? t.friction : mu);
      const BladePose& from = motion.from.back();
      const BladePose& to = motion.to.back();
      shapes.velocity.push_back((0.5 * (to.a + to.b) - 0.5 * (from.a + from.b)) /
                                settings.timeStep);
    }
  }
  return motion;
}

// After the frame: each tool where it went, with the reaction the bodies pushed it with, its
// haptic model published and its pose recorded.
void World::Impl::finishTools(const Motion& motion, const FrameReport& report) {
  for (std::size_t ti = 0; ti < tools.size(); ++ti) {
    WorldTool& t = tools[ti];
    t.pose = motion.to[ti];
    t.target.reset();
    t.reaction = report.toolReactions[ti];
    if (t.kind == ToolKind::Probe) publishHaptic(t, settings.timeStep);
    if (recording) t.recorded.push_back({time(), t.pose});
  }
}

// One frame (docs/architecture.md, "One frame"): the tools' motion; refinement under resting
// fronts and coarsening; the cutting stage; then, beside the voxel octrees' deferred updates,
// the cut topology and surface, the contacts and each body's step.
FrameReport World::step() {
  Impl& w = *impl_;
  const Timer timer;
  w.beforeStep();
  try {
    FrameReport report = w.runFrame();
    w.failFrame = -1;
    Checkpoint& c = w.checkpoint;
    c.frameMs += (report.totalMs - c.frameMs) / static_cast<double>(c.controls.size());
    report.totalMs = timer.ms();  // with the rollback point's copy, when one was taken
    return report;
  } catch (...) {
    w.rollBack();
    w.failFrame = -1;
    throw;
  }
}

FrameReport World::Impl::runFrame() {
  const Timer frameTimer;
  Frame f;
  f.report.frame = frame;
  f.report.stageMs.assign(kStageCount, 0.0);
  f.report.obstacleForces.assign(obstacles.size(), Vec3d::Zero());
  f.report.toolReactions.assign(tools.size(), ToolReaction{});
  contacts.clear();
  f.motion = frameMotion(f.shapes);
  const std::size_t n = bodies.size();
  f.cuts.resize(n);
  f.ends.resize(n);
  for (SimBody& b : bodies) {
    refineRestingFronts(b, f);
    coarsenBody(b, f);
  }
  for (std::size_t i = 0; i < n; ++i) {
    f.cuts[i] = cutBody(bodies[i], f.ends[i], f);
    bodies[i].cutLinks += f.cuts[i].size();
    f.report.cutLinks += f.cuts[i].size();
    f.report.positionedVoxels += bodies[i].cutWork.positionedVoxels;
    f.report.testedLinks +=
        bodies[i].cutWork.testedLinks + bodies[i].cutWork.subdivisionTestedLinks;
  }
  // The octrees' deferred updates run beside the rest of the frame (the paper's figure 3):
  // they touch only each body's voxel octree, which nothing after the cut reads.
  std::vector<double> deferredMs(n, 0.0);
  parallelInvoke(
      [&] {
        for (std::size_t i = 0; i < n; ++i)
          deferredMs[i] = runDeferredUpdates(bodies[i].cut, settings.threaded);
      },
      [&] {
        for (std::size_t i = 0; i < n; ++i) afterCut(bodies[i], f.cuts[i], f.ends[i], f);
        std::vector<BodyContactSet> bodyContacts = findBodyContactsAll(f);
        for (std::size_t i = 0; i < n; ++i) solvePhase(bodies[i], std::move(bodyContacts[i]), f);
      },
      settings.threaded);
  for (const double ms : deferredMs) f.ms(kDeferredUpdates) += ms;
  ++frame;
  finishTools(f.motion, f.report);
  f.report.time = time();
  f.report.totalMs = frameTimer.ms();
  return std::move(f.report);
}

}  // namespace voxcut
