#include "voxcut/voxel/PlaneCut.h"

#include <algorithm>
#include <cmath>

#include "voxcut/core/Parallel.h"

namespace voxcut {

std::size_t cutWithPlane(VoxelGrid& grid, const Plane& plane, bool threaded) {
  const double len = plane.normal.norm();
  if (!(len > 0) || !std::isfinite(len) || !std::isfinite(plane.offset))
    throw InputError("cut plane needs a non-zero finite normal and a finite offset");
  const Vec3d n = plane.normal / len;
  const double d = plane.offset / len;
  const Index3 dims = grid.dims();
  std::vector<std::vector<std::pair<std::uint64_t, Hermite>>> slices(
      static_cast<std::size_t>(dims.z));
  parallelFor(
      0, slices.size(), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z)
          for (int y = 0; y < dims.y; ++y)
            for (int x = 0; x < dims.x; ++x) {
              const std::size_t v = grid.index(x, y, static_cast<int>(z));
              if (!grid.occupied(v)) continue;
              const double s0 = n.dot(grid.position(v)) - d;
              for (int a = 0; a < 3; ++a) {
                if (!grid.connected(v, a)) continue;
                const double s1 = n.dot(grid.position(v + grid.stride(a))) - d;
                if ((s0 < 0) == (s1 < 0)) continue;
                Hermite h;
                h.t = std::clamp(static_cast<float>(s0 / (s0 - s1)), 1e-3f, 1.f - 1e-3f);
                const float sg = n[a] < 0 ? -1.f : 1.f;
                for (int i = 0; i < 3; ++i) h.n[i] = sg * static_cast<float>(n[i]);
                slices[z].emplace_back(VoxelGrid::linkId(v, a), h);
              }
            }
      },
      threaded);
  std::size_t count = 0;
  for (const auto& s : slices)
    for (const auto& [id, h] : s) {
      const std::size_t v = static_cast<std::size_t>(id / 3);
      grid.setConnected(v, static_cast<int>(id % 3), false);
      grid.hermite().set(id, h);
      ++count;
    }
  return count;
}

}  // namespace voxcut
