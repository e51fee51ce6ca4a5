// Meshes read from files go through the voxelizer as read: in double precision, so a
// millimetre cube ten thousand kilometres from the origin keeps its shape, and a file
// whose triangles all have zero area is rejected naming the model.

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "CubeFiles.h"
#include "TempDir.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

using test::TempDir;

/// The cube of side `side` with its lowest corner at (x0, 0, 0), as OBJ with 17 digits.
std::string cubeAt(double x0, double side) {
  std::string s;
  char line[128];
  for (const auto& c : test::kCubeCorners) {
    // Corners are 0.25 or 0.75: map them to 0 or side.
    const double x = c[0] < 0.5 ? 0.0 : side, y = c[1] < 0.5 ? 0.0 : side,
                 z = c[2] < 0.5 ? 0.0 : side;
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", x0 + x, y, z);
    s += line;
  }
  for (const auto& q : test::kCubeQuads)
    s += "f " + std::to_string(q[0] + 1) + " " + std::to_string(q[1] + 1) + " " +
         std::to_string(q[2] + 1) + " " + std::to_string(q[3] + 1) + "\n";
  return s;
}

std::size_t occupied(const VoxelGrid& g) {
  std::size_t n = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) n += g.occupied(v);
  return n;
}

TEST(MeshVoxelizing, MillimetreCubeFarFromTheOrigin) {
  const TempDir dir;
  const double side = 0x1p-10;  // about 1 mm; 1e7 + side is exact in double
  for (const int resolution : {12, 34}) {
    SCOPED_TRACE(resolution);
    VoxelizeParams p;
    p.resolution.resolution = resolution;
    const Model far = loadModel(dir.write("far.obj", cubeAt(1e7, side)));
    const Model near = loadModel(dir.write("near.obj", cubeAt(0.0, side)));
    VoxelizeReport report;
    const VoxelGrid g = voxelize(far.materials, p, &report);
    const auto inner = static_cast<std::size_t>(resolution - 2);
    EXPECT_EQ(occupied(g), inner * inner * inner);
    EXPECT_TRUE(report.repairs[0].watertight);
    EXPECT_EQ(occupied(voxelize(near.materials, p)), occupied(g));
    EXPECT_NEAR(g.voxelSize(), side / static_cast<double>(inner), 1e-15);
    EXPECT_NEAR(g.origin().x(), 1e7 - 0.5 * g.voxelSize(), 4e-9);  // ulp(1e7) = 2^-29
  }
}

TEST(MeshVoxelizing, FileOfDegenerateTrianglesIsRejectedNamingTheMesh) {
  const TempDir dir;
  // Read as written (the reader keeps degenerate faces); the voxelizer drops them all.
  const std::string path =
      dir.write("sliver.obj", "v 0 0 0\nv 1 1 1\nv 2 2 2\nv 0 0 1\nf 1 2 3\nf 3 2 1\nf 4 4 1\n");
  const Model model = loadModel(path);
  ASSERT_EQ(model.materials.front().mesh.faces.size(), 3u);
  VoxelizeParams p;
  p.resolution.resolution = 16;
  try {
    (void)voxelize(model.materials, p);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mesh 'sliver'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace voxcut
