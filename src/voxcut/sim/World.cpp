/// @file World.cpp
/// The world's facade (sim/World.h): construction, settings and clock, obstacles by handle,
/// and the frame as the list of its stages. Bodies are in BodyBuild.cpp, tools and their
/// motion in ToolMotion.cpp.

#include "voxcut/sim/World.h"

#include <algorithm>
#include <string>

#include "voxcut/sim/WorldChecks.h"
#include "voxcut/sim/WorldImpl.h"

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
    w.addBody(std::move(grids[i]), bodySettings(scene.bodies[i]));
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

// One frame, or nothing (docs/architecture.md, "Errors"): the world's rollback point kept up
// to date, the frame run, and on any failure the world brought back to where it was.
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

// One frame (docs/architecture.md, "One frame"): the tools' motion; refinement under resting
// fronts and coarsening; the cutting stage; then, beside the voxel octrees' deferred updates,
// the cut topology and surface, the contacts and each body's step.
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
