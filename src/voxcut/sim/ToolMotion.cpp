/// @file ToolMotion.cpp
/// The world's tools (sim/World.h): blades and probes added and removed, posed by the
/// application or driven by trajectories, placed without sweeping, recorded; and each frame,
/// where they go (frameMotion) and where they end with their reactions (finishTools).

#include "voxcut/sim/World.h"

#include <algorithm>
#include <string>

#include "voxcut/sim/WorldChecks.h"
#include "voxcut/sim/WorldImpl.h"

namespace voxcut {

// ---- tools ----

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

// ---- each frame ----

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

}  // namespace voxcut
