#include "voxcut/voxel/Pieces.h"

#include "voxcut/core/UnionFind.h"

namespace voxcut {

PieceLabels findPieces(const VoxelGrid& grid) {
  // Voxels joined through connected links; the root of a piece is its lowest voxel.
  const std::size_t n = grid.voxelCount();
  UnionFind sets(n);
  for (std::size_t v = 0; v < n; ++v) {
    if (!grid.occupied(v)) continue;
    for (int a = 0; a < 3; ++a)
      if (grid.connected(v, a))
        sets.unite(static_cast<std::uint32_t>(v), static_cast<std::uint32_t>(v + grid.stride(a)));
  }
  PieceLabels out;
  out.label.assign(n, -1);
  for (std::size_t v = 0; v < n; ++v) {
    if (!grid.occupied(v)) continue;
    const std::uint32_t r = sets.find(static_cast<std::uint32_t>(v));
    if (r == v) {
      out.label[v] = out.count++;
      out.voxels.push_back(0);
    } else {
      out.label[v] = out.label[r];
    }
    ++out.voxels[static_cast<std::size_t>(out.label[v])];
  }
  return out;
}

}  // namespace voxcut
