/// @file Snapshots.cpp
/// Snapshots and the step that either finishes or changes nothing (docs/architecture.md,
/// "Snapshots" and "Errors"). A snapshot is a copy of the world's state (WorldState); restoring
/// copies it back into the world's own memory. A failed step goes back through the world's
/// checkpoint: the state at some earlier frame's start and the tools' controls of each frame
/// since, run again. Results do not depend on timing or threads, so the frames run again give
/// the world before the failed step bit for bit, and the copy need not be taken every frame.

#include <algorithm>
#include <utility>

#include "voxcut/core/Timer.h"
#include "voxcut/sim/WorldImpl.h"
#include "voxcut/sim/WorldTesting.h"

namespace voxcut {

WorldSnapshot::WorldSnapshot() = default;
WorldSnapshot::~WorldSnapshot() = default;
WorldSnapshot::WorldSnapshot(const WorldSnapshot&) = default;
WorldSnapshot& WorldSnapshot::operator=(const WorldSnapshot&) = default;
WorldSnapshot::WorldSnapshot(WorldSnapshot&&) noexcept = default;
WorldSnapshot& WorldSnapshot::operator=(WorldSnapshot&&) noexcept = default;

bool WorldSnapshot::empty() const {
  return state_ == nullptr;
}

int WorldSnapshot::frame() const {
  return state_ ? state_->frame : 0;
}

double WorldSnapshot::time() const {
  return state_ ? state_->frame * state_->settings.timeStep : 0.0;
}

WorldSnapshot World::snapshot() {
  Impl& w = *impl_;
  WorldSnapshot s;
  const Timer timer;
  s.state_ = w.copyState();
  // The world's rollback point from now on: nothing to run again to reach it.
  w.useAsCheckpoint(s.state_);
  w.checkpoint.copyMs = timer.ms();
  return s;
}

std::shared_ptr<WorldState> World::Impl::copyState() {
  // Into memory of the world's own when it has some that no snapshot shares (a copy into
  // fresh memory costs its page faults, several times the copy).
  Checkpoint& c = checkpoint;
  std::shared_ptr<WorldState> into = std::exchange(c.spare, nullptr);
  if (into == nullptr && c.state != nullptr && c.state.use_count() == 1)
    into = std::const_pointer_cast<WorldState>(std::exchange(c.state, nullptr));
  if (into == nullptr) return std::make_shared<WorldState>(static_cast<const WorldState&>(*this));
  *into = static_cast<const WorldState&>(*this);
  return into;
}

void World::restore(const WorldSnapshot& snapshot) {
  Impl& w = *impl_;
  if (snapshot.empty()) throw InputError(w.prefix() + "snapshot: empty (never taken)");
  const WorldState& from = *snapshot.state_;
  // Surface revisions start above every one this world has given out: a reader holding one
  // gets the whole surface (SurfaceChanges::full), never the changes of another history.
  for (const SimBody& b : w.bodies)
    w.surfaceRevisionHigh = std::max(w.surfaceRevisionHigh, b.surfaceRevision);
  for (const SimBody& b : from.bodies)
    w.surfaceRevisionHigh = std::max(w.surfaceRevisionHigh, b.surfaceRevision);
  w.assignState(from, false);
  for (SimBody& b : w.bodies) {
    b.surfaceRevision = w.surfaceRevisionHigh + 1;
    b.surfaceLog.clear();
  }
  ++w.surfaceRevisionHigh;
  // Each tool its own haptic slot again, holding the restored force model.
  for (WorldTool& t : w.tools) {
    auto slot = std::make_shared<HapticSlot>();
    slot->model = t.haptic;
    t.slot = std::move(slot);
  }
  w.useAsCheckpoint(snapshot.state_);
}

void World::Impl::useAsCheckpoint(std::shared_ptr<const WorldState> state) {
  Checkpoint& c = checkpoint;
  if (c.state != nullptr && c.state.use_count() == 1)
    c.spare = std::const_pointer_cast<WorldState>(std::move(c.state));
  c.state = std::move(state);
  c.valid = true;
  c.controls.clear();
  c.frameMs = 0.0;
}

void World::Impl::assignState(const WorldState& from, bool keepSlots) {
  settings = from.settings;
  source = from.source;
  bodies = from.bodies;
  obstacles = from.obstacles;
  bodySlots.restoreFrom(from.bodySlots);
  obstacleSlots.restoreFrom(from.obstacleSlots);
  contacts = from.contacts;
  frame = from.frame;
  recording = from.recording;
  if (keepSlots) {
    // The same tools as the checkpoint's (an edit would have dropped it): only what frames
    // change is assigned, as haptic threads read the rest and the slots meanwhile.
    for (std::size_t ti = 0; ti < tools.size(); ++ti)
      static_cast<ToolState&>(tools[ti]) = static_cast<const ToolState&>(from.tools[ti]);
  } else {
    tools = from.tools;
    toolSlots.restoreFrom(from.toolSlots);
  }
}

void World::Impl::beforeStep() {
  Checkpoint& c = checkpoint;
  const double framesMs = c.frameMs * static_cast<double>(c.controls.size());
  if (!c.valid || c.controls.size() >= kCheckpointMaxFrames ||
      (c.controls.size() > 0 && c.copyMs <= kCheckpointShare * framesMs)) {
    const Timer timer;
    useAsCheckpoint(copyState());
    c.copyMs = timer.ms();
  }
  std::vector<ToolControl>& controls = c.controls.emplace_back();
  controls.reserve(tools.size());
  for (const WorldTool& t : tools) controls.push_back({t.pose, t.target, t.longest});
}

void World::Impl::rollBack() {
  Checkpoint& c = checkpoint;
  VOXCUT_ASSERT(c.valid && !c.controls.empty(), "rollBack: no checkpoint");
  const int failed = frame;
  const std::vector<std::vector<ToolControl>> controls = std::move(c.controls);
  assignState(*c.state, true);
  auto setControls = [&](const std::vector<ToolControl>& of) {
    for (std::size_t ti = 0; ti < tools.size(); ++ti) {
      tools[ti].pose = of[ti].pose;
      tools[ti].target = of[ti].target;
      tools[ti].longest = of[ti].longest;
    }
  };
  // The frames since the checkpoint, again (they finished before, so they finish again).
  failFrame = -1;
  for (std::size_t f = 0; f + 1 < controls.size(); ++f) {
    setControls(controls[f]);
    (void)runFrame();
  }
  setControls(controls.back());
  VOXCUT_ASSERT(frame == failed, "rollBack: the frames run again end elsewhere");
  c.controls.assign(controls.begin(), controls.end() - 1);
}

void WorldTesting::failNextStep(World& world, BodyId body) {
  World::Impl& w = *world.impl_;
  (void)w.bodyAt(body);
  w.failFrame = w.frame;
  w.failBody = body;
}

}  // namespace voxcut
