#include "voxcut/cutting/Fragments.h"

#include <algorithm>
#include <unordered_map>
#include <unordered_set>

namespace voxcut {

namespace {

/// The voxel across link (v, a) in direction dir (+1 or -1), or false outside the grid.
bool across(const VoxelGrid& g, std::size_t v, int a, int dir, std::size_t& out) {
  Index3 c = g.coord(v);
  c[a] += dir;
  if (c[a] < 0 || c[a] >= g.dims()[a]) return false;
  out = g.index(c);
  return true;
}

/// The voxels connected to `start`, if fewer than `limit` (then also as a set in `inside`);
/// empty otherwise. Visits at most `limit` voxels.
std::vector<std::size_t> smallComponent(const VoxelGrid& g, std::size_t start, std::size_t limit,
                                        std::unordered_set<std::size_t>& inside) {
  inside.clear();
  inside.insert(start);
  std::vector<std::size_t> found{start};
  for (std::size_t k = 0; k < found.size(); ++k) {
    const std::size_t v = found[k];
    for (int a = 0; a < 3; ++a)
      for (int dir : {-1, 1}) {
        std::size_t w = 0;
        if (!across(g, v, a, dir, w)) continue;
        const std::uint64_t link = VoxelGrid::linkId(dir > 0 ? v : w, a);
        if (!g.connected(static_cast<std::size_t>(link / 3), static_cast<int>(link % 3))) continue;
        if (!inside.insert(w).second) continue;
        found.push_back(w);
        if (found.size() >= limit) return {};
      }
  }
  return found;
}

}  // namespace

std::vector<std::uint64_t> healSmallFragments(VoxelGrid& grid, std::vector<LinkCut>& cuts,
                                              std::size_t minVoxels) {
  std::vector<std::uint64_t> healed;
  if (minVoxels <= 1 || cuts.empty()) return healed;
  std::unordered_map<std::uint64_t, std::size_t> open;  // this frame's cut links still cut
  for (std::size_t k = 0; k < cuts.size(); ++k) open.emplace(cuts[k].link, k);
  std::unordered_set<std::size_t> inside;
  for (std::size_t k = 0; k < cuts.size(); ++k) {
    const auto v = static_cast<std::size_t>(cuts[k].link / 3);
    const int axis = static_cast<int>(cuts[k].link % 3);
    std::size_t w = 0;
    if (!across(grid, v, axis, 1, w)) continue;
    for (std::size_t end : {v, w}) {
      if (!grid.occupied(end)) continue;
      for (;;) {
        const std::vector<std::size_t> fragment = smallComponent(grid, end, minVoxels, inside);
        if (fragment.empty()) break;
        std::uint64_t best = ~std::uint64_t{0};
        for (std::size_t u : fragment)
          for (int a = 0; a < 3; ++a)
            for (int dir : {-1, 1}) {
              std::size_t x = 0;
              if (!across(grid, u, a, dir, x) || inside.count(x) != 0) continue;
              const std::uint64_t link = VoxelGrid::linkId(dir > 0 ? u : x, a);
              if (open.count(link) != 0) best = std::min(best, link);
            }
        if (best == ~std::uint64_t{0}) break;  // apart before this frame
        const LinkCut& lc = cuts[open.at(best)];
        grid.setConnected(static_cast<std::size_t>(best / 3), static_cast<int>(best % 3), true);
        if (lc.previous)
          grid.hermite().set(best, *lc.previous);
        else
          grid.hermite().erase(best);
        open.erase(best);
        healed.push_back(best);
      }
    }
  }
  std::sort(healed.begin(), healed.end());
  cuts.erase(std::remove_if(cuts.begin(), cuts.end(),
                            [&](const LinkCut& lc) {
                              return std::binary_search(healed.begin(), healed.end(), lc.link);
                            }),
             cuts.end());
  return healed;
}

}  // namespace voxcut
