#pragma once
/// @file Renderer.h
/// Draws a DrawData with OpenGL 3.3 core (docs/viewer.md, "Rendering"): lit triangles with
/// per-vertex colours and normals (a headlight, both faces lit), optional wireframe, lines on
/// top; offscreen into a framebuffer for screenshots. Needs a current OpenGL 3.3 context
/// (GLFW's, a hidden window's for headless use); one renderer per context.

#include <cstdint>
#include <string>
#include <vector>

#include "Camera.h"
#include "DrawData.h"

namespace voxcut::view {

/// An RGB image, rows from the top.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
};

/// Writes `image` as a PNG (through a temporary file: an interrupted run leaves no half
/// file). Throws InputError when it cannot.
void writePng(const Image& image, const std::string& path);

/// Reads the bound framebuffer's read buffer (width x height from its lower left corner).
[[nodiscard]] Image readPixels(int width, int height);

class Renderer {
 public:
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Draws `data` seen by `camera` into the bound framebuffer (camera.width x camera.height).
  void draw(const DrawData& data, const Camera& camera, bool wireframe);
  /// Draws into an offscreen framebuffer of the camera's size and reads it back.
  [[nodiscard]] Image capture(const DrawData& data, const Camera& camera, bool wireframe);

 private:
  unsigned meshProgram_ = 0, lineProgram_ = 0;
  unsigned meshVao_ = 0, meshVbo_ = 0, lineVao_ = 0, lineVbo_ = 0;
  unsigned bodyVao_ = 0, bodyVbo_ = 0, bodyEbo_ = 0;
  /// The stamp of the frame whose arrays the buffers hold: a frame drawn again is not
  /// uploaded again.
  std::uint64_t uploaded_ = 0;
  unsigned fbo_ = 0, colour_ = 0, depth_ = 0;
  int fboWidth_ = 0, fboHeight_ = 0;
};

}  // namespace voxcut::view
