#pragma once
/// @file GlContext.h
/// A GLFW window with a current OpenGL 3.3 core context: visible for the viewer, hidden for
/// headless rendering (screenshots with no user, e.g. under Xvfb).

#include <string>

struct GLFWwindow;

namespace voxcut::view {

class GlContext {
 public:
  /// Opens the window. Throws InputError with one line when there is no display or no
  /// OpenGL 3.3 (e.g. "voxcut-view: cannot open a window: no display (run under xvfb-run
  /// for headless use)").
  GlContext(int width, int height, bool visible, const std::string& title);
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  [[nodiscard]] GLFWwindow* window() const { return window_; }

 private:
  GLFWwindow* window_ = nullptr;
};

}  // namespace voxcut::view
