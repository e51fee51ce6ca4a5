#include "voxcut/topology/TopologyEditor.h"

#include <algorithm>

#include "voxcut/core/Parallel.h"

namespace voxcut {

using namespace topology_detail;

void TopologyEditor::dirtyPoints(std::vector<std::uint64_t>& keys,
                                 std::vector<std::array<std::uint64_t, 8>>& around) {
  // Points seen, one bit per node-grid point (leaves reach at most 2^maxLevel - 1 past the
  // grid).
  const Index3 gd = grid_.dims();
  const int pad = (1 << oc_.maxLevel_) + 1;
  const std::size_t nx = static_cast<std::size_t>(gd.x + pad),
                    ny = static_cast<std::size_t>(gd.y + pad);
  std::vector<std::uint64_t>& seen = seenPoints_;
  seen.resize((nx * ny * static_cast<std::size_t>(gd.z + pad) + 63) / 64, 0);
  std::vector<std::uint64_t> pts;
  auto add = [&](const Index3& p) {
    const std::size_t i = static_cast<std::size_t>(p.x) +
                          nx * (static_cast<std::size_t>(p.y) + ny * static_cast<std::size_t>(p.z));
    const std::uint64_t bit = std::uint64_t{1} << (i & 63);
    if (seen[i >> 6] & bit) return;
    seen[i >> 6] |= bit;
    pts.push_back(pointKey(p));
  };
  auto add27 = [&](std::uint64_t key) {
    const Index3 f = keyFirstVoxel(key);
    const int s = 1 << keyLevel(key), step = s == 1 ? 1 : s / 2;
    for (int z = 0; z <= s; z += step)
      for (int y = 0; y <= s; y += step)
        for (int x = 0; x <= s; x += step) add({f.x + x, f.y + y, f.z + z});
  };
  // The leaves around points [from, pts.size()), after building the tiles they read (serial).
  std::vector<std::array<std::uint64_t, 8>> leaves;
  auto findLeaves = [&](std::size_t from) {
    constexpr int m = kTileSize - 1;
    for (std::size_t i = from; i < pts.size(); ++i) {
      const Index3 p = pointOf(pts[i]);
      if ((p.x & m) != 0 && (p.y & m) != 0 && (p.z & m) != 0)
        buildTile(p);  // one tile holds all 8
      else
        for (int d = 0; d < 8; ++d)
          buildTile({p.x - 1 + (d & 1), p.y - 1 + ((d >> 1) & 1), p.z - 1 + (d >> 2)});
    }
    leaves.resize(pts.size());
    parallelFor(
        from, pts.size(), 256,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t i = b; i < e; ++i) leaves[i] = leavesAround(pointOf(pts[i]));
        },
        threaded_);
  };
  for (const auto& kv : partitioned_) add27(kv.first);
  for (std::uint64_t k : removedCubes_) add27(k);
  const std::size_t first = pts.size();
  findLeaves(0);
  // The leaves touching those points: their hanging nodes' masters may have changed. Only
  // their edge midpoints and face centres can hold such nodes.
  FlatHashMap<std::uint8_t> cubeSeen;
  cubeSeen.reserve(first / 2 + 8);
  for (std::size_t i = 0; i < first; ++i)
    for (std::size_t d = 0; d < 8; ++d) {
      const std::uint64_t k = leaves[i][d];
      if (k == kNoKey || (d > 0 && k == leaves[i][d - 1]) || !cubeSeen.insert(k)) continue;
      const int L = keyLevel(k);
      if (L == 0) continue;
      const Index3 f = keyFirstVoxel(k);
      const int s = 1 << L, h = s / 2;
      for (int z = 0; z <= s; z += h)
        for (int y = 0; y <= s; y += h)
          for (int x = 0; x <= s; x += h) {
            const int mid = (x == h) + (y == h) + (z == h);
            if (mid == 1 || mid == 2) add({f.x + x, f.y + y, f.z + z});
          }
    }
  findLeaves(first);
  // Ascending point keys (distinct); the bitmap is left clear for the next round.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> order(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    order[i] = {pts[i], static_cast<std::uint32_t>(i)};
    const Index3 p = pointOf(pts[i]);
    seen[(static_cast<std::size_t>(p.x) +
          nx * (static_cast<std::size_t>(p.y) + ny * static_cast<std::size_t>(p.z))) >>
         6] = 0;
  }
  std::sort(order.begin(), order.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  keys.resize(order.size());
  around.resize(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    keys[i] = order[i].first;
    around[i] = leaves[order[i].second];
  }
}

PointGroups TopologyEditor::groupAt(const Index3& p, const std::array<std::uint64_t, 8>& around,
                                    GroupScratch& scratch) const {
  PointGroups out;
  out.p = p;
  std::array<std::uint64_t, 8> cubes{};
  std::size_t cubeCount = 0;
  for (std::uint64_t k : around)
    if (k != kNoKey &&
        std::find(cubes.begin(), cubes.begin() + static_cast<std::ptrdiff_t>(cubeCount), k) ==
            cubes.begin() + static_cast<std::ptrdiff_t>(cubeCount))
      cubes[cubeCount++] = k;
  std::vector<std::uint32_t>& members = scratch.members;
  members.clear();
  std::array<std::size_t, 9> firstOf{};
  for (std::size_t i = 0; i < cubeCount; ++i) {
    firstOf[i] = members.size();
    copiesOf(cubes[i], members);
  }
  firstOf[cubeCount] = members.size();
  if (members.empty()) return out;
  auto localIndex = [&](std::size_t cube, std::uint32_t copy) {
    for (std::size_t m = firstOf[cube]; m < firstOf[cube + 1]; ++m)
      if (members[m] == copy) return static_cast<std::uint32_t>(m);
    VOXCUT_ASSERT(false, "voxel owner is not a copy of its cube");
    return std::uint32_t{0};
  };
  // Members joined through connected links (roots are the lowest index of their set).
  UnionFind& sets = scratch.sets;
  sets.reset(members.size());
  const Index3 gd = grid_.dims();
  for (std::size_t i = 0; i < cubeCount; ++i)
    for (std::size_t j = i + 1; j < cubeCount; ++j) {
      // Cubes sharing a face region: one axis where they touch, overlap along the other two.
      const Index3 fa = keyFirstVoxel(cubes[i]), fb = keyFirstVoxel(cubes[j]);
      const int sa = 1 << keyLevel(cubes[i]), sb = 1 << keyLevel(cubes[j]);
      int axis = -1;
      bool face = true;
      Index3 lo, hi;
      for (int k = 0; k < 3 && face; ++k) {
        lo[k] = std::max(fa[k], fb[k]);
        hi[k] = std::min(fa[k] + sa, fb[k] + sb);
        if (lo[k] == hi[k]) {
          face = axis < 0;
          axis = k;
        } else if (lo[k] > hi[k]) {
          face = false;
        }
      }
      if (!face || axis < 0) continue;
      const bool iLow = fa[axis] < fb[axis];
      const std::size_t low = iLow ? i : j, high = iLow ? j : i;
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      Index3 c;
      c[axis] = lo[axis] - 1;
      if (c[axis] + 1 >= gd[axis]) continue;
      // With one copy on each side the first connected link settles the pair, and nothing is
      // left to find when the two are joined already.
      const bool single =
          firstOf[low + 1] - firstOf[low] == 1 && firstOf[high + 1] - firstOf[high] == 1;
      if (single && sets.same(static_cast<std::uint32_t>(firstOf[low]),
                              static_cast<std::uint32_t>(firstOf[high])))
        continue;
      bool done = false;
      for (c[w] = lo[w]; c[w] < std::min(hi[w], gd[w]) && !done; ++c[w])
        for (c[u] = lo[u]; c[u] < std::min(hi[u], gd[u]); ++c[u]) {
          const std::size_t x = grid_.index(c);
          if (!grid_.occupied(x) || !grid_.connected(x, axis)) continue;
          const std::size_t y = x + grid_.stride(axis);
          if (!grid_.occupied(y)) continue;
          sets.unite(localIndex(low, oc_.embedding_[x].element),
                     localIndex(high, oc_.embedding_[y].element));
          if (single) {
            done = true;
            break;
          }
        }
    }
  // Groups numbered in the order of their first member; each member's corner at p, or -1 on
  // a coarse copy.
  std::vector<int>& groupOf = scratch.groupOf;
  groupOf.assign(2 * members.size(), -1);
  int* memberGroup = groupOf.data() + members.size();
  std::array<int, 9> cornerOf{};
  int groupCount = 0;
  for (std::size_t c = 0; c < cubeCount; ++c) {
    const Index3 f = keyFirstVoxel(cubes[c]);
    const int s = 1 << keyLevel(cubes[c]);
    cornerOf[c] = interiorAxes(f, s, p) == 0 ? cornerIndex(f, s, p) : -1;
    for (std::size_t m = firstOf[c]; m < firstOf[c + 1]; ++m) {
      const std::size_t r = sets.find(static_cast<std::uint32_t>(m));
      if (groupOf[r] < 0) groupOf[r] = groupCount++;
      memberGroup[m] = groupOf[r];
    }
  }
  // Emit group by group, members in order; groups without a corner copy are dropped.
  out.members.reserve(members.size());
  for (int g = 0; g < groupCount; ++g) {
    const std::size_t begin = out.members.size();
    bool corner = false;
    for (std::size_t c = 0; c < cubeCount; ++c)
      for (std::size_t m = firstOf[c]; m < firstOf[c + 1]; ++m)
        if (memberGroup[m] == g) {
          out.members.push_back({members[m], static_cast<std::int8_t>(cornerOf[c]), false});
          corner = corner || cornerOf[c] >= 0;
        }
    if (!corner)
      out.members.resize(begin);
    else
      out.members.back().last = true;
  }
  return out;
}

void TopologyEditor::assignTempNodes() {
  cornerNodes_.clear();
  tempNodes_.clear();
  for (std::size_t i = 0; i < points_.size(); ++i)
    for (std::size_t b = 0; b < points_[i].members.size();) {
      const std::uint32_t t = kTempNode | static_cast<std::uint32_t>(tempNodes_.size());
      tempNodes_.emplace_back(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(b));
      for (;; ++b) {
        const GroupMember& gm = points_[i].members[b];
        if (gm.corner >= 0) {
          auto [it, fresh] = cornerNodes_.try_emplace(gm.copy);
          if (fresh) {
            if (gm.copy < oldElements_)
              it->second = oc_.elements_[gm.copy].nodes;
            else
              it->second.fill(kNoElement);
          }
          it->second[static_cast<std::size_t>(gm.corner)] = t;
        }
        if (gm.last) break;
      }
      ++b;
    }
}

std::uint32_t TopologyEditor::cornerNode(std::uint32_t copy, int c) const {
  const auto it = cornerNodes_.find(copy);
  if (it != cornerNodes_.end()) return it->second[static_cast<std::size_t>(c)];
  VOXCUT_ASSERT(copy < oldElements_, "a new copy without nodes");
  return oc_.elements_[copy].nodes[static_cast<std::size_t>(c)];
}

std::vector<std::uint64_t> TopologyEditor::ambiguousCubes() const {
  std::vector<std::uint64_t> out;
  auto keyOf = [&](std::uint32_t copy) {
    if (copy >= oldElements_) return copies_[copy - oldElements_].key;
    const OctreeElement& e = oc_.elements_[copy];
    return DeformationOctree::cubeKey(e.level, e.coord);
  };
  std::vector<std::uint32_t> coarse;
  for (const PointGroups& pg : points_)
    for (std::size_t b = 0; b < pg.members.size();) {
      coarse.clear();
      for (;; ++b) {
        if (pg.members[b].corner < 0) coarse.push_back(pg.members[b].copy);
        if (pg.members[b].last) break;
      }
      ++b;
      if (coarse.size() < 2) continue;
      std::vector<std::pair<std::uint64_t, std::uint32_t>> ref;
      bool same = true;
      for (std::uint32_t copy : coarse) {
        const std::uint64_t k = keyOf(copy);
        const Index3 f = keyFirstVoxel(k);
        const int s = 1 << keyLevel(k);
        std::array<int, 4> mc{};
        const int n = masterCorners(f, s, pg.p, mc);
        std::vector<std::pair<std::uint64_t, std::uint32_t>> m;
        for (int i = 0; i < n; ++i)
          m.emplace_back(pointKey(cornerPoint(f, s, mc[static_cast<std::size_t>(i)])),
                         cornerNode(copy, mc[static_cast<std::size_t>(i)]));
        std::sort(m.begin(), m.end());
        if (ref.empty())
          ref = m;
        else if (m != ref)
          same = false;
      }
      if (!same)
        for (std::uint32_t copy : coarse) out.push_back(keyOf(copy));
    }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

TopologyChange TopologyEditor::run() {
  // Embeddings (and elements) change from here on: what was derived from them is stale.
  for (int round = 0;; ++round) {
    VOXCUT_ASSERT(round < 64, "topology update does not settle");
    partitionPending();
    // A point whose leaves are those of the last round has the same groups (a leaf keeps its
    // copies while it stays a leaf): those are moved over, the others regrouped.
    std::vector<std::uint64_t> pts;
    std::vector<std::array<std::uint64_t, 8>> around;
    dirtyPoints(pts, around);
    std::vector<PointGroups> groups(pts.size());
    parallelFor(
        0, pts.size(), 64,
        [&](std::size_t b, std::size_t e) {
          GroupScratch scratch;
          for (std::size_t i = b; i < e; ++i) {
            const auto it = std::lower_bound(lastPoints_.begin(), lastPoints_.end(), pts[i]);
            const auto j = static_cast<std::size_t>(it - lastPoints_.begin());
            if (it != lastPoints_.end() && *it == pts[i] && lastAround_[j] == around[i])
              groups[i] = std::move(points_[j]);
            else
              groups[i] = groupAt(pointOf(pts[i]), around[i], scratch);
          }
        },
        threaded_);
    points_ = std::move(groups);
    lastPoints_ = std::move(pts);
    lastAround_ = std::move(around);
    assignTempNodes();
    const std::vector<std::uint64_t> ambiguous = ambiguousCubes();
    if (ambiguous.empty()) break;
    for (std::uint64_t k : ambiguous) {
      if (merged_.count(k) != 0) unmerged_.push_back(k);
      split(k);
    }
  }
  return finalize();
}

}  // namespace voxcut
