#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>

#include "CubeFiles.h"
#include "TempDir.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/BunnyData.h"
#include "voxcut/io/MeshReader.h"

namespace voxcut {
namespace {

using test::TempDir;

/// Runs `f`, expecting an InputError whose message is one line containing every `parts`.
void expectInputError(const std::function<void()>& f, std::initializer_list<std::string> parts) {
  try {
    f();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    for (const auto& part : parts) EXPECT_NE(message.find(part), std::string::npos) << message;
  }
}

/// Whether every directed edge is matched by its reverse exactly once (closed, oriented).
bool isClosedOriented(const TriangleMesh& mesh) {
  std::map<std::pair<int, int>, int> edges;
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k) ++edges[{f[k], f[(k + 1) % 3]}];
  for (const auto& [edge, count] : edges) {
    const auto reverse = edges.find({edge.second, edge.first});
    if (count != 1 || reverse == edges.end() || reverse->second != 1) return false;
  }
  return true;
}

TEST(MeshReader, BunnyFromMemory) {
  const TriangleMesh bunny = readMeshFromMemory(detail::kBunnyObj, "obj");
  EXPECT_EQ(bunny.vertices.size(), 1839u);
  EXPECT_EQ(bunny.faces.size(), 3674u);
  EXPECT_TRUE(isClosedOriented(bunny));
  EXPECT_GT(bunny.signedVolume(), 0.0);
  const auto [lo, hi] = bunny.bounds();
  EXPECT_NEAR(hi.x() - lo.x(), 0.158, 0.005);  // metres
}

TEST(MeshReader, ObjWithQuads) {
  const TempDir dir;
  test::expectCube(readMesh(dir.write("cube.obj", test::cubeObj())));
}

TEST(MeshReader, AsciiStlIsWelded) {
  const TempDir dir;
  test::expectCube(readMesh(dir.write("cube.stl", test::cubeAsciiStl())));
}

TEST(MeshReader, BinaryStlIsWelded) {
  const TempDir dir;
  test::expectCube(readMesh(dir.write("cube.stl", test::cubeBinaryStl())));
}

TEST(MeshReader, AsciiPlyWithQuads) {
  const TempDir dir;
  test::expectCube(readMesh(dir.write("cube.ply", test::cubeAsciiPly())));
}

TEST(MeshReader, BinaryPly) {
  const TempDir dir;
  test::expectCube(readMesh(dir.write("cube.ply", test::cubeBinaryPly())));
}

TEST(MeshReader, Off) {
  const TempDir dir;
  test::expectCube(readMesh(dir.write("cube.off", test::cubeOff())));
}

TEST(MeshReader, FromMemoryEachFormat) {
  test::expectCube(readMeshFromMemory(test::cubeObj(), "obj"));
  test::expectCube(readMeshFromMemory(test::cubeAsciiStl(), "stl"));
  test::expectCube(readMeshFromMemory(test::cubeBinaryStl(), "stl"));
  test::expectCube(readMeshFromMemory(test::cubeBinaryPly(), "ply"));
  test::expectCube(readMeshFromMemory(test::cubeOff(), "off"));
}

TEST(MeshReader, MergesObjectsAndDropsLines) {
  const TempDir dir;
  const std::string path = dir.write("two.obj",
                                     "o first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nl 1 2\n"
                                     "o second\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4 5 6\np 4\n");
  const TriangleMesh mesh = readMesh(path);
  EXPECT_EQ(mesh.faces.size(), 2u);
  EXPECT_EQ(mesh.vertices.size(), 6u);
}

TEST(MeshReader, KeepsDegenerateTriangles) {
  const TriangleMesh mesh =
      readMeshFromMemory("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n", "obj");
  EXPECT_EQ(mesh.faces.size(), 2u);  // the second is flat (collinear) and is kept
}

TEST(MeshReaderErrors, MissingFile) {
  const TempDir dir;
  const std::string path = dir.file("nothing.obj");
  expectInputError([&] { (void)readMesh(path); }, {path, "does not exist"});
}

TEST(MeshReaderErrors, Directory) {
  const TempDir dir;
  const std::string path = dir.file("folder.obj");
  std::filesystem::create_directory(path);
  expectInputError([&] { (void)readMesh(path); }, {path, "is a directory"});
}

TEST(MeshReaderErrors, EmptyFile) {
  const TempDir dir;
  const std::string path = dir.write("empty.obj", "");
  expectInputError([&] { (void)readMesh(path); }, {path, "is empty"});
}

TEST(MeshReaderErrors, Unreadable) {
  if (::geteuid() == 0) GTEST_SKIP() << "root reads any file";
  const TempDir dir;
  const std::string path = dir.write("locked.obj", test::cubeObj());
  std::filesystem::permissions(path, std::filesystem::perms::none);
  expectInputError([&] { (void)readMesh(path); }, {path, "cannot be opened"});
}

TEST(MeshReaderErrors, NoTriangles) {
  const TempDir dir;
  const std::pair<const char*, const char*> files[] = {
      {"points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"},
      {"pointPrimitive.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\np 1\np 2\n"},
      {"lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n"},
      {"zeroFaces.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n"},
      {"vertexOnly.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"},
      {"emptySolid.stl", "solid nothing\nendsolid nothing\n"},
  };
  for (const auto& [name, text] : files) {
    SCOPED_TRACE(name);
    const std::string path = dir.write(name, text);
    expectInputError([&] { (void)readMesh(path); }, {path, "has no triangles"});
  }
}

TEST(MeshReaderErrors, NonFiniteCoordinate) {
  const TempDir dir;
  const std::string nan = dir.write("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
  expectInputError([&] { (void)readMesh(nan); }, {nan, "non-finite"});
  const std::string inf = dir.write("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n");
  expectInputError([&] { (void)readMesh(inf); }, {inf, "non-finite"});
  const std::string ply = dir.write("nan.ply", test::cubeBinaryPly(std::nanf("")));
  expectInputError([&] { (void)readMesh(ply); }, {ply, "non-finite"});
}

TEST(MeshReaderErrors, IndexOutOfRange) {
  const TempDir dir;
  const std::string obj = dir.write("index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  expectInputError([&] { (void)readMesh(obj); }, {obj});
  const std::string ply = dir.write(
      "index.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n");
  expectInputError([&] { (void)readMesh(ply); }, {ply});
}

TEST(MeshReaderErrors, UnparsableFile) {
  const TempDir dir;
  const std::string unknown = dir.write("mesh.xyz", "this is not a mesh\n");
  expectInputError([&] { (void)readMesh(unknown); }, {unknown, "cannot read"});
  // Truncated files: the position where the data ends is named.
  const std::string stl = dir.write("truncated.stl", test::cubeBinaryStl().substr(0, 300));
  expectInputError([&] { (void)readMesh(stl); }, {stl, "byte 80", "declares 12 triangles"});
  const std::string fullStl = test::cubeAsciiStl();
  std::size_t cut = 0;
  for (int line = 0; line < 5; ++line) cut = fullStl.find('\n', cut) + 1;
  const std::string asciiStl = dir.write("truncated-ascii.stl", fullStl.substr(0, cut));
  expectInputError([&] { (void)readMesh(asciiStl); }, {asciiStl, "line 5", "inside a facet"});
  const std::string ply = dir.write("truncated.ply", test::cubeBinaryPly().substr(0, 400));
  expectInputError([&] { (void)readMesh(ply); }, {ply, "byte ", "'face' element"});
  const std::string off = dir.write("truncated.off", "OFF\n3 1 0\n0 0 0\n1 0\n");
  expectInputError([&] { (void)readMesh(off); }, {off, "line 4", "x y z needed"});
}

TEST(MeshReaderErrors, FromMemory) {
  expectInputError([] { (void)readMeshFromMemory("", "obj"); }, {"in-memory mesh (obj)", "empty"});
  expectInputError([] { (void)readMeshFromMemory("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "obj"); },
                   {"no triangles"});
  expectInputError(
      [] { (void)readMeshFromMemory("v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "obj"); },
      {"non-finite"});
}

}  // namespace
}  // namespace voxcut
