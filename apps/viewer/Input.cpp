#include "Input.h"

#include <cmath>

namespace voxcut::view {

DrivenTools drivenTools(const Session& session) {
  DrivenTools t;
  t.blade = session.blade();
  t.probe = session.probe();
  t.bladePark = session.bladePark();
  t.probePark = session.probePark();
  t.bladeLength = session.bladeLength();
  t.probeRadius = session.world().toolRadius(session.probe());
  return t;
}

ToolId InputController::draggedTool() const {
  return dragMode_ == ToolMode::Blade ? tools_.blade : tools_.probe;
}

BladePose InputController::poseAt(double px, double py) const {
  const Ray r = camera.ray(px, py);
  // The cursor's point on the plane through the picked point, facing the press's view.
  const double along = r.direction.dot(sight_);
  const double t = std::abs(along) > 1e-9 ? (planePoint_ - r.origin).dot(sight_) / along : 0.0;
  const Vec3d q = r.origin + t * r.direction + depth_ * sight_;
  if (dragMode_ == ToolMode::Blade) {
    // The edge along the line of sight: a quarter in front of the plane, the rest behind it.
    const double l = tools_.bladeLength;
    return {q - 0.25 * l * sight_, q + 0.75 * l * sight_};
  }
  // The probe's centre half its radius in front of the plane: pressed in by half its radius
  // where it was put down. (Centred on the surface, the surface would cross the sphere at its
  // widest, where the contact normals lie in the surface and push sideways.)
  const Vec3d c = q - 0.5 * tools_.probeRadius * sight_;
  return {c, c};
}

std::vector<ToolCommand> InputController::follow() {
  return {ToolCommand{draggedTool(), poseAt(lastX_, lastY_), false}};
}

std::vector<ToolCommand> InputController::button(MouseButton b, bool pressed, double px, double py,
                                                 bool shift, const DrawData& scene) {
  lastX_ = px;
  lastY_ = py;
  if (!pressed) {
    orbiting_ = panning_ = false;
    // Only the left button's release ends a drag (it started with the left button).
    if (!dragging_ || b != MouseButton::Left) return {};
    dragging_ = false;
    // Lifted off: back to where it waits, without sweeping through anything on the way.
    const bool blade = dragMode_ == ToolMode::Blade;
    return {ToolCommand{draggedTool(), blade ? tools_.bladePark : tools_.probePark, true}};
  }
  if (b == MouseButton::Left && !shift && mode != ToolMode::Camera) {
    if (const std::optional<Vec3d> hit = pick(scene, camera.ray(px, py))) {
      dragging_ = true;
      dragMode_ = mode;
      planePoint_ = *hit;
      sight_ = camera.forward();
      depth_ = 0.0;
      return {ToolCommand{draggedTool(), poseAt(px, py), true}};
    }
  }
  if (b == MouseButton::Left && !shift)
    orbiting_ = true;
  else
    panning_ = true;
  return {};
}

std::vector<ToolCommand> InputController::move(double px, double py) {
  const double dx = px - lastX_, dy = py - lastY_;
  lastX_ = px;
  lastY_ = py;
  if (dragging_) return follow();
  if (orbiting_) camera.orbit(dx, dy);
  if (panning_) camera.pan(dx, dy);
  return {};
}

std::vector<ToolCommand> InputController::wheel(double steps) {
  if (!dragging_) {
    camera.zoom(steps);
    return {};
  }
  // Away from the user pushes the tool deeper, by 2 % of the blade's length a step.
  depth_ += 0.02 * tools_.bladeLength * steps;
  return follow();
}

}  // namespace voxcut::view
