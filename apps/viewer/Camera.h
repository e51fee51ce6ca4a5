#pragma once
/// @file Camera.h
/// The viewer's orbit camera (docs/viewer.md): a target point, a distance and two angles, with
/// the matrices a renderer needs and the ray under a pixel that picking and tool driving use.
/// Plain maths, no window: the viewer's tests drive it directly.

#include <Eigen/Geometry>
#include <string>

#include "voxcut/core/Types.h"

namespace voxcut::view {

/// A ray from `origin` along the unit vector `direction`.
struct Ray {
  Vec3d origin = Vec3d::Zero();
  Vec3d direction = -Vec3d::UnitZ();
};

/// Looks at `target` from `distance` away, from the direction given by `yaw` (about `worldUp`)
/// and `pitch` (above the plane square to it); `worldUp` is up on screen (the scene's, opposite
/// its gravity: +y by default, +z for a z-up scene). Pixels count from the top left.
struct Camera {
  Vec3d target = Vec3d::Zero();
  Vec3d worldUp = Vec3d::UnitY();  ///< unit
  double distance = 1.0;  ///< m, > 0
  double yaw = 0.6;       ///< rad
  double pitch = 0.35;    ///< rad, within (-pi/2, pi/2)
  double fovY = 0.7;      ///< vertical field of view (rad)
  int width = 960;        ///< viewport (pixels)
  int height = 720;

  [[nodiscard]] Vec3d eye() const;
  /// Unit vectors of the view: into the screen, to the right, up.
  [[nodiscard]] Vec3d forward() const;
  [[nodiscard]] Vec3d right() const;
  [[nodiscard]] Vec3d up() const;
  /// World to eye (a right-handed look-at).
  [[nodiscard]] Eigen::Matrix4d view() const;
  /// Eye to clip (OpenGL's perspective; near and far planes scale with the distance).
  [[nodiscard]] Eigen::Matrix4d projection() const;
  /// The ray from the eye through the centre of pixel (px, py).
  [[nodiscard]] Ray ray(double px, double py) const;
  /// Where the world point x lands on screen (pixels), and whether it lies in front.
  [[nodiscard]] bool project(const Vec3d& x, double& px, double& py) const;

  /// Turns around the target by a mouse motion of (dx, dy) pixels.
  void orbit(double dx, double dy);
  /// Moves the target with the view by a mouse motion of (dx, dy) pixels: the point under the
  /// cursor at the target's depth follows the cursor.
  void pan(double dx, double dy);
  /// Moves closer (steps > 0) or farther, by 10 % a step.
  void zoom(double steps);
  /// Looks at the middle of `box` from far enough to see all of it; keeps the angles.
  void fit(const Eigen::AlignedBox3d& box);
  /// Sets `worldUp` opposite `gravity` (unchanged for a zero gravity).
  void upAgainst(const Vec3d& gravity);
};

/// Parses a view's size "WxH" (16 <= W, H <= 8192) into width and height. Throws InputError
/// naming `option` otherwise.
void parseViewSize(const std::string& text, const std::string& option, int& width, int& height);

}  // namespace voxcut::view
