// Coarsening after cuts (docs/algorithms.md, "Coarsening after cuts"): the leaves inside the
// given regions merge bottom up into their parents where the build's own rule would have made
// the parent, the 2:1 rule allows it, and (above the front level) no cut link would end up
// with both voxels in one part. The merged leaves are partitioned and their nodes regrouped by
// the same machinery as a cut (TopologyEditor::run).
#include <algorithm>

#include "voxcut/core/Error.h"
#include "voxcut/core/UnionFind.h"
#include "voxcut/topology/CutTopology.h"
#include "voxcut/topology/TopologyEditor.h"

namespace voxcut {

using namespace topology_detail;

std::vector<std::uint64_t> TopologyEditor::seedMerges(const std::vector<std::uint64_t>& regions,
                                                      const CoarsenRule& rule) {
  std::vector<std::uint64_t> blocked;
  // Passes until nothing merges: a region refused by 2:1 may be freed by a neighbouring
  // region's merges. Each pass that merges removes leaves, so this ends.
  std::vector<std::uint64_t> todo(regions);
  std::sort(todo.begin(), todo.end());
  todo.erase(std::unique(todo.begin(), todo.end()), todo.end());
  for (;;) {
    const std::size_t before = removed_.size() + removedCubes_.size() + pending_.size();
    std::vector<std::uint64_t> again;
    for (std::uint64_t k : todo) {
      bool refused = false;
      coarsenBelow(k, rule, refused);
      if (refused) again.push_back(k);
    }
    const std::size_t after = removed_.size() + removedCubes_.size() + pending_.size();
    todo = std::move(again);
    if (todo.empty() || after == before) break;
  }
  blocked = std::move(todo);
  return blocked;
}

TopologyEditor::Below TopologyEditor::coarsenBelow(std::uint64_t key, const CoarsenRule& rule,
                                                   bool& blocked) {
  if (leaves_.contains(key)) return Below::kLeaf;
  const int L = keyLevel(key);
  const Index3 f = keyFirstVoxel(key), gd = grid_.dims();
  if (L == 0 || f.x >= gd.x || f.y >= gd.y || f.z >= gd.z) return Below::kEmpty;
  // Inside a coarser leaf: nothing below to merge.
  buildTile(f);
  const std::uint64_t holder = leafOf(f);
  if (holder != kNoKey && keyLevel(holder) > L) return Below::kLeaf;
  bool inner = false, leaf = false;
  const int h = 1 << (L - 1);
  for (int c = 0; c < 8; ++c) {
    const Index3 cf = cornerPoint(f, h, c);
    const Below b = coarsenBelow(
        DeformationOctree::cubeKey(L - 1, {cf.x >> (L - 1), cf.y >> (L - 1), cf.z >> (L - 1)}), rule,
        blocked);
    inner = inner || b == Below::kInner;
    leaf = leaf || b == Below::kLeaf;
  }
  if (inner) return Below::kInner;
  if (!leaf) return Below::kEmpty;
  if (!mayMerge(key, rule, blocked)) return Below::kInner;
  merge(key);
  return Below::kLeaf;
}

bool TopologyEditor::mayMerge(std::uint64_t key, const CoarsenRule& rule, bool& blocked) {
  const int L = keyLevel(key);
  if (L > rule.startLevel) return false;
  const Index3 f = keyFirstVoxel(key), gd = grid_.dims();
  const int s = 1 << L;
  // The build's rule: above the surface level only a parent at least half full is an element.
  if (L > rule.surfaceLevel) {
    std::size_t occupied = 0;
    for (int z = f.z; z < std::min(f.z + s, gd.z); ++z)
      for (int y = f.y; y < std::min(f.y + s, gd.y); ++y)
        for (int x = f.x; x < std::min(f.x + s, gd.x); ++x)
          occupied += grid_.occupied(grid_.index(x, y, z)) ? 1 : 0;
    if (2 * occupied < static_cast<std::size_t>(s) * s * s) return false;
  }
  // 2:1: the children are of level L - 1 and balanced, so only a leaf of level L - 2 touching
  // the cube can break the rule; it holds exactly one point of the lattice of its size.
  if (L >= 2) {
    const int t = 1 << (L - 2);
    for (int z = f.z - t; z < f.z + s + t; z += t)
      for (int y = f.y - t; y < f.y + s + t; y += t)
        for (int x = f.x - t; x < f.x + s + t; x += t) {
          if (x >= f.x && x < f.x + s && y >= f.y && y < f.y + s && z >= f.z && z < f.z + s)
            continue;
          if (x < 0 || y < 0 || z < 0 || x >= gd.x || y >= gd.y || z >= gd.z) continue;
          buildTile({x, y, z});
          const std::uint64_t k = leafOf({x, y, z});
          if (k != kNoKey && keyLevel(k) < L - 1) {
            blocked = true;
            return false;
          }
        }
  }
  return L <= rule.frontLevel || !mergeGlues(key);
}

bool TopologyEditor::mergeGlues(std::uint64_t key) const {
  const Index3 f = keyFirstVoxel(key), gd = grid_.dims();
  const int s = 1 << keyLevel(key);
  const Index3 hi{std::min(f.x + s, gd.x), std::min(f.y + s, gd.y), std::min(f.z + s, gd.z)};
  std::vector<std::int32_t> local(static_cast<std::size_t>(s) * s * s, -1);
  auto li = [&](const Index3& c) {
    return static_cast<std::size_t>(c.x - f.x) +
           static_cast<std::size_t>(s) * (static_cast<std::size_t>(c.y - f.y) +
                                          static_cast<std::size_t>(s) *
                                              static_cast<std::size_t>(c.z - f.z));
  };
  std::vector<std::uint32_t> voxels;
  for (int z = f.z; z < hi.z; ++z)
    for (int y = f.y; y < hi.y; ++y)
      for (int x = f.x; x < hi.x; ++x) {
        const std::size_t v = grid_.index(x, y, z);
        if (!grid_.occupied(v)) continue;
        local[li({x, y, z})] = static_cast<std::int32_t>(voxels.size());
        voxels.push_back(static_cast<std::uint32_t>(v));
      }
  UnionFind uf(voxels.size());
  std::vector<std::pair<std::int32_t, std::int32_t>> cutPairs;
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    const Index3 c = grid_.coord(voxels[i]);
    for (int a = 0; a < 3; ++a) {
      if (c[a] + 1 >= hi[a]) continue;
      Index3 n = c;
      ++n[a];
      const std::int32_t j = local[li(n)];
      if (j < 0) continue;
      if (grid_.connected(voxels[i], a))
        uf.unite(static_cast<int>(i), j);
      else
        cutPairs.emplace_back(static_cast<std::int32_t>(i), j);
    }
  }
  for (const auto& [i, j] : cutPairs)
    if (uf.find(i) == uf.find(j)) return true;
  return false;
}

void TopologyEditor::merge(std::uint64_t key) {
  const int L = keyLevel(key);
  const Index3 f = keyFirstVoxel(key);
  const int h = 1 << (L - 1);
  for (int c = 0; c < 8; ++c) {
    const Index3 cf = cornerPoint(f, h, c);
    const std::uint64_t ck =
        DeformationOctree::cubeKey(L - 1, {cf.x >> (L - 1), cf.y >> (L - 1), cf.z >> (L - 1)});
    const auto it = oc_.cubeFirst_.find(ck);
    if (it == oc_.cubeFirst_.end()) continue;
    if (it->second != kNoElement) {
      for (std::uint32_t e = it->second; e != kNoElement; e = oc_.nextCopy_[e])
        removed_.push_back(e);
      removedCubes_.push_back(ck);
    } else if (auto p = partitioned_.find(ck); p != partitioned_.end()) {
      for (std::uint32_t id : p->second) copies_[id - oldElements_].alive = false;
      partitioned_.erase(p);
    }
    pending_.erase(ck);
    oc_.cubeFirst_.erase(it);
    leaves_.erase(ck);
  }
  oc_.cubeFirst_[key] = kNoElement;
  leaves_.set(key, kNoElement);
  setLeafLevels(f, 1 << L, L);
  pending_.insert(key);
  merged_.insert(key);
}

CoarsenResult coarsenCutTopology(DeformationOctree& octree, const VoxelGrid& grid,
                                 const std::vector<std::uint64_t>& regions,
                                 const CoarsenParams& params) {
  if (params.startLevel < 0 || params.startLevel > 7 || params.frontLevel < 0 ||
      params.surfaceLevel < 0)
    throw InputError("coarsening levels must be in [0, 7]");
  TopologyEditor editor(octree, grid, params.threaded);
  CoarsenRule rule{params.startLevel, params.surfaceLevel, params.frontLevel};
  CoarsenResult out;
  out.blocked = editor.seedMerges(regions, rule);
  if (editor.anythingDirty()) {
    out.change = editor.run();
    // The regions of merges the node rule undid: merging them again would be undone again.
    for (std::uint64_t k : editor.unmerged()) {
      const int L = keyLevel(k), up = params.startLevel - L;
      if (up < 0) continue;
      const Index3 f = keyFirstVoxel(k);
      out.unsettled.push_back(DeformationOctree::cubeKey(
          params.startLevel, {f.x >> params.startLevel, f.y >> params.startLevel,
                              f.z >> params.startLevel}));
    }
    std::sort(out.unsettled.begin(), out.unsettled.end());
    out.unsettled.erase(std::unique(out.unsettled.begin(), out.unsettled.end()),
                        out.unsettled.end());
    return out;
  }
  out.change = identityChange(octree);
  return out;
}

}  // namespace voxcut
