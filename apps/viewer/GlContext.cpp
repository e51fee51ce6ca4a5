#include "GlContext.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cstdlib>

#include "voxcut/core/Error.h"

namespace voxcut::view {
namespace {
std::string lastError;
void onError(int, const char* description) {
  lastError = description;
}
}  // namespace

GlContext::GlContext(int width, int height, bool visible, const std::string& title) {
  glfwSetErrorCallback(onError);
  if (!glfwInit()) {
    const char* display = std::getenv("DISPLAY");
    throw InputError("cannot open a window: " +
                     (display == nullptr || *display == '\0'
                          ? std::string("no display (DISPLAY is not set; for headless use run "
                                        "under xvfb-run -a)")
                          : lastError));
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, visible ? GLFW_TRUE : GLFW_FALSE);
  window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (window_ == nullptr) {
    glfwTerminate();
    throw InputError("cannot open an OpenGL 3.3 core window: " + lastError);
  }
  glfwMakeContextCurrent(window_);
}

GlContext::~GlContext() {
  glfwDestroyWindow(window_);
  glfwTerminate();
}

}  // namespace voxcut::view
