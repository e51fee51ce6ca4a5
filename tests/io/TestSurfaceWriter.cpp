#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "TempDir.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/MeshReader.h"
#include "voxcut/io/SurfaceWriter.h"

namespace voxcut {
namespace {

using test::TempDir;
namespace fs = std::filesystem;

/// An octahedron of radius 0.1 m around (1/3, 0.2, -0.7): coordinates not exact in binary.
SurfaceMesh octahedron() {
  SurfaceMesh m;
  const Vec3d centre(1.0 / 3.0, 0.2, -0.7);
  const Vec3d axes[6] = {Vec3d::UnitX(),  -Vec3d::UnitX(), Vec3d::UnitY(),
                         -Vec3d::UnitY(), Vec3d::UnitZ(),  -Vec3d::UnitZ()};
  for (const Vec3d& a : axes) {
    m.positions.push_back(centre + 0.1 * a);
    m.normals.push_back(a);
    m.vertexVoxel.push_back(m.positions.size());
  }
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                 {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return m;
}

/// A height field of (n-1)^2 * 2 triangles in a 0.2 m square.
SurfaceMesh grid(int n) {
  SurfaceMesh m;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = 0.2 * i / (n - 1), y = 0.2 * j / (n - 1);
      m.positions.emplace_back(x, y, 0.01 * std::sin(40.0 * x) * std::cos(30.0 * y));
      m.normals.push_back(Vec3d::UnitZ());
    }
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j, b = a + 1, c = a + n, d = c + 1;
      m.triangles.push_back({a, c, d});
      m.triangles.push_back({a, d, b});
    }
  return m;
}

std::string readFile(const std::string& path) {
  std::string bytes(fs::file_size(path), '\0');
  std::ifstream(path, std::ios::binary)
      .read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return bytes;
}

/// The file names in `dir`.
std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename());
  return names;
}

/// Checks that `read` has `written`'s triangles, corner by corner, within `tolerance`.
void expectSameSurface(const SurfaceMesh& written, const TriangleMesh& read, double tolerance) {
  ASSERT_EQ(read.faces.size(), written.triangles.size());
  EXPECT_EQ(read.vertices.size(), written.positions.size());
  for (std::size_t t = 0; t < read.faces.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Vec3d& expected = written.positions[written.triangles[t][k]];
      const Vec3d& actual = read.vertices[read.faces[t][k]];
      ASSERT_LE((expected - actual).norm(), tolerance) << "triangle " << t << " corner " << k;
    }
}

TEST(SurfaceWriter, ObjRoundTrip) {
  const TempDir dir;
  const SurfaceMesh mesh = octahedron();
  const std::string path = dir.file("octahedron.obj");
  writeSurface(mesh, path);
  EXPECT_EQ(listing(dir.path()), std::vector<std::string>{"octahedron.obj"});
  expectSameSurface(mesh, readMesh(path), 1e-7);  // assimp reads floats

  // The text holds the doubles exactly, in order, with one normal per vertex.
  std::istringstream text(readFile(path));
  std::string line;
  std::size_t v = 0, vn = 0, f = 0;
  while (std::getline(text, line)) {
    std::istringstream words(line);
    std::string tag;
    words >> tag;
    if (tag == "v") {
      for (int k = 0; k < 3; ++k) {
        std::string number;
        words >> number;
        EXPECT_EQ(std::strtod(number.c_str(), nullptr), mesh.positions[v][k]);
      }
      ++v;
    } else if (tag == "vn") {
      ++vn;
    } else if (tag == "f") {
      if (f == 0) {
        EXPECT_EQ(line, "f 1//1 3//3 5//5");
      }
      ++f;
    }
  }
  EXPECT_EQ(v, 6u);
  EXPECT_EQ(vn, 6u);
  EXPECT_EQ(f, 8u);
}

TEST(SurfaceWriter, PlyRoundTrip) {
  const TempDir dir;
  const SurfaceMesh mesh = octahedron();
  const std::string path = dir.file("octahedron.ply");
  writeSurface(mesh, path);
  EXPECT_EQ(listing(dir.path()), std::vector<std::string>{"octahedron.ply"});
  expectSameSurface(mesh, readMesh(path), 1e-7);

  const std::string bytes = readFile(path);
  ASSERT_EQ(bytes.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(bytes.find("property float nz\n"), std::string::npos);
  const std::string end = "end_header\n";
  const std::size_t header = bytes.find(end) + end.size();
  EXPECT_EQ(bytes.size(), header + 6 * 6 * sizeof(float) + 8 * (1 + 3 * sizeof(int)));
}

TEST(SurfaceWriter, WithoutNormals) {
  const TempDir dir;
  SurfaceMesh mesh = octahedron();
  mesh.normals.clear();
  writeSurface(mesh, dir.file("a.obj"));
  writeSurface(mesh, dir.file("a.ply"));
  const std::string obj = readFile(dir.file("a.obj"));
  EXPECT_EQ(obj.find("vn "), std::string::npos);
  EXPECT_NE(obj.find("\nf 1 3 5\n"), std::string::npos);
  EXPECT_EQ(readFile(dir.file("a.ply")).find("nx"), std::string::npos);
  expectSameSurface(mesh, readMesh(dir.file("a.obj")), 1e-7);
  expectSameSurface(mesh, readMesh(dir.file("a.ply")), 1e-7);
}

TEST(SurfaceWriter, UppercaseExtensionAndOverwrite) {
  const TempDir dir;
  const std::string path = dir.write("old.OBJ", "previous contents");
  writeSurface(octahedron(), path);
  EXPECT_EQ(listing(dir.path()), std::vector<std::string>{"old.OBJ"});
  EXPECT_EQ(readMesh(path).faces.size(), 8u);
}

TEST(SurfaceWriter, LargeSurfaceRoundTrip) {
  const TempDir dir;
  const SurfaceMesh mesh = grid(275);  // 75,625 vertices, 150,152 triangles
  for (const char* name : {"large.obj", "large.ply"}) {
    const std::string path = dir.file(name);
    const auto start = std::chrono::steady_clock::now();
    writeSurface(mesh, path);
    const std::chrono::duration<double, std::milli> ms = std::chrono::steady_clock::now() - start;
    RecordProperty(std::string("write_ms_") + name, std::to_string(ms.count()));
    expectSameSurface(mesh, readMesh(path), 1e-7);
  }
  EXPECT_EQ(listing(dir.path()).size(), 2u);  // no temporaries
}

TEST(SurfaceWriterErrors, UnknownExtension) {
  const TempDir dir;
  for (const char* name : {"surface.stl", "surface", "surface.obj.gz"}) {
    const std::string path = dir.file(name);
    try {
      writeSurface(octahedron(), path);
      ADD_FAILURE() << "no InputError for " << path;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("unknown extension"), std::string::npos) << e.what();
    }
  }
  EXPECT_TRUE(listing(dir.path()).empty());
}

TEST(SurfaceWriterErrors, MissingDirectory) {
  const TempDir dir;
  const std::string path = dir.file("missing/surface.obj");
  try {
    writeSurface(octahedron(), path);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(listing(dir.path()).empty());
}

TEST(SurfaceWriterErrors, PathIsADirectory) {
  const TempDir dir;
  const std::string path = dir.file("taken.ply");
  fs::create_directory(path);
  EXPECT_THROW(writeSurface(octahedron(), path), InputError);
  EXPECT_TRUE(fs::is_directory(path));
  EXPECT_EQ(listing(dir.path()), std::vector<std::string>{"taken.ply"});
}

TEST(SurfaceWriterErrors, ReadOnlyDirectory) {
  if (::geteuid() == 0) GTEST_SKIP() << "root writes anywhere";
  const TempDir dir;
  const fs::path locked = dir.path() / "locked";
  fs::create_directory(locked);
  fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
  EXPECT_THROW(writeSurface(octahedron(), (locked / "s.obj").string()), InputError);
  fs::permissions(locked, fs::perms::owner_all);
  EXPECT_TRUE(listing(locked).empty());
}

TEST(SurfaceWriterErrors, WriteFailureLeavesNoTemporary) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  // A temporary that is a link to /dev/full makes every write fail (disk full).
  const TempDir dir;
  const std::string path = dir.file("full.obj");
  fs::create_symlink("/dev/full", path + ".tmp");
  const SurfaceMesh mesh = grid(300);  // more than one buffer's worth
  EXPECT_THROW(writeSurface(mesh, path), InputError);
  EXPECT_TRUE(listing(dir.path()).empty());
}

TEST(SurfaceWriterDeathTest, NormalCountMismatch) {
  SurfaceMesh mesh = octahedron();
  mesh.normals.pop_back();
  EXPECT_DEATH(writeSurface(mesh, "unused.obj"), "one normal per position");
}

}  // namespace
}  // namespace voxcut
