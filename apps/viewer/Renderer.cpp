#include "Renderer.h"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/gl.h>
#include <GL/glext.h>
#include <stb_image_write.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "voxcut/core/Error.h"

namespace voxcut::view {
namespace {

const char* const kMeshVertex = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 colour;
uniform mat4 viewMatrix;
uniform mat4 projectionMatrix;
out vec3 eyeNormal;
out vec3 eyePosition;
out vec3 vertexColour;
void main() {
  vec4 eye = viewMatrix * vec4(position, 1.0);
  eyePosition = eye.xyz;
  eyeNormal = mat3(viewMatrix) * normal;
  vertexColour = colour;
  gl_Position = projectionMatrix * eye;
}
)";

// A headlight: diffuse with a little ambient and a soft highlight; faces lit from both sides
// (a cut's faces and open obstacle meshes are seen from either side).
const char* const kMeshFragment = R"(#version 330 core
in vec3 eyeNormal;
in vec3 eyePosition;
in vec3 vertexColour;
uniform int flatShade;
out vec4 fragColour;
void main() {
  vec3 n = length(eyeNormal) > 0.0 ? normalize(eyeNormal) : vec3(0.0, 0.0, 1.0);
  if (flatShade != 0) n = normalize(cross(dFdx(eyePosition), dFdy(eyePosition)));
  vec3 toEye = normalize(-eyePosition);
  float d = abs(dot(n, toEye));
  float s = pow(d, 24.0);
  fragColour = vec4(vertexColour * (0.28 + 0.72 * d) + vec3(0.12 * s), 1.0);
}
)";

const char* const kLineVertex = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 colour;
uniform mat4 viewMatrix;
uniform mat4 projectionMatrix;
out vec3 vertexColour;
void main() {
  vertexColour = colour;
  gl_Position = projectionMatrix * viewMatrix * vec4(position, 1.0);
}
)";

const char* const kLineFragment = R"(#version 330 core
in vec3 vertexColour;
out vec4 fragColour;
void main() { fragColour = vec4(vertexColour, 1.0); }
)";

GLuint compile(GLenum kind, const char* source) {
  const GLuint s = glCreateShader(kind);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    throw InputError(std::string("OpenGL: a shader does not compile: ") + log);
  }
  return s;
}

GLuint link(const char* vertex, const char* fragment) {
  const GLuint p = glCreateProgram();
  const GLuint v = compile(GL_VERTEX_SHADER, vertex), f = compile(GL_FRAGMENT_SHADER, fragment);
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) throw InputError("OpenGL: a shader program does not link");
  return p;
}

void setMatrices(GLuint program, const Camera& camera) {
  const Eigen::Matrix4f view = camera.view().cast<float>(),
                        proj = camera.projection().cast<float>();
  glUniformMatrix4fv(glGetUniformLocation(program, "viewMatrix"), 1, GL_FALSE, view.data());
  glUniformMatrix4fv(glGetUniformLocation(program, "projectionMatrix"), 1, GL_FALSE, proj.data());
}

/// A vertex array of interleaved float attributes of the given sizes.
void makeArray(GLuint& vao, GLuint& vbo, std::initializer_list<int> sizes) {
  glGenVertexArrays(1, &vao);
  glGenBuffers(1, &vbo);
  glBindVertexArray(vao);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  int stride = 0;
  for (int s : sizes) stride += s;
  int offset = 0, index = 0;
  for (int s : sizes) {
    glEnableVertexAttribArray(static_cast<GLuint>(index));
    glVertexAttribPointer(
        static_cast<GLuint>(index), s, GL_FLOAT, GL_FALSE, stride * static_cast<int>(sizeof(float)),
        reinterpret_cast<const void*>(static_cast<std::uintptr_t>(offset) * sizeof(float)));
    offset += s;
    ++index;
  }
  glBindVertexArray(0);
}

}  // namespace

void writePng(const Image& image, const std::string& path) {
  const std::string temp = path + ".part.png";
  if (image.width <= 0 || image.height <= 0 ||
      !stbi_write_png(temp.c_str(), image.width, image.height, 3, image.rgb.data(),
                      image.width * 3))
    throw InputError(path + ": cannot write the PNG");
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) throw InputError(path + ": cannot write the PNG (" + ec.message() + ")");
}

Renderer::Renderer() {
  meshProgram_ = link(kMeshVertex, kMeshFragment);
  lineProgram_ = link(kLineVertex, kLineFragment);
  makeArray(meshVao_, meshVbo_, {3, 3, 3});
  makeArray(bodyVao_, bodyVbo_, {3, 3, 3});
  glGenBuffers(1, &bodyEbo_);
  glBindVertexArray(bodyVao_);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, bodyEbo_);
  glBindVertexArray(0);
  makeArray(lineVao_, lineVbo_, {3, 3});
}

Renderer::~Renderer() {
  glDeleteProgram(meshProgram_);
  glDeleteProgram(lineProgram_);
  glDeleteVertexArrays(1, &meshVao_);
  glDeleteVertexArrays(1, &bodyVao_);
  glDeleteBuffers(1, &bodyVbo_);
  glDeleteBuffers(1, &bodyEbo_);
  glDeleteVertexArrays(1, &lineVao_);
  glDeleteBuffers(1, &meshVbo_);
  glDeleteBuffers(1, &lineVbo_);
  if (fbo_ != 0) {
    glDeleteFramebuffers(1, &fbo_);
    glDeleteRenderbuffers(1, &colour_);
    glDeleteRenderbuffers(1, &depth_);
  }
}

void Renderer::draw(const DrawData& data, const Camera& camera, bool wireframe) {
  const Eigen::Vector3f bg = backgroundColour();
  glViewport(0, 0, camera.width, camera.height);
  glClearColor(bg.x(), bg.y(), bg.z(), 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glUseProgram(meshProgram_);
  setMatrices(meshProgram_, camera);
  glUniform1i(glGetUniformLocation(meshProgram_, "flatShade"), 0);
  // A frame drawn again (the window redraws faster than frames come) is not uploaded again.
  const bool upload = data.stamp == 0 || data.stamp != uploaded_;
  uploaded_ = data.stamp;
  const auto bodyIndices = static_cast<GLsizei>(data.bodyIndices.size());
  glBindVertexArray(bodyVao_);
  if (upload) {
    glBindBuffer(GL_ARRAY_BUFFER, bodyVbo_);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.bodyVertices.size() * sizeof(float)),
                 data.bodyVertices.data(), GL_STREAM_DRAW);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER,
                 static_cast<GLsizeiptr>(data.bodyIndices.size() * sizeof(std::uint32_t)),
                 data.bodyIndices.data(), GL_STREAM_DRAW);
  }
  if (wireframe) {
    // Surfaces, their edges on top.
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.0f, 1.0f);
    glDrawElements(GL_TRIANGLES, bodyIndices, GL_UNSIGNED_INT, nullptr);
    glDisable(GL_POLYGON_OFFSET_FILL);
    glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
    glUniform1i(glGetUniformLocation(meshProgram_, "flatShade"), 1);
    glDrawElements(GL_TRIANGLES, bodyIndices, GL_UNSIGNED_INT, nullptr);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glUniform1i(glGetUniformLocation(meshProgram_, "flatShade"), 0);
  } else {
    // Bodies' surfaces are closed and wound counter-clockwise seen from outside: their back
    // faces are hidden anyway (half the rasterising saved).
    glEnable(GL_CULL_FACE);
    glDrawElements(GL_TRIANGLES, bodyIndices, GL_UNSIGNED_INT, nullptr);
    glDisable(GL_CULL_FACE);
  }
  glBindVertexArray(meshVao_);
  glBindBuffer(GL_ARRAY_BUFFER, meshVbo_);
  if (upload)
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.triangles.size() * sizeof(float)),
                 data.triangles.data(), GL_STREAM_DRAW);
  glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(data.triangles.size() / kTriangleStride));
  if (!data.lines.empty()) {
    glUseProgram(lineProgram_);
    setMatrices(lineProgram_, camera);
    glBindVertexArray(lineVao_);
    glBindBuffer(GL_ARRAY_BUFFER, lineVbo_);
    if (upload)
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.lines.size() * sizeof(float)),
                   data.lines.data(), GL_STREAM_DRAW);
    // Lines through the surface stay visible: drawn over it.
    glDisable(GL_DEPTH_TEST);
    glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(data.lines.size() / kLineStride));
    glEnable(GL_DEPTH_TEST);
  }
  glBindVertexArray(0);
  glUseProgram(0);
}

Image Renderer::capture(const DrawData& data, const Camera& camera, bool wireframe) {
  if (fbo_ == 0 || fboWidth_ != camera.width || fboHeight_ != camera.height) {
    if (fbo_ == 0) {
      glGenFramebuffers(1, &fbo_);
      glGenRenderbuffers(1, &colour_);
      glGenRenderbuffers(1, &depth_);
    }
    glBindRenderbuffer(GL_RENDERBUFFER, colour_);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, camera.width, camera.height);
    glBindRenderbuffer(GL_RENDERBUFFER, depth_);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, camera.width, camera.height);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw InputError("OpenGL: the offscreen framebuffer is incomplete");
    fboWidth_ = camera.width;
    fboHeight_ = camera.height;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  draw(data, camera, wireframe);
  Image image = readPixels(camera.width, camera.height);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return image;
}

Image readPixels(int width, int height) {
  Image image;
  image.width = width;
  image.height = height;
  image.rgb.resize(static_cast<std::size_t>(width) * height * 3);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, image.rgb.data());
  // OpenGL's rows run from the bottom.
  const std::size_t row = static_cast<std::size_t>(width) * 3;
  for (int y = 0; y < height / 2; ++y)
    std::swap_ranges(image.rgb.begin() + static_cast<std::ptrdiff_t>(y * row),
                     image.rgb.begin() + static_cast<std::ptrdiff_t>((y + 1) * row),
                     image.rgb.begin() + static_cast<std::ptrdiff_t>((height - 1 - y) * row));
  return image;
}

}  // namespace voxcut::view
