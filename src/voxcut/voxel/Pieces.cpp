#include "voxcut/voxel/Pieces.h"

namespace voxcut {

PieceLabels findPieces(const VoxelGrid& grid) {
  // Union-find with path halving; the root of a set is its lowest voxel index.
  const std::size_t n = grid.voxelCount();
  std::vector<std::uint32_t> parent(n);
  auto find = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::size_t v = 0; v < n; ++v) parent[v] = static_cast<std::uint32_t>(v);
  for (std::size_t v = 0; v < n; ++v) {
    if (!grid.occupied(v)) continue;
    for (int a = 0; a < 3; ++a) {
      if (!grid.connected(v, a)) continue;
      const std::uint32_t r0 = find(static_cast<std::uint32_t>(v));
      const std::uint32_t r1 = find(static_cast<std::uint32_t>(v + grid.stride(a)));
      if (r0 < r1)
        parent[r1] = r0;
      else if (r1 < r0)
        parent[r0] = r1;
    }
  }
  PieceLabels out;
  out.label.assign(n, -1);
  for (std::size_t v = 0; v < n; ++v) {
    if (!grid.occupied(v)) continue;
    const std::uint32_t r = find(static_cast<std::uint32_t>(v));
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
