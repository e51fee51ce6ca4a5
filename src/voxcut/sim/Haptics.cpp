/// @file Haptics.cpp
/// Forces at haptic rate (docs/algorithms.md, "Forces at haptic rate"): each probe's force
/// model published at a frame's end, and World::hapticForce, which any thread may call.

#include <algorithm>

#include "voxcut/sim/WorldImpl.h"

namespace voxcut {

namespace {

/// The force of one model at the probe's midpoint c: the linearisation, used within the last
/// frame's motion of the model's pose (held at that distance beyond: a device running ahead of
/// frames that fall behind feels no extrapolated wall or cliff), zero where it would pull, and
/// fading to zero as the probe is pulled out from one to two radii.
Vec3d hapticModelForce(const HapticModel& m, const Vec3d& c) {
  if (!m.contact) return Vec3d::Zero();
  Vec3d offset = c - m.centre;
  // Pulled out farther than its radius, the probe is leaving whatever the frames say: the
  // force fades to nothing at twice the radius.
  double leaving = 1.0;
  if (offset.dot(m.reaction.force) > 0.0)
    leaving = std::clamp(2.0 - offset.norm() / m.radius, 0.0, 1.0);
  if (offset.norm() > m.reach) offset *= m.reach / offset.norm();
  const Vec3d force = leaving * (m.reaction.force + m.jacobian * offset);
  // Contact pushes and never pulls: past the point where the extrapolation turns round, the
  // probe has left the surface.
  return force.dot(m.reaction.force) > 0.0 ? force : Vec3d::Zero();
}

}  // namespace

namespace {

/// What the haptic call answers at the probe midpoint c: the model's force plus what is left
/// of the step to it, never pulling (along the model's contact force, or along the leftover
/// where the model has none). The publication uses the same answer, so a step that the call
/// clamped to nothing is faded from nothing.
Vec3d hapticAnswer(const HapticModel& m, const Vec3d& leftover, const Vec3d& c) {
  const Vec3d force = hapticModelForce(m, c) + leftover;
  const Vec3d along = m.contact ? m.reaction.force : leftover;
  return force.dot(along) > 0.0 ? force : Vec3d::Zero();
}

}  // namespace

/// The probe's force model after a frame: its reaction there, and the Jacobian estimate
/// updated by the secant of the last two frames along the probe's motion (Broyden's rank-one
/// update, which keeps what earlier motions taught in the other directions). A frame without
/// contact forgets it; the first frame of a contact has no slope yet. Published to the slot.
void publishHaptic(WorldTool& t, double timeStep) {
  HapticModel next;
  next.centre = 0.5 * (t.pose.a + t.pose.b);
  next.radius = t.radius;
  next.reaction = t.reaction;
  next.contact = t.reaction.force != Vec3d::Zero();
  next.reach = std::min(0.5 * t.radius, (next.centre - t.haptic.centre).norm());
  if (next.contact && t.haptic.contact) {
    next.jacobian = t.haptic.jacobian;
    const Vec3d dc = next.centre - t.haptic.centre;
    // Below a ten-thousandth of the radius, the force's change is the tissue settling, not
    // the motion: the slope would be noise.
    if (dc.norm() > 1e-4 * t.radius) {
      const Vec3d miss = next.reaction.force - t.haptic.reaction.force - next.jacobian * dc;
      next.jacobian += miss * dc.transpose() / dc.squaredNorm();
    }
  }
  t.haptic = next;
  const auto now = std::chrono::steady_clock::now();
  const std::lock_guard<std::mutex> lock(t.slot->mutex);
  HapticSlot& slot = *t.slot;
  // What the call answered at the new pose until now, less what the new model answers there:
  // faded out over the next period, it makes the force continuous in time.
  const Vec3d at = slot.wasAsked ? slot.asked : next.centre;
  const Vec3d answered = hapticAnswer(slot.model, (1.0 - slot.blend(now)) * slot.offset, at);
  const Vec3d fresh = hapticModelForce(next, at);
  slot.offset = answered - fresh;
  // The frames' wall-clock period (0 at the first publication: nothing to fade from).
  double period = 0.0;
  if (slot.published != std::chrono::steady_clock::time_point{})
    period = std::clamp(std::chrono::duration<double>(now - slot.published).count(),
                        std::min(timeStep, kHapticMaxPeriod), kHapticMaxPeriod);
  // A step larger than the frame period can spread at kHapticStepRate of the force per
  // millisecond is spread over longer (within the longest period): the force lags the frames
  // a little where they disagree much, rather than jumping.
  const double smaller = std::min(answered.norm(), fresh.norm());
  slot.fade = period;
  if (smaller > 0.0)
    slot.fade = std::clamp(1e-3 * slot.offset.norm() / (kHapticStepRate * smaller), period,
                           std::max(period, kHapticMaxPeriod));
  slot.model = next;
  slot.published = now;
}


HapticAnswer World::hapticForce(ToolId tool, const BladePose& pose) const noexcept {
  HapticAnswer answer;
  const std::optional<std::size_t> ti = impl_->toolSlots.find(tool);
  if (!ti || impl_->tools[*ti].kind != ToolKind::Probe) {
    answer.status = HapticAnswer::Status::NotAProbe;
    return answer;
  }
  if (!isCoordinate(pose.a) || !isCoordinate(pose.b)) {
    answer.status = HapticAnswer::Status::NonFinitePose;
    return answer;
  }
  HapticModel m;
  Vec3d offset;
  {
    const HapticSlot& slot = *impl_->tools[*ti].slot;
    const std::lock_guard<std::mutex> lock(slot.mutex);
    m = slot.model;
    offset = (1.0 - slot.blend(std::chrono::steady_clock::now())) * slot.offset;
    slot.asked = 0.5 * (pose.a + pose.b);
    slot.wasAsked = true;
  }
  // The newest frame's model, plus what is left of the step to it (docs/algorithms.md,
  // "Forces at haptic rate"); still never pulling.
  ToolReaction& r = answer.reaction;
  r.force = hapticAnswer(m, offset, 0.5 * (pose.a + pose.b));
  if (r.force != Vec3d::Zero()) r.torque = m.reaction.torque;
  return answer;
}

}  // namespace voxcut
