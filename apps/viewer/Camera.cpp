#include "Camera.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "voxcut/core/Error.h"

namespace voxcut::view {

namespace {

/// Two unit vectors square to `up` and to each other, (e1, e2, up) right-handed: +x and +z for
/// up = +y, so that the angles mean what they always did there.
void horizontalBasis(const Vec3d& up, Vec3d& e1, Vec3d& e2) {
  const Vec3d a = std::abs(up.z()) < 0.9 ? Vec3d::UnitZ() : Vec3d(-Vec3d::UnitY());
  e2 = (a - a.dot(up) * up).normalized();
  e1 = up.cross(e2);
}

}  // namespace

Vec3d Camera::forward() const {
  Vec3d e1, e2;
  horizontalBasis(worldUp, e1, e2);
  return -(std::cos(pitch) * std::sin(yaw) * e1 + std::sin(pitch) * worldUp +
           std::cos(pitch) * std::cos(yaw) * e2);
}

Vec3d Camera::eye() const {
  return target - distance * forward();
}

Vec3d Camera::right() const {
  return forward().cross(worldUp).normalized();
}

Vec3d Camera::up() const {
  return right().cross(forward());
}

Eigen::Matrix4d Camera::view() const {
  const Vec3d f = forward(), r = right(), u = up(), e = eye();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = r.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -r.dot(e);
  m(1, 3) = -u.dot(e);
  m(2, 3) = f.dot(e);
  return m;
}

Eigen::Matrix4d Camera::projection() const {
  const double aspect = static_cast<double>(std::max(width, 1)) / std::max(height, 1);
  const double n = 0.01 * distance, f = 100.0 * distance;
  const double t = 1.0 / std::tan(0.5 * fovY);
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  p(0, 0) = t / aspect;
  p(1, 1) = t;
  p(2, 2) = -(f + n) / (f - n);
  p(2, 3) = -2.0 * f * n / (f - n);
  p(3, 2) = -1.0;
  return p;
}

Ray Camera::ray(double px, double py) const {
  const double aspect = static_cast<double>(std::max(width, 1)) / std::max(height, 1);
  const double t = std::tan(0.5 * fovY);
  // Normalised device coordinates of the pixel's centre.
  const double x = (2.0 * (px + 0.5) / std::max(width, 1) - 1.0) * t * aspect;
  const double y = (1.0 - 2.0 * (py + 0.5) / std::max(height, 1)) * t;
  return {eye(), (forward() + x * right() + y * up()).normalized()};
}

bool Camera::project(const Vec3d& x, double& px, double& py) const {
  const Eigen::Vector4d c = projection() * view() * Eigen::Vector4d(x.x(), x.y(), x.z(), 1.0);
  if (!(c.w() > 0.0)) return false;
  px = (0.5 * (c.x() / c.w()) + 0.5) * width - 0.5;
  py = (0.5 - 0.5 * (c.y() / c.w())) * height - 0.5;
  return true;
}

void Camera::orbit(double dx, double dy) {
  yaw -= 0.008 * dx;
  pitch = std::clamp(pitch + 0.008 * dy, -1.55, 1.55);
}

void Camera::pan(double dx, double dy) {
  const double perPixel = 2.0 * distance * std::tan(0.5 * fovY) / std::max(height, 1);
  target += perPixel * (-dx * right() + dy * up());
}

void Camera::zoom(double steps) {
  distance = std::clamp(distance * std::pow(0.9, steps), 1e-4, 1e4);
}

void Camera::fit(const Eigen::AlignedBox3d& box) {
  if (box.isEmpty()) return;
  target = box.center();
  const double radius = std::max(0.5 * box.diagonal().norm(), 1e-3);
  const double aspect = static_cast<double>(std::max(width, 1)) / std::max(height, 1);
  const double half = 0.5 * fovY * std::min(1.0, aspect);
  distance = 1.1 * radius / std::sin(half);
}

void Camera::upAgainst(const Vec3d& gravity) {
  if (gravity.norm() > 0.0) worldUp = -gravity.normalized();
}

void parseViewSize(const std::string& text, const std::string& option, int& width, int& height) {
  int w = 0, h = 0;
  char x = 0;
  if (std::sscanf(text.c_str(), "%d%c%d", &w, &x, &h) != 3 || x != 'x' || w < 16 || h < 16 ||
      w > 8192 || h > 8192)
    throw InputError(option + ": must be WxH with 16 <= W, H <= 8192, got '" + text + "'");
  width = w;
  height = h;
}

}  // namespace voxcut::view
