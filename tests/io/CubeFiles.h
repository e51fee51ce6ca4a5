#pragma once
/// @file CubeFiles.h
/// A small closed cube written by hand in each mesh format the reader must accept, so that
/// the reader is tested against files it did not write.

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "voxcut/core/TriangleMesh.h"

namespace voxcut::test {

/// The cube [0.25, 0.75]^3 (exact in float): 8 corners, 6 outward quads.
inline const std::array<std::array<double, 3>, 8> kCubeCorners = {{{0.25, 0.25, 0.25},
                                                                   {0.75, 0.25, 0.25},
                                                                   {0.75, 0.75, 0.25},
                                                                   {0.25, 0.75, 0.25},
                                                                   {0.25, 0.25, 0.75},
                                                                   {0.75, 0.25, 0.75},
                                                                   {0.75, 0.75, 0.75},
                                                                   {0.25, 0.75, 0.75}}};
inline const std::array<std::array<int, 4>, 6> kCubeQuads = {
    {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {3, 7, 6, 2}, {0, 4, 7, 3}, {1, 2, 6, 5}}};

/// The cube's 12 outward triangles (each quad a b c d split into a b c and a c d).
inline std::vector<std::array<int, 3>> cubeTriangles() {
  std::vector<std::array<int, 3>> t;
  for (const auto& q : kCubeQuads) {
    t.push_back({q[0], q[1], q[2]});
    t.push_back({q[0], q[2], q[3]});
  }
  return t;
}

inline std::string cubeObj() {
  std::ostringstream s;
  s << "# cube\n";
  for (const auto& c : kCubeCorners) s << "v " << c[0] << ' ' << c[1] << ' ' << c[2] << '\n';
  for (const auto& q : kCubeQuads)
    s << "f " << q[0] + 1 << ' ' << q[1] + 1 << ' ' << q[2] + 1 << ' ' << q[3] + 1 << '\n';
  return s.str();
}

inline std::string cubeOff() {
  std::ostringstream s;
  s << "OFF\n8 6 12\n";
  for (const auto& c : kCubeCorners) s << c[0] << ' ' << c[1] << ' ' << c[2] << '\n';
  for (const auto& q : kCubeQuads)
    s << "4 " << q[0] << ' ' << q[1] << ' ' << q[2] << ' ' << q[3] << '\n';
  return s.str();
}

inline std::string cubeAsciiPly() {
  std::ostringstream s;
  s << "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
       "property float z\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& c : kCubeCorners) s << c[0] << ' ' << c[1] << ' ' << c[2] << '\n';
  for (const auto& q : kCubeQuads)
    s << "4 " << q[0] << ' ' << q[1] << ' ' << q[2] << ' ' << q[3] << '\n';
  return s.str();
}

template <class T>
void appendRaw(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // the test machines are little-endian
  out.append(bytes, sizeof(T));
}

/// Appends `value`'s bytes in the given byte order (the test machines are little-endian).
template <class T>
void appendEndian(std::string& out, T value, bool bigEndian) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if (bigEndian)
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  out.append(bytes, sizeof(T));
}

/// Binary PLY of the cube translated by `offset` (double coordinates), in the given byte
/// order, with what real files carry besides the geometry: comments, obj_info, normals and
/// colours of mixed types, a list property on vertices, an element before and one after the
/// faces, a short list count and unsigned indices, and a property after the index list.
inline std::string cubeRichBinaryPly(bool bigEndian, double offset = 0.0) {
  std::string s = std::string("ply\nformat ") +
                  (bigEndian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\ncomment written by hand\nobj_info test cube\n"
                  "element vertex 8\nproperty float nx\nproperty double x\nproperty double y\n"
                  "property double z\nproperty uchar red\nproperty list uchar short tags\n"
                  "property int16 extra\n"
                  "element material 2\nproperty float shine\nproperty list int uint ids\n"
                  "element face 6\nproperty ushort flags\nproperty list short uint vertex_indices\n"
                  "property double weight\n"
                  "element edge 1\nproperty int a\nproperty int b\nend_header\n";
  for (const auto& c : kCubeCorners) {
    appendEndian(s, 0.5f, bigEndian);
    for (int k = 0; k < 3; ++k) appendEndian(s, c[k] + (k == 0 ? offset : 0.0), bigEndian);
    appendEndian(s, std::uint8_t{200}, bigEndian);
    appendEndian(s, std::uint8_t{2}, bigEndian);
    appendEndian(s, std::int16_t{-7}, bigEndian);
    appendEndian(s, std::int16_t{9}, bigEndian);
    appendEndian(s, std::int16_t{-1}, bigEndian);
  }
  for (int m = 0; m < 2; ++m) {
    appendEndian(s, 1.5f, bigEndian);
    appendEndian(s, std::int32_t{m}, bigEndian);  // a list of m ids
    for (int k = 0; k < m; ++k) appendEndian(s, std::uint32_t{77}, bigEndian);
  }
  for (const auto& q : kCubeQuads) {
    appendEndian(s, std::uint16_t{3}, bigEndian);
    appendEndian(s, std::int16_t{4}, bigEndian);
    for (const int v : q) appendEndian(s, static_cast<std::uint32_t>(v), bigEndian);
    appendEndian(s, 0.25, bigEndian);
  }
  appendEndian(s, std::int32_t{0}, bigEndian);
  appendEndian(s, std::int32_t{1}, bigEndian);
  return s;
}

/// Binary little-endian PLY of the cube's triangles; `corner0x` replaces corner 0's x.
inline std::string cubeBinaryPly(float corner0x = 0.25f) {
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex 8\nproperty float x\n"
      "property float y\nproperty float z\nelement face 12\n"
      "property list uchar int vertex_indices\nend_header\n";
  for (std::size_t i = 0; i < kCubeCorners.size(); ++i)
    for (int k = 0; k < 3; ++k)
      appendRaw(s, i == 0 && k == 0 ? corner0x : static_cast<float>(kCubeCorners[i][k]));
  for (const auto& t : cubeTriangles()) {
    appendRaw(s, std::uint8_t{3});
    for (const int v : t) appendRaw(s, static_cast<std::int32_t>(v));
  }
  return s;
}

inline std::array<double, 3> corner(int i) {
  return kCubeCorners[i];
}

inline std::array<double, 3> triangleNormal(const std::array<int, 3>& t) {
  const auto a = corner(t[0]), b = corner(t[1]), c = corner(t[2]);
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                       u[0] * v[1] - u[1] * v[0]};
  const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  return {n[0] / len, n[1] / len, n[2] / len};
}

inline std::string cubeAsciiStl() {
  std::ostringstream s;
  s << "solid cube\n";
  for (const auto& t : cubeTriangles()) {
    const auto n = triangleNormal(t);
    s << "  facet normal " << n[0] << ' ' << n[1] << ' ' << n[2] << "\n    outer loop\n";
    for (const int v : t)
      s << "      vertex " << corner(v)[0] << ' ' << corner(v)[1] << ' ' << corner(v)[2] << '\n';
    s << "    endloop\n  endfacet\n";
  }
  s << "endsolid cube\n";
  return s.str();
}

inline std::string cubeBinaryStl() {
  std::string s(80, ' ');
  s.replace(0, 10, "voxel cube");  // must not start with "solid"
  const auto triangles = cubeTriangles();
  appendRaw(s, static_cast<std::uint32_t>(triangles.size()));
  for (const auto& t : triangles) {
    for (const double n : triangleNormal(t)) appendRaw(s, static_cast<float>(n));
    for (const int v : t)
      for (int k = 0; k < 3; ++k) appendRaw(s, static_cast<float>(corner(v)[k]));
    appendRaw(s, std::uint16_t{0});
  }
  return s;
}

/// Checks that `mesh` is the cube: 8 welded corners, 12 triangles, outward, volume 0.125.
inline void expectCube(const TriangleMesh& mesh) {
  EXPECT_EQ(mesh.vertices.size(), 8u);
  EXPECT_EQ(mesh.faces.size(), 12u);
  EXPECT_NEAR(mesh.signedVolume(), 0.125, 1e-12);
  const auto [lo, hi] = mesh.bounds();
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(lo[k], 0.25);
    EXPECT_EQ(hi[k], 0.75);
  }
}

}  // namespace voxcut::test
