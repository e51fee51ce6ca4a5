#pragma once
// Random voxel grids for the surface tests: random materials, link states and Hermite data.

#include <cmath>
#include <random>

#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut::test {

/// A grid with random materials and random link states: links between two occupied voxels are
/// connected with probability pConnect, every other link with material on a side is cut (no
/// Hermite data yet: addHermite). The padding layer stays empty.
inline VoxelGrid randomGrid(int n, double pOccupied, double pConnect, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  VoxelGrid g(Index3{n, n, n}, Vec3d::Zero(), 1.0);
  g.setMaterialNames({"a", "b"});
  for (int z = 1; z + 1 < n; ++z)
    for (int y = 1; y + 1 < n; ++y)
      for (int x = 1; x + 1 < n; ++x)
        if (U(rng) < pOccupied) g.setMaterial(g.index(x, y, z), U(rng) < 0.8 ? 1 : 2);
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a) {
      if (!g.hasLink(v, a)) continue;
      const bool o0 = g.occupied(v), o1 = g.occupied(v + g.stride(a));
      if (!o0 && !o1) continue;
      g.setConnected(v, a, o0 && o1 && U(rng) < pConnect);
    }
  return g;
}

/// Random Hermite data for a link along axis a.
inline Hermite randomHermite(int a, std::mt19937& rng) {
  std::uniform_real_distribution<double> U(0.0, 1.0);
  Hermite h;
  h.t = static_cast<float>(0.05 + 0.9 * U(rng));
  Vec3d nrm(U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5);
  nrm[a] = std::abs(nrm[a]) + 0.1;
  nrm.normalize();
  for (int i = 0; i < 3; ++i) h.n[i] = static_cast<float>(nrm[i]);
  return h;
}

/// Gives every disconnected link with material on a side random Hermite data.
inline void addHermite(VoxelGrid& g, unsigned seed) {
  std::mt19937 rng(seed);
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a)
      if (g.hasLink(v, a) && !g.connected(v, a) && (g.occupied(v) || g.occupied(v + g.stride(a))))
        g.hermite().set(VoxelGrid::linkId(v, a), randomHermite(a, rng));
}

/// randomGrid with Hermite data on every cut link: the hardest test of closedness there is.
inline VoxelGrid randomCutGrid(int n, double pOccupied, double pConnect, unsigned seed) {
  VoxelGrid g = randomGrid(n, pOccupied, pConnect, seed);
  addHermite(g, seed + 1000);
  return g;
}

}  // namespace voxcut::test
