#pragma once
// Checks shared by the octree tests: the active voxel index array, its link table and the
// index map agree with the state bits.

#include <gtest/gtest.h>

#include "voxcut/octree/VoxelOctree.h"

namespace voxcut {

inline void expectActiveTablesConsistent(const VoxelGrid& g, const VoxelOctree& oct) {
  ASSERT_EQ(oct.activeIndex.size(), g.voxelCount());
  ASSERT_EQ(oct.activeNext.size(), oct.activeVoxels.size());
  std::size_t k = 0;
  ASSERT_TRUE(oct.changed.empty());
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    if (!oct.voxelActive(v)) {
      ASSERT_EQ(oct.activeIndex[v], kNoActive) << v;
      continue;
    }
    ASSERT_LT(k, oct.activeVoxels.size());
    ASSERT_EQ(oct.activeVoxels[k], v);
    ASSERT_EQ(oct.activeIndex[v], k);
    ++k;
  }
  ASSERT_EQ(k, oct.activeVoxels.size());
  for (std::size_t i = 0; i < oct.activeVoxels.size(); ++i) {
    const std::size_t v = oct.activeVoxels[i];
    for (int a = 0; a < 3; ++a) {
      const std::uint32_t next = oct.activeNext[i][static_cast<std::size_t>(a)];
      if (!oct.linkActive(v, a)) {
        ASSERT_EQ(next, kNoActive) << v << " " << a;
      } else {
        ASSERT_LT(next, oct.activeVoxels.size());
        ASSERT_EQ(oct.activeVoxels[next], v + g.stride(a)) << v << " " << a;
      }
    }
  }
}

}  // namespace voxcut
