#include <algorithm>
#include <numeric>
#include <tuple>

#include "voxcut/surface/SurfaceMesh.h"

namespace voxcut {
namespace {

int findRoot(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

}  // namespace

SurfaceTopology surfaceTopology(const SurfaceMesh& mesh) {
  SurfaceTopology topo;
  const int nv = static_cast<int>(mesh.positions.size());
  struct Half {
    int lo, hi;
    bool forward;
    bool operator<(const Half& o) const {
      return std::tie(lo, hi, forward) < std::tie(o.lo, o.hi, o.forward);
    }
  };
  std::vector<Half> halves;
  halves.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const int i = t[k], j = t[(k + 1) % 3];
      halves.push_back({std::min(i, j), std::max(i, j), i < j});
    }
  std::sort(halves.begin(), halves.end());
  bool closed = !mesh.triangles.empty() && halves.size() % 2 == 0;
  std::size_t edges = 0;
  for (std::size_t s = 0; closed && s < halves.size(); s += 2) {
    const bool pair = halves[s].lo == halves[s + 1].lo && halves[s].hi == halves[s + 1].hi &&
                      !halves[s].forward && halves[s + 1].forward;
    const bool third = s + 2 < halves.size() && halves[s + 2].lo == halves[s].lo &&
                       halves[s + 2].hi == halves[s].hi;
    if (!pair || third || halves[s].lo == halves[s].hi) closed = false;
    ++edges;
  }
  topo.closed = closed;

  // Pieces through shared vertices; Euler characteristic per piece.
  std::vector<int> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<char> used(nv, 0);
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      used[t[k]] = 1;
      const int a = findRoot(parent, t[k]), b = findRoot(parent, t[(k + 1) % 3]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<long> chi(nv, 0);
  for (int v = 0; v < nv; ++v)
    if (used[v]) {
      ++chi[findRoot(parent, v)];
      if (findRoot(parent, v) == v) ++topo.pieces;
    }
  for (const auto& t : mesh.triangles) ++chi[findRoot(parent, t[0])];
  if (closed) {
    for (std::size_t s = 0; s < halves.size(); s += 2) --chi[findRoot(parent, halves[s].lo)];
    for (int v = 0; v < nv; ++v)
      if (used[v] && findRoot(parent, v) == v) topo.genusSum += static_cast<int>((2 - chi[v]) / 2);
  }
  (void)edges;

  // Vertex manifoldness: the triangles around each vertex form one cycle.
  bool manifold = closed;
  if (manifold) {
    std::vector<std::array<int, 3>> corner;  // (vertex, next, prev) per triangle corner
    corner.reserve(3 * mesh.triangles.size());
    for (const auto& t : mesh.triangles)
      for (int k = 0; k < 3; ++k) corner.push_back({t[k], t[(k + 1) % 3], t[(k + 2) % 3]});
    std::sort(corner.begin(), corner.end());
    for (std::size_t s = 0; manifold && s < corner.size();) {
      std::size_t e = s;
      while (e < corner.size() && corner[e][0] == corner[s][0]) ++e;
      // Follow next -> prev links: starting at corner s, the fan must visit all e - s corners.
      std::size_t steps = 0;
      int cur = corner[s][1];
      const int start = cur;
      do {
        auto it = std::find_if(corner.begin() + static_cast<long>(s),
                               corner.begin() + static_cast<long>(e),
                               [&](const std::array<int, 3>& c) { return c[2] == cur; });
        if (it == corner.begin() + static_cast<long>(e)) {
          manifold = false;
          break;
        }
        cur = (*it)[1];
        ++steps;
      } while (cur != start && steps <= e - s);
      if (steps != e - s) manifold = false;
      s = e;
    }
  }
  topo.manifold = manifold;
  return topo;
}

}  // namespace voxcut
