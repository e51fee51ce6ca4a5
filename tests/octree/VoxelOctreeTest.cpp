#include <gtest/gtest.h>

#include "ActiveTables.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/octree/VoxelOctree.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

const VoxelGrid& bunny() {
  static const VoxelGrid g = [] {
    VoxelizeParams p;
    p.resolution.resolution = 101;
    return voxelize(loadModel("bunny").materials, p);
  }();
  return g;
}

const VoxelGrid& liver() {
  static const VoxelGrid g = [] {
    VoxelizeParams p;
    p.resolution.resolution = 100;
    return voxelize(loadModel("liver").materials, p);
  }();
  return g;
}

std::size_t at(const std::vector<std::size_t>& v, int level) {
  return level <= static_cast<int>(v.size()) ? v[level - 1] : 0;
}

TEST(VoxelOctree, CubeCountsFollowTheOctreeArithmetic) {
  // Paper Table 2: cubes at max level L, minus 8 x cubes of level L+1 at max level L+1,
  // equals cubes of level L at max level L+1.
  std::vector<std::vector<std::size_t>> counts;
  for (int max = 1; max <= 4; ++max)
    counts.push_back(buildVoxelOctree(bunny(), OctreeParams::uniform(1, max, 0)).cubesPerLevel());
  for (int max = 1; max < 4; ++max) {
    EXPECT_EQ(at(counts[max - 1], max), 8 * at(counts[max], max + 1) + at(counts[max], max))
        << "max " << max;
    // Lower levels do not change when the limit rises.
    for (int level = 1; level < max; ++level)
      EXPECT_EQ(at(counts[max - 1], level), at(counts[max], level))
          << "max " << max << " level " << level;
  }
  EXPECT_GT(at(counts[0], 1), 10000u);
  EXPECT_GT(at(counts[3], 4), 0u);
}

TEST(VoxelOctree, CubesAreSolidDisjointAndMaximal) {
  const VoxelGrid& g = bunny();
  const VoxelOctree oct = buildVoxelOctree(g, OctreeParams::uniform(1, 4, 0));
  std::vector<int> cover(g.voxelCount(), 0);
  for (std::size_t c = 0; c < oct.cubes.size(); ++c) {
    const OctreeCube& cube = oct.cubes[c];
    const int s = 1 << cube.level;
    for (int a = 0; a < 3; ++a) ASSERT_EQ(cube.origin[a] % s, 0);
    for (int z = 0; z <= s; ++z)
      for (int y = 0; y <= s; ++y)
        for (int x = 0; x <= s; ++x) {
          const std::size_t v = g.index(cube.origin.x + x, cube.origin.y + y, cube.origin.z + z);
          ASSERT_TRUE(g.occupied(v));
          const int d[3] = {x, y, z};
          for (int a = 0; a < 3; ++a) {
            if (d[a] < s) {
              ASSERT_TRUE(g.connected(v, a));
            }
          }
          if (x < s && y < s && z < s) {
            ++cover[v];
            ASSERT_EQ(oct.cellCube[v], static_cast<std::int32_t>(c));
          }
        }
  }
  for (std::size_t v = 0; v < g.voxelCount(); ++v) ASSERT_EQ(cover[v] > 0, oct.cellCube[v] >= 0);
  for (int c : cover) ASSERT_LE(c, 1);
}

TEST(VoxelOctree, ActivationMarksShellAndFrameOnly) {
  const VoxelGrid& g = bunny();
  const VoxelOctree oct = buildVoxelOctree(g, OctreeParams::uniform(1, 3, 0));
  const Index3 d = g.dims();
  // Links on cube edges are active.
  std::vector<std::uint8_t> edge(g.voxelCount(), 0);
  for (const OctreeCube& cube : oct.cubes) {
    const int s = 1 << cube.level;
    for (int a = 0; a < 3; ++a) {
      const int u = (a + 1) % 3, w = (a + 2) % 3;
      for (int cu = 0; cu <= s; cu += s)
        for (int cw = 0; cw <= s; cw += s)
          for (int i = 0; i < s; ++i) {
            Index3 p = cube.origin;
            p[u] += cu;
            p[w] += cw;
            p[a] += i;
            edge[g.index(p)] |= static_cast<std::uint8_t>(1u << a);
          }
    }
  }
  std::size_t inactive = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    const Index3 c = g.coord(v);
    for (int a = 0; a < 3; ++a) {
      if (!g.connected(v, a)) {
        ASSERT_FALSE(oct.linkActive(v, a));
        continue;
      }
      const int u = (a + 1) % 3, w = (a + 2) % 3;
      bool surrounded = true;
      for (int k = 0; k < 4; ++k) {
        Index3 cell = c;
        cell[u] -= k & 1;
        cell[w] -= k >> 1;
        surrounded = surrounded && cell[u] >= 0 && cell[w] >= 0 && oct.cellCube[g.index(cell)] >= 0;
      }
      const bool expected = !surrounded || ((edge[v] >> a) & 1);
      ASSERT_EQ(oct.linkActive(v, a), expected);
      inactive += !expected;
    }
    bool touched = (oct.state[v] & 7u) != 0;
    for (int a = 0; a < 3; ++a)
      touched = touched || (c[a] > 0 && oct.linkActive(v - g.stride(a), a));
    ASSERT_EQ(oct.voxelActive(v), touched);
  }
  EXPECT_GT(inactive, 100000u);
  // The index array lists exactly the active voxels, in order.
  std::size_t k = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    if (oct.voxelActive(v)) {
      ASSERT_EQ(oct.activeVoxels[k++], v);
    }
  EXPECT_EQ(k, oct.activeVoxels.size());
  expectActiveTablesConsistent(g, oct);
  (void)d;
}

TEST(VoxelOctree, BoundaryLevelZeroKeepsMaterialsApart) {
  const VoxelGrid& g = liver();
  const VoxelOctree oct = buildVoxelOctree(g, OctreeParams::uniform(2, 4, 0));
  ASSERT_FALSE(oct.cubes.empty());
  for (const OctreeCube& cube : oct.cubes) {
    const int s = 1 << cube.level;
    const std::uint8_t m = g.material(g.index(cube.origin));
    for (int z = 0; z <= s; ++z)
      for (int y = 0; y <= s; ++y)
        for (int x = 0; x <= s; ++x)
          ASSERT_EQ(g.material(g.index(cube.origin.x + x, cube.origin.y + y, cube.origin.z + z)),
                    m);
  }
  // Per-material limits: no tumor cubes when its internal level is 0.
  OctreeParams p = OctreeParams::uniform(2, 4, 0);
  p.maxInternalLevel[1] = 0;
  for (const OctreeCube& cube : buildVoxelOctree(g, p).cubes) {
    ASSERT_EQ(g.material(g.index(cube.origin)), 1);
  }
}

TEST(VoxelOctree, BaselineActivatesEverything) {
  const VoxelGrid& g = bunny();
  const VoxelOctree all = allActive(g);
  std::size_t links = 0, voxels = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    voxels += g.occupied(v);
    for (int a = 0; a < 3; ++a) {
      links += g.connected(v, a);
      ASSERT_EQ(all.linkActive(v, a), g.connected(v, a));
    }
  }
  EXPECT_EQ(all.activeVoxels.size(), voxels);
  EXPECT_EQ(all.activeLinkCount(), links);
  expectActiveTablesConsistent(g, all);
  // Level 0 everywhere is the baseline too.
  const VoxelOctree none = buildVoxelOctree(g, OctreeParams::uniform(1, 0, 0));
  EXPECT_TRUE(none.cubes.empty());
  EXPECT_EQ(none.activeLinkCount(), links);
}

TEST(VoxelOctree, SameForAnyThreadCount) {
  const VoxelGrid& g = liver();
  VoxelOctree a, b;
  {
    ThreadLimit one(1);
    a = buildVoxelOctree(g, OctreeParams::uniform(2, 4, 1));
  }
  {
    ThreadLimit two(2);
    b = buildVoxelOctree(g, OctreeParams::uniform(2, 4, 1));
  }
  ASSERT_EQ(a.cubes.size(), b.cubes.size());
  for (std::size_t c = 0; c < a.cubes.size(); ++c) {
    ASSERT_EQ(a.cubes[c].origin, b.cubes[c].origin);
    ASSERT_EQ(a.cubes[c].level, b.cubes[c].level);
  }
  ASSERT_EQ(a.state, b.state);
  ASSERT_EQ(a.activeVoxels, b.activeVoxels);
}

TEST(VoxelOctree, RejectsBadLevels) {
  EXPECT_THROW((void)buildVoxelOctree(bunny(), OctreeParams::uniform(1, -1, 0)), InputError);
  EXPECT_THROW((void)buildVoxelOctree(bunny(), OctreeParams::uniform(0, 1, 0)), InputError);
}

}  // namespace
}  // namespace voxcut
