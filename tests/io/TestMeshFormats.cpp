// Good files in every format our readers handle: each reads to the expected triangles, in
// double precision, whatever optional parts the format allows.

#include <gtest/gtest.h>

#include <string>

#include "CubeFiles.h"
#include "TempDir.h"
#include "voxcut/io/MeshReader.h"

namespace voxcut {
namespace {

using test::TempDir;

/// The cube [0.25, 0.75]^3 as an OBJ using every corner form, negative indices, CRLF line
/// ends, tabs, comments, and the statements that do not change the surface.
std::string richCubeObj() {
  return "# comment line\r\n"
         "mtllib cube.mtl\r\n"
         "o cube\r\n"
         "v 0.25 0.25 0.25\r\n"
         "v\t0.75 0.25 0.25 1.0\r\n"   // with w
         "v 0.75 0.75 0.25 1 0 0\r\n"  // with a colour
         "v +0.25 0.75 0.25 # trailing comment\r\n"
         "v 0.25 0.25 0.75\r\n"
         "v 0.75 0.25 0.75\r\n"
         "v 0.75 0.75 0.75\r\n"
         "v 2.5e-1 0.75 0.75\r\n"
         "\r\n"
         "vt 0 0\r\nvt 1 0\r\nvn 0 0 1\r\nvp 0.5\r\n"
         "g sides\r\nusemtl red\r\ns off\r\n"
         "f 1 4 3 2\r\n"
         "f 5/1 6/2 7/1 8/2\r\n"
         "f 1//1 2//1 6//1 5//1\r\n"
         "f 4/1/1 8/2/1 7/1/1 3/2/1\r\n"
         "f -8 -4 -1 -5\r\n"  // 1 5 8 4, relative to the 8 vertices defined
         "s 1\r\n"
         "f -7/-1/-1 -6/-2/-1 -2/-1/-1 -3/-2/-1\r\n"  // 2 3 7 6
         "l 1 2\r\np 3\r\n";
}

TEST(MeshFormats, ObjEveryCornerForm) {
  test::expectCube(readMeshFromMemory(richCubeObj(), "obj"));
}

TEST(MeshFormats, ObjPolygonsAreFans) {
  const TriangleMesh mesh =
      readMeshFromMemory("v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf 1 2 3 4 5\n", "obj");
  ASSERT_EQ(mesh.faces.size(), 3u);
  EXPECT_EQ(mesh.faces[0], (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(mesh.faces[1], (std::array<int, 3>{0, 2, 3}));
  EXPECT_EQ(mesh.faces[2], (std::array<int, 3>{0, 3, 4}));
}

TEST(MeshFormats, ObjReadsDoublePrecision) {
  // 10000000.001 is not a float (the nearest is 10000000); 0.1 is the double nearest 1/10.
  const TriangleMesh mesh = readMeshFromMemory(
      "v 10000000.001 0.1 -1e-300\nv 10000000.002 0.1 0\nv 10000000.001 0.2 0\nf 1 2 3\n", "obj");
  ASSERT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.vertices[0].x(), 10000000.001);
  EXPECT_EQ(mesh.vertices[1].x(), 10000000.002);
  EXPECT_EQ(mesh.vertices[0].y(), 0.1);
  EXPECT_EQ(mesh.vertices[0].z(), -1e-300);
}

TEST(MeshFormats, ObjUnusedVerticesAreDroppedAndEqualOnesWelded) {
  const TriangleMesh mesh = readMeshFromMemory(
      "v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv -0 0 0\nv 1 1 0\nf 2 3 4\nf 5 6 3\n", "obj");
  EXPECT_EQ(mesh.vertices.size(), 4u);  // 9 9 9 unused; -0 0 0 welded to 0 0 0
  ASSERT_EQ(mesh.faces.size(), 2u);
  EXPECT_EQ(mesh.faces[1], (std::array<int, 3>{0, 3, 1}));
}

TEST(MeshFormats, StlBinaryWhoseHeaderSaysSolid) {
  std::string stl = test::cubeBinaryStl();
  stl.replace(0, 10, "solid cube");  // still binary: it holds non-text bytes
  test::expectCube(readMeshFromMemory(stl, "stl"));
}

TEST(MeshFormats, StlAsciiWithUtf8Name) {
  std::string text = test::cubeAsciiStl();
  text.replace(0, 10, "solid W\xc3\xbcrfel");
  test::expectCube(readMeshFromMemory(text, "stl"));
}

TEST(MeshFormats, StlAsciiSeveralSolidsAndCrlf) {
  std::string text = test::cubeAsciiStl();
  // Split after the sixth facet into two solids, and use CRLF line ends.
  std::size_t at = 0;
  for (int k = 0; k < 6; ++k) at = text.find("endfacet\n", at) + 9;
  text.insert(at, "endsolid a\n\nsolid b\n");
  std::string crlf;
  for (const char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  test::expectCube(readMeshFromMemory(crlf, "stl"));
}

TEST(MeshFormats, PlyAsciiWithExtraPropertiesAndElements) {
  std::string ply =
      "ply\nformat ascii 1.0\ncomment hand made\nobj_info cube\n"
      "element vertex 8\nproperty uchar red\nproperty double x\nproperty float y\n"
      "property list uchar float uv\nproperty int z\n"
      "element face 6\nproperty list uint8 uint32 vertex_index\nproperty float quality\n"
      "element edge 2\nproperty int vertex1\nproperty int vertex2\nend_header\n";
  // Integer z: the cube [0.25, 0.75] x [0.25, 0.75] x [1, 3] (z as int).
  for (const auto& c : test::kCubeCorners)
    ply += "7 " + std::to_string(c[0]) + " " + std::to_string(c[1]) + " 2 0.5 0.5 " +
           (c[2] < 0.5 ? "1" : "3") + "\n";
  for (const auto& q : test::kCubeQuads)
    ply += "4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) +
           " " + std::to_string(q[3]) + " 0.5\n";
  ply += "0 1\n\n1 2\n\n";
  const TriangleMesh mesh = readMeshFromMemory(ply, "ply");
  EXPECT_EQ(mesh.vertices.size(), 8u);
  EXPECT_EQ(mesh.faces.size(), 12u);
  EXPECT_NEAR(mesh.signedVolume(), 0.5 * 0.5 * 2.0, 1e-12);
}

TEST(MeshFormats, PlyBinaryBothByteOrders) {
  test::expectCube(readMeshFromMemory(test::cubeRichBinaryPly(false), "ply"));
  test::expectCube(readMeshFromMemory(test::cubeRichBinaryPly(true), "ply"));
}

TEST(MeshFormats, PlyBinaryReadsDoublePrecision) {
  for (const bool bigEndian : {false, true}) {
    const TriangleMesh mesh = readMeshFromMemory(test::cubeRichBinaryPly(bigEndian, 1e7), "ply");
    const auto [lo, hi] = mesh.bounds();
    EXPECT_EQ(lo.x(), 1e7 + 0.25);
    EXPECT_EQ(hi.x(), 1e7 + 0.75);
    EXPECT_NEAR(mesh.signedVolume(), 0.125, 1e-6);
  }
}

TEST(MeshFormats, PlyFacesBeforeVertices) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
      "3 0 1 2\n0 0 0\n1 0 0\n0 1 0\n";
  EXPECT_EQ(readMeshFromMemory(ply, "ply").faces.size(), 1u);
}

TEST(MeshFormats, OffVariants) {
  // Counts on the keyword's line, comments, blank lines, colours on vertices and faces.
  std::string off = "COFF 8 6 0 # counts\n\n";
  for (const auto& c : test::kCubeCorners)
    off += std::to_string(c[0]) + " " + std::to_string(c[1]) + " " + std::to_string(c[2]) +
           " 255 0 0 255\n";
  for (const auto& q : test::kCubeQuads)
    off += "4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) +
           " " + std::to_string(q[3]) + " 0.1 0.2 0.3\n";
  test::expectCube(readMeshFromMemory(off, "off"));
  // No keyword at all, and only two counts.
  std::string bare = test::cubeOff();
  bare.replace(0, bare.find('\n', 4) + 1, "# a cube\n8 6\n");
  test::expectCube(readMeshFromMemory(bare, "off"));
}

TEST(MeshFormats, ExtensionIsCaseInsensitive) {
  const TempDir dir;
  test::expectCube(readMesh(dir.write("CUBE.OBJ", test::cubeObj())));
  test::expectCube(readMesh(dir.write("cube.Ply", test::cubeRichBinaryPly(true))));
  test::expectCube(readMesh(dir.write("cube.StL", test::cubeBinaryStl())));
  test::expectCube(readMesh(dir.write("cube.oFF", test::cubeOff())));
  test::expectCube(readMeshFromMemory(test::cubeOff(), "OFF"));
}

}  // namespace
}  // namespace voxcut
