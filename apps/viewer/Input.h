#pragma once
/// @file Input.h
/// The viewer's input layer (docs/viewer.md, "Mouse and keys"): mouse and key events in, camera
/// motion and tool commands out. With the blade or the probe chosen, a press on a body picks
/// the surface point under the cursor; the tool is put down there (ToolCommand::place) and
/// follows the cursor on the plane through that point facing the view while the button is
/// held: the blade's edge runs along the line of sight through the point, reaching into the
/// body, so a drag cuts; the probe's centre sits half its radius in front of the plane, so it
/// presses in by half its radius (the wheel moves the tool along the line of sight meanwhile). On
/// release the tool is put back where it waits. Otherwise the left button orbits, the right one (or
/// shift + left) pans and the wheel zooms. No window: the window's callbacks and the tests call it
/// alike.

#include <cstddef>
#include <vector>

#include "Camera.h"
#include "DrawData.h"
#include "Session.h"

namespace voxcut::view {

enum class ToolMode { Camera, Blade, Probe };

enum class MouseButton { Left, Right, Middle };

/// What the input layer needs to know of the session: the tools it drives and where they wait.
struct DrivenTools {
  ToolId blade, probe;
  BladePose bladePark, probePark;
  double bladeLength = 0.1;   ///< m
  double probeRadius = 0.01;  ///< m
};

/// A session's driven tools.
[[nodiscard]] DrivenTools drivenTools(const Session& session);

class InputController {
 public:
  explicit InputController(const DrivenTools& tools) : tools_(tools) {}

  Camera camera;
  ToolMode mode = ToolMode::Camera;

  /// A button went down or up at pixel (px, py); `shift` held. `scene` is the latest drawn
  /// frame, for picking. Returns the tool commands to send.
  std::vector<ToolCommand> button(MouseButton b, bool pressed, double px, double py, bool shift,
                                  const DrawData& scene);
  /// The cursor moved to (px, py).
  std::vector<ToolCommand> move(double px, double py);
  /// The wheel turned by `steps` (> 0 away from the user).
  std::vector<ToolCommand> wheel(double steps);

  /// Ends a drag without a command (the world was reset: the tool is back where it waits).
  void cancel() { dragging_ = orbiting_ = panning_ = false; }
  /// Whether a tool follows the cursor now.
  [[nodiscard]] bool dragging() const { return dragging_; }
  /// The tool the drag drives.
  [[nodiscard]] ToolId draggedTool() const;

 private:
  /// The driven tool's pose for the cursor at (px, py).
  [[nodiscard]] BladePose poseAt(double px, double py) const;
  [[nodiscard]] std::vector<ToolCommand> follow();

  DrivenTools tools_;
  bool dragging_ = false;
  ToolMode dragMode_ = ToolMode::Camera;
  bool orbiting_ = false, panning_ = false;
  double lastX_ = 0.0, lastY_ = 0.0;
  Vec3d planePoint_ = Vec3d::Zero();  ///< the picked surface point
  Vec3d sight_ = -Vec3d::UnitZ();     ///< the line of sight at the press (the plane's normal)
  double depth_ = 0.0;                ///< the wheel's offset along the line of sight (m)
};

}  // namespace voxcut::view
