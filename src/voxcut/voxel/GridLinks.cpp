#include "voxcut/voxel/GridLinks.h"

#include <algorithm>
#include <utility>
#include <vector>

#include "voxcut/core/Parallel.h"

namespace voxcut {
namespace {

// Per voxel row (y + dims.y z), whether it holds material.
std::vector<std::uint8_t> occupiedRows(const VoxelGrid& grid, const std::uint8_t* mat,
                                       bool threaded) {
  const Index3 d = grid.dims();
  const std::size_t nRows = static_cast<std::size_t>(d.y) * static_cast<std::size_t>(d.z);
  std::vector<std::uint8_t> rowOccupied(nRows, 0);
  parallelFor(
      0, nRows, 256,
      [&](std::size_t r0, std::size_t r1) {
        for (std::size_t r = r0; r < r1; ++r) {
          const std::uint8_t* row = mat + r * static_cast<std::size_t>(d.x);
          rowOccupied[r] = std::any_of(row, row + d.x, [](std::uint8_t m) { return m != 0; });
        }
      },
      threaded);
  return rowOccupied;
}

}  // namespace

void clearPadding(VoxelGrid& grid) {
  std::uint8_t* mat = grid.materialData();
  const Index3 d = grid.dims();
  for (int a = 0; a < 3; ++a)
    for (int side = 0; side < 2; ++side) {
      const int u = (a + 1) % 3, w = (a + 2) % 3;
      Index3 c;
      c[a] = side ? d[a] - 1 : 0;
      for (c[w] = 0; c[w] < d[w]; ++c[w])
        for (c[u] = 0; c[u] < d[u]; ++c[u]) mat[grid.index(c)] = 0;
    }
}

void buildLinks(VoxelGrid& grid, const LinkHermiteFn& hermiteOf, bool threaded) {
  const Index3 d = grid.dims();
  const std::uint8_t* mat = grid.materialData();
  std::uint8_t* links = grid.linkData();
  // Per z slice, its links between different materials with their Hermite data, in order.
  std::vector<std::vector<std::pair<std::uint64_t, Hermite>>> slices(static_cast<std::size_t>(d.z));
  const std::vector<std::uint8_t> rowOccupied = occupiedRows(grid, mat, threaded);
  parallelFor(
      0, static_cast<std::size_t>(d.z), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z)
          for (int y = 0; y < d.y; ++y) {
            // A row's links reach its own row, the next in y and the next in z.
            const std::size_t row = static_cast<std::size_t>(y) + static_cast<std::size_t>(d.y) * z;
            const bool busy =
                rowOccupied[row] || (y + 1 < d.y && rowOccupied[row + 1]) ||
                (static_cast<int>(z) + 1 < d.z && rowOccupied[row + static_cast<std::size_t>(d.y)]);
            if (!busy) continue;
            for (int x = 0; x < d.x; ++x) {
              const Index3 c{x, y, static_cast<int>(z)};
              const std::size_t v = grid.index(c);
              std::uint8_t bits = 0;
              for (int a = 0; a < 3; ++a) {
                if (c[a] + 1 >= d[a]) continue;
                const std::uint8_t m0 = mat[v], m1 = mat[v + grid.stride(a)];
                if (m0 == 0 && m1 == 0) continue;
                if (m0 != 0 && m1 != 0) bits = static_cast<std::uint8_t>(bits | (1u << a));
                if (m0 == m1) continue;
                slices[z].emplace_back(VoxelGrid::linkId(v, a), hermiteOf(c, a, m0, m1));
              }
              links[v] = bits;
            }
          }
      },
      threaded);
  std::size_t total = 0;
  for (const auto& s : slices) total += s.size();
  grid.hermite().reserve(total);
  for (const auto& s : slices)
    for (const auto& [id, h] : s) grid.hermite().set(id, h);
}

}  // namespace voxcut
