#include "voxcut/linalg/BlockSparsity.h"

#include "voxcut/core/Error.h"

namespace voxcut {

std::vector<std::uint32_t> blockMirrors(const BlockSparsity& sp) {
  // Row k's columns ascend, so walking the rows in order meets the slots (i, k) of a fixed
  // column k in ascending i.
  const std::size_t rows = sp.diagonal.size();
  std::vector<std::uint32_t> mirror(sp.blockCount(), 0);
  std::vector<std::uint32_t> next(sp.rowStart.begin(), sp.rowStart.end() - 1);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s) {
      const std::uint32_t k = sp.column[s];
      const std::uint32_t m = next[k]++;
      VOXCUT_ASSERT(sp.column[m] == i, "the sparsity is not symmetric");
      mirror[s] = m;
    }
  return mirror;
}

}  // namespace voxcut
