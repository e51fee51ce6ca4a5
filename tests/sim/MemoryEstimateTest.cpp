// The memory estimate made before building a model (sim/MemoryEstimate.h).

#include <gtest/gtest.h>

#include "voxcut/core/Error.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/sim/MemoryEstimate.h"

namespace voxcut {
namespace {

MemoryEstimate estimate(const std::string& model, int resolution, MemoryEstimateParams p = {}) {
  p.resolution.resolution = resolution;
  return estimateModelMemory(loadModel(model).materials, p);
}

TEST(MemoryEstimate, BoxCountsFollowTheGrid) {
  const MemoryEstimate e = estimate("box:0.1,0.1,0.1", 102);
  EXPECT_EQ(e.frame.dims, (Index3{102, 102, 102}));
  EXPECT_EQ(e.resolution, 102);
  EXPECT_EQ(e.gridVoxels, 102u * 102 * 102);
  EXPECT_EQ(e.occupiedVoxels, 100u * 100 * 100);  // every voxel inside the box
  EXPECT_NEAR(static_cast<double>(e.surfaceLinks), 6.0 * 100 * 100, 1.0);  // one per face voxel
  EXPECT_EQ(e.elements, 13u * 13 * 13);  // level-3 elements of 8 voxels
  EXPECT_EQ(e.nodes, 14u * 14 * 14);
  // At least the grid's own 2 bytes per voxel, at most a few hundred.
  EXPECT_GT(e.bytes, 2 * e.gridVoxels);
  EXPECT_LT(e.bytes, 200 * e.gridVoxels);
}

TEST(MemoryEstimate, GrowsWithTheResolutionAndWhatIsBuilt) {
  const MemoryEstimate low = estimate("bunny", 101), high = estimate("bunny", 202);
  EXPECT_GT(high.bytes, 6 * low.bytes);  // about 8x: the grid's voxels
  MemoryEstimateParams sim;
  sim.cutting = sim.simulation = sim.factor = true;
  EXPECT_GT(estimate("bunny", 101, sim).bytes, low.bytes);
  MemoryEstimateParams baseline = sim;
  baseline.allActive = true;
  EXPECT_GT(estimate("bunny", 101, baseline).bytes, estimate("bunny", 101, sim).bytes);
  MemoryEstimateParams surfaceOnly;
  surfaceOnly.octrees = false;
  EXPECT_LT(estimate("bunny", 101, surfaceOnly).bytes, low.bytes);
  // The sphere holds fewer voxels than its bounding box: the volume bound is used.
  const MemoryEstimate sphere = estimate("sphere:0.05", 101);
  EXPECT_LT(sphere.occupiedVoxels, 99u * 99 * 99 * 7 / 10);
  EXPECT_GT(sphere.occupiedVoxels, 99u * 99 * 99 / 2);
}

TEST(MemoryEstimate, HugeGridIsEstimatedWithoutAllocating) {
  const MemoryEstimate e = estimate("box:0.1,0.1,0.1", 1024);
  EXPECT_EQ(e.gridVoxels, std::size_t{1} << 30);
  EXPECT_GT(e.bytes, std::size_t{30} << 30);
  EXPECT_THROW(checkMemory(e, std::size_t{16} << 30, "model"), InputError);
  EXPECT_NO_THROW(checkMemory(e, 0, "model"));  // no limit
  EXPECT_NO_THROW(checkMemory(e, e.bytes, "model"));
  try {
    checkMemory(e, std::size_t{16} << 30, "model");
  } catch (const InputError& err) {
    const std::string m = err.what();
    EXPECT_EQ(m.rfind("model needs about ", 0), 0u) << m;
    EXPECT_NE(m.find("GiB at resolution 1024 (grid 1024 x 1024 x 1024); the limit is 16.0 GiB"),
              std::string::npos)
        << m;
  }
}

TEST(MemoryEstimate, UnusableMeshesAreLeftToTheVoxelizer) {
  MaterialMesh m{"x", {}};
  EXPECT_EQ(estimateModelMemory({m}, {}).bytes, 0u);
  m.mesh.vertices = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0, std::nan(""), 0)};
  m.mesh.faces = {{0, 1, 2}};
  EXPECT_EQ(estimateModelMemory({m}, {}).bytes, 0u);
  m.mesh.vertices[2] = Vec3d(0, 1, 0);
  m.mesh.faces = {{0, 1, 7}};  // a face with an index out of range is skipped, never read
  EXPECT_EQ(estimateModelMemory({m}, {}).bytes, 0u);
  m.mesh.faces = {{0, 1, 7}, {0, 1, 2}};  // the valid faces still count
  EXPECT_GT(estimateModelMemory({m}, {}).bytes, 0u);
}

TEST(MemoryEstimate, ParsesSizes) {
  EXPECT_EQ(parseMemorySize("1048576", "--m"), 1048576u);
  EXPECT_EQ(parseMemorySize("512M", "--m"), std::size_t{512} << 20);
  EXPECT_EQ(parseMemorySize("8G", "--m"), std::size_t{8} << 30);
  EXPECT_EQ(parseMemorySize("8gib", "--m"), std::size_t{8} << 30);
  EXPECT_EQ(parseMemorySize("1.5K", "--m"), 1536u);
  EXPECT_EQ(parseMemorySize("2T", "--m"), std::size_t{2} << 40);
  EXPECT_EQ(parseMemorySize("100B", "--m"), 100u);
  for (const char* bad : {"", "G", "-1G", "0", "0.1", "1e9", "0x10", "inf", "nan", "8Q", "8GG",
                          " 8G", "8G ", "99999999E"})
    EXPECT_THROW((void)parseMemorySize(bad, "--m"), InputError) << bad;
  try {
    (void)parseMemorySize("lots", "--max-memory");
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--max-memory 'lots': ", 0), 0u) << e.what();
  }
}

TEST(MemoryEstimate, FormatsBytes) {
  EXPECT_EQ(formatBytes(812), "812 B");
  EXPECT_EQ(formatBytes(3482), "3.4 KiB");
  EXPECT_EQ(formatBytes(std::size_t{41} << 30), "41.0 GiB");
  EXPECT_EQ(formatBytes(std::size_t{500} << 20), "500 MiB");
}

TEST(MemoryEstimate, AvailableMemoryIsSomething) {
  // Every machine the tests run on says how much memory is left.
  EXPECT_GT(availableMemory(), std::size_t{1} << 20);
}

}  // namespace
}  // namespace voxcut
