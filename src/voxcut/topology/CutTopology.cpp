#include "voxcut/topology/CutTopology.h"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <limits>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/topology/TopologyEditor.h"

namespace voxcut {

using namespace topology_detail;

std::uint64_t TopologyEditor::leafOf(const Index3& v, int minLevel) const {
  if (v.x < 0 || v.y < 0 || v.z < 0) return kNoKey;
  const Index3 t{v.x >> kTileLevel, v.y >> kTileLevel, v.z >> kTileLevel};
  if (t.x < tileDims_.x && t.y < tileDims_.y && t.z < tileDims_.z) {
    const std::int32_t tile =
        tileIndex_[static_cast<std::size_t>(t.x + tileDims_.x * (t.y + tileDims_.y * t.z))];
    if (tile >= 0) {
      const int m = kTileSize - 1;
      const int L = tileLevels_[static_cast<std::size_t>(tile) * kTileSize * kTileSize * kTileSize +
                                static_cast<std::size_t>(
                                    (v.x & m) + kTileSize * ((v.y & m) + kTileSize * (v.z & m)))];
      // Leaves do not overlap, so the one leaf holding v answers for every minLevel.
      return L >= minLevel ? DeformationOctree::cubeKey(L, {v.x >> L, v.y >> L, v.z >> L}) : kNoKey;
    }
  }
  return probeLeaf(v, minLevel);
}

std::uint64_t TopologyEditor::probeLeaf(const Index3& v, int minLevel) const {
  for (int L = minLevel; L <= oc_.maxLevel_; ++L) {
    const std::uint64_t k = DeformationOctree::cubeKey(L, {v.x >> L, v.y >> L, v.z >> L});
    if (leaves_.contains(k)) return k;
  }
  return kNoKey;
}

std::array<std::uint64_t, 8> TopologyEditor::leavesAround(const Index3& p) const {
  std::array<std::uint64_t, 8> out{};
  // Off the tile boundaries the 8 voxels share one tile: read it once.
  constexpr int m = kTileSize - 1;
  if ((p.x & m) != 0 && (p.y & m) != 0 && (p.z & m) != 0) {
    const Index3 t{p.x >> kTileLevel, p.y >> kTileLevel, p.z >> kTileLevel};
    if (t.x < tileDims_.x && t.y < tileDims_.y && t.z < tileDims_.z) {
      const std::int32_t tile =
          tileIndex_[static_cast<std::size_t>(t.x + tileDims_.x * (t.y + tileDims_.y * t.z))];
      if (tile >= 0) {
        const std::int8_t* lv =
            tileLevels_.data() + static_cast<std::size_t>(tile) * kTileSize * kTileSize * kTileSize;
        for (int d = 0; d < 8; ++d) {
          const Index3 v{p.x - 1 + (d & 1), p.y - 1 + ((d >> 1) & 1), p.z - 1 + (d >> 2)};
          const int L = lv[(v.x & m) + kTileSize * ((v.y & m) + kTileSize * (v.z & m))];
          out[static_cast<std::size_t>(d)] =
              L >= 0 ? DeformationOctree::cubeKey(L, {v.x >> L, v.y >> L, v.z >> L}) : kNoKey;
        }
        return out;
      }
    }
  }
  for (int d = 0; d < 8; ++d)
    out[static_cast<std::size_t>(d)] =
        leafOf({p.x - 1 + (d & 1), p.y - 1 + ((d >> 1) & 1), p.z - 1 + (d >> 2)});
  return out;
}

void TopologyEditor::buildTile(const Index3& v) {
  if (v.x < 0 || v.y < 0 || v.z < 0) return;
  const Index3 t{v.x >> kTileLevel, v.y >> kTileLevel, v.z >> kTileLevel};
  if (t.x >= tileDims_.x || t.y >= tileDims_.y || t.z >= tileDims_.z) return;
  std::int32_t& index =
      tileIndex_[static_cast<std::size_t>(t.x + tileDims_.x * (t.y + tileDims_.y * t.z))];
  if (index >= 0) return;
  constexpr std::size_t n = kTileSize * kTileSize * kTileSize;
  index = static_cast<std::int32_t>(tileLevels_.size() / n);
  tileLevels_.resize(tileLevels_.size() + n, -1);
  std::int8_t* lv = tileLevels_.data() + static_cast<std::size_t>(index) * n;
  const Index3 f{t.x << kTileLevel, t.y << kTileLevel, t.z << kTileLevel};
  // A leaf as large as the tile or larger holds all of it.
  for (int L = kTileLevel; L <= oc_.maxLevel_; ++L)
    if (leaves_.contains(DeformationOctree::cubeKey(L, {f.x >> L, f.y >> L, f.z >> L}))) {
      std::fill(lv, lv + n, static_cast<std::int8_t>(L));
      return;
    }
  // Else every leaf in it is smaller and, like every leaf, holds an occupied voxel (the build
  // and the splits make no other): find each through one of its occupied voxels.
  const Index3 gd = grid_.dims();
  for (int z = f.z; z < std::min(f.z + kTileSize, gd.z); ++z)
    for (int y = f.y; y < std::min(f.y + kTileSize, gd.y); ++y)
      for (int x = f.x; x < std::min(f.x + kTileSize, gd.x); ++x) {
        const std::size_t i =
            static_cast<std::size_t>((x - f.x) + kTileSize * ((y - f.y) + kTileSize * (z - f.z)));
        if (lv[i] >= 0 || !grid_.occupied(grid_.index(x, y, z))) continue;
        for (int L = 0; L < kTileLevel && L <= oc_.maxLevel_; ++L) {
          const Index3 c{x >> L, y >> L, z >> L};
          if (!leaves_.contains(DeformationOctree::cubeKey(L, c))) continue;
          const int s = 1 << L;
          for (int cz = (c.z << L) - f.z; cz < (c.z << L) - f.z + s; ++cz)
            for (int cy = (c.y << L) - f.y; cy < (c.y << L) - f.y + s; ++cy)
              for (int cx = (c.x << L) - f.x; cx < (c.x << L) - f.x + s; ++cx)
                lv[cx + kTileSize * (cy + kTileSize * cz)] = static_cast<std::int8_t>(L);
          break;
        }
      }
}

void TopologyEditor::setLeafLevels(const Index3& first, int size, int level) {
  constexpr int m = kTileSize - 1;
  for (int z = first.z; z < first.z + size; ++z)
    for (int y = first.y; y < first.y + size; ++y)
      for (int x = first.x; x < first.x + size; x += kTileSize) {
        const Index3 t{x >> kTileLevel, y >> kTileLevel, z >> kTileLevel};
        if (t.x >= tileDims_.x || t.y >= tileDims_.y || t.z >= tileDims_.z) continue;
        const std::int32_t tile =
            tileIndex_[static_cast<std::size_t>(t.x + tileDims_.x * (t.y + tileDims_.y * t.z))];
        if (tile < 0) continue;
        // The run of the row inside this tile (size < 8 or x at a tile start).
        const int run = std::min(size, kTileSize - (x & m));
        std::int8_t* row =
            tileLevels_.data() +
            static_cast<std::size_t>(tile) * kTileSize * kTileSize * kTileSize +
            static_cast<std::size_t>((x & m) + kTileSize * ((y & m) + kTileSize * (z & m)));
        std::fill(row, row + run, static_cast<std::int8_t>(level));
      }
}

void TopologyEditor::makeDirty(std::uint64_t key) {
  auto it = oc_.cubeFirst_.find(key);
  VOXCUT_ASSERT(it != oc_.cubeFirst_.end(), "not a leaf");
  if (it->second != kNoElement) {
    for (std::uint32_t e = it->second; e != kNoElement; e = oc_.nextCopy_[e]) removed_.push_back(e);
    it->second = kNoElement;
    leaves_.set(key, kNoElement);
    removedCubes_.push_back(key);
  }
  if (partitioned_.count(key) == 0) pending_.insert(key);
}

void TopologyEditor::split(std::uint64_t first) {
  std::vector<std::uint64_t> queue{first};
  const Index3 gd = grid_.dims();
  while (!queue.empty()) {
    const std::uint64_t key = queue.back();
    queue.pop_back();
    auto it = oc_.cubeFirst_.find(key);
    if (it == oc_.cubeFirst_.end()) continue;
    const int L = keyLevel(key);
    VOXCUT_ASSERT(L > 0, "cannot split a level-0 element");
    if (it->second != kNoElement) {
      for (std::uint32_t e = it->second; e != kNoElement; e = oc_.nextCopy_[e])
        removed_.push_back(e);
      removedCubes_.push_back(key);
    } else if (auto p = partitioned_.find(key); p != partitioned_.end()) {
      for (std::uint32_t id : p->second) copies_[id - oldElements_].alive = false;
      partitioned_.erase(p);
    }
    pending_.erase(key);
    oc_.cubeFirst_.erase(it);
    leaves_.erase(key);
    setLeafLevels(keyFirstVoxel(key), 1 << L, -1);
    // Children holding an occupied voxel become leaves.
    const Index3 f = keyFirstVoxel(key);
    const int s = 1 << L, h = s / 2;
    std::array<bool, 8> occupied{};
    for (int z = f.z; z < std::min(f.z + s, gd.z); ++z)
      for (int y = f.y; y < std::min(f.y + s, gd.y); ++y)
        for (int x = f.x; x < std::min(f.x + s, gd.x); ++x)
          if (grid_.occupied(grid_.index(x, y, z)))
            occupied[static_cast<std::size_t>((x - f.x) / h + 2 * ((y - f.y) / h) +
                                              4 * ((z - f.z) / h))] = true;
    for (int c = 0; c < 8; ++c) {
      if (!occupied[static_cast<std::size_t>(c)]) continue;
      const Index3 cc = cornerPoint(f, h, c);
      const Index3 coord{cc.x >> (L - 1), cc.y >> (L - 1), cc.z >> (L - 1)};
      const std::uint64_t ck = DeformationOctree::cubeKey(L - 1, coord);
      oc_.cubeFirst_[ck] = kNoElement;
      leaves_.set(ck, kNoElement);
      setLeafLevels(cc, h, L - 1);
      pending_.insert(ck);
      // 2:1 (vertex adjacency): a leaf two or more levels coarser touching the child splits.
      for (int d = 0; d < 27; ++d) {
        if (d == 13) continue;
        const Index3 nb{coord.x + d % 3 - 1, coord.y + (d / 3) % 3 - 1, coord.z + d / 9 - 1};
        if (nb.x < 0 || nb.y < 0 || nb.z < 0) continue;
        const Index3 v{nb.x << (L - 1), nb.y << (L - 1), nb.z << (L - 1)};
        buildTile(v);
        const std::uint64_t k = leafOf(v, L + 1);
        if (k != kNoKey) queue.push_back(k);
      }
    }
  }
}

const CubeParts& TopologyEditor::cachedParts(std::uint64_t key) {
  auto it = partCache_.find(key);
  if (it == partCache_.end()) it = partCache_.emplace(key, partition(key)).first;
  return it->second;
}

namespace {

/// The part of occupied voxel v in a cube's parts (its voxels ascending).
std::uint32_t partOf(const CubeParts& parts, std::size_t v) {
  const auto it = std::lower_bound(parts.voxels.begin(), parts.voxels.end(),
                                   static_cast<std::uint32_t>(v));
  VOXCUT_ASSERT(it != parts.voxels.end() && *it == v, "voxel outside its leaf");
  return parts.part[static_cast<std::size_t>(it - parts.voxels.begin())];
}

}  // namespace

bool TopologyEditor::glued(std::uint64_t a, std::uint64_t b, std::size_t v, std::size_t w,
                           int axis) {
  const std::uint32_t partV = partOf(cachedParts(a), v);
  if (a == b) return partV == partOf(cachedParts(a), w);
  const std::uint32_t partW = partOf(cachedParts(b), w);
  const CubeParts& pa = cachedParts(a);
  const CubeParts& pb = cachedParts(b);
  // The layer of a's voxels on the face it shares with b (w lies across it from v).
  const Index3 fa = keyFirstVoxel(a), fb = keyFirstVoxel(b), gd = grid_.dims();
  const int sa = 1 << keyLevel(a), sb = 1 << keyLevel(b);
  const int u = (axis + 1) % 3, t = (axis + 2) % 3;
  Index3 c = grid_.coord(v);
  const int uHi = std::min({fa[u] + sa, fb[u] + sb, gd[u]});
  const int tHi = std::min({fa[t] + sa, fb[t] + sb, gd[t]});
  for (c[t] = std::max(fa[t], fb[t]); c[t] < tHi; ++c[t])
    for (c[u] = std::max(fa[u], fb[u]); c[u] < uHi; ++c[u]) {
      const std::size_t x = grid_.index(c);
      if (!grid_.occupied(x) || !grid_.connected(x, axis)) continue;
      const std::size_t y = x + grid_.stride(axis);
      if (grid_.occupied(y) && partOf(pa, x) == partV && partOf(pb, y) == partW) return true;
    }
  return false;
}

void TopologyEditor::seedCuts(const std::vector<std::uint64_t>& links, int finest,
                              bool refineOnly) {
  std::vector<std::uint64_t> sorted(links);
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  for (std::uint64_t id : sorted) {
    const std::size_t v = static_cast<std::size_t>(id / 3);
    const int a = static_cast<int>(id % 3);
    VOXCUT_ASSERT(v < grid_.voxelCount() && grid_.hasLink(v, a), "link id out of range");
    const std::size_t w = v + grid_.stride(a);
    const Index3 pv = grid_.coord(v), pw = grid_.coord(w);
    const bool both = grid_.occupied(v) && grid_.occupied(w);
    if (both) {
      // Refine while the cut cannot open: the coarser leaf first, both when equal.
      for (;;) {
        buildTile(pv);
        buildTile(pw);
        const std::uint64_t ka = leafOf(pv), kb = leafOf(pw);
        VOXCUT_ASSERT(ka != kNoKey && kb != kNoKey, "occupied voxel outside every element");
        if (!glued(ka, kb, v, w, a)) break;
        const int la = keyLevel(ka), lb = keyLevel(kb);
        bool refined = false;
        if (la >= lb && la > finest) {
          split(ka);
          refined = true;
        }
        if (kb != ka && lb >= la && lb > finest) {
          split(kb);
          refined = true;
        }
        if (!refined) break;
      }
    }
    for (std::size_t u : {v, w}) {
      if (refineOnly || !grid_.occupied(u)) continue;
      const Index3 p = grid_.coord(u);
      buildTile(p);
      const std::uint64_t k = leafOf(p);
      VOXCUT_ASSERT(k != kNoKey, "occupied voxel outside every element");
      makeDirty(k);
    }
  }
  partCache_.clear();
}

void TopologyEditor::seedAll() {
  std::vector<std::uint64_t> keys;
  keys.reserve(oc_.cubeFirst_.size());
  for (const auto& kv : oc_.cubeFirst_) keys.push_back(kv.first);
  std::sort(keys.begin(), keys.end());
  for (std::uint64_t k : keys) makeDirty(k);
}

void TopologyEditor::copiesOf(std::uint64_t key, std::vector<std::uint32_t>& out) const {
  const std::uint32_t* first = leaves_.find(key);
  if (first == nullptr || *first == kNoElement) return;
  if (*first >= oldElements_) {
    for (std::size_t i = *first - oldElements_; i < copies_.size() && copies_[i].key == key; ++i)
      out.push_back(oldElements_ + static_cast<std::uint32_t>(i));
    return;
  }
  for (std::uint32_t e = *first; e != kNoElement; e = oc_.nextCopy_[e]) out.push_back(e);
}

CubeParts TopologyEditor::partition(std::uint64_t key) const {
  CubeParts out;
  const Index3 f = keyFirstVoxel(key), gd = grid_.dims();
  const int s = 1 << keyLevel(key);
  if (s == 1) {
    // One voxel (occupied, as in every leaf): one part, the same as its old level-0 copy.
    const auto v = static_cast<std::uint32_t>(grid_.index(f));
    VOXCUT_ASSERT(grid_.occupied(v), "an empty level-0 leaf");
    const std::uint32_t o = oc_.embedding_[v].element;
    NewCopy nc;
    nc.key = key;
    nc.minVoxel = v;
    nc.origin = oldElementOf(v);
    if (o < oldElements_ && oc_.elements_[o].level == 0) nc.sameAs = o;
    out.voxels.push_back(v);
    out.part.push_back(0);
    out.parts.push_back(nc);
    return out;
  }
  const Index3 hi{std::min(f.x + s, gd.x), std::min(f.y + s, gd.y), std::min(f.z + s, gd.z)};
  std::vector<std::int32_t> local(static_cast<std::size_t>(s) * s * s, -1);
  auto li = [&](int x, int y, int z) {
    return static_cast<std::size_t>(x - f.x) +
           static_cast<std::size_t>(s) *
               (static_cast<std::size_t>(y - f.y) +
                static_cast<std::size_t>(s) * static_cast<std::size_t>(z - f.z));
  };
  for (int z = f.z; z < hi.z; ++z)
    for (int y = f.y; y < hi.y; ++y)
      for (int x = f.x; x < hi.x; ++x) {
        const std::size_t v = grid_.index(x, y, z);
        if (!grid_.occupied(v)) continue;
        local[li(x, y, z)] = static_cast<std::int32_t>(out.voxels.size());
        out.voxels.push_back(static_cast<std::uint32_t>(v));
      }
  UnionFind uf(out.voxels.size());
  for (std::size_t i = 0; i < out.voxels.size(); ++i) {
    const std::size_t v = out.voxels[i];
    const Index3 c = grid_.coord(v);
    for (int a = 0; a < 3; ++a) {
      if (c[a] + 1 >= hi[a] || !grid_.connected(v, a)) continue;
      Index3 n = c;
      ++n[a];
      const std::int32_t j = local[li(n.x, n.y, n.z)];
      if (j >= 0) uf.unite(static_cast<int>(i), j);
    }
  }
  // Parts numbered by their lowest voxel (roots are the lowest index of their set).
  out.part.resize(out.voxels.size());
  std::vector<std::uint32_t> count;
  std::vector<bool> uniform;
  for (std::size_t i = 0; i < out.voxels.size(); ++i) {
    const int r = uf.find(static_cast<int>(i));
    if (r == static_cast<int>(i)) {
      NewCopy nc;
      nc.key = key;
      nc.minVoxel = out.voxels[i];
      nc.origin = oldElementOf(out.voxels[i]);
      out.part[i] = static_cast<std::uint32_t>(out.parts.size());
      out.parts.push_back(nc);
      count.push_back(0);
      uniform.push_back(true);
    } else {
      out.part[i] = out.part[static_cast<std::size_t>(r)];
    }
    const std::uint32_t p = out.part[i];
    ++count[p];
    if (oc_.embedding_[out.voxels[i]].element != oc_.embedding_[out.parts[p].minVoxel].element)
      uniform[p] = false;
  }
  // A part equal to an old copy of this very cube keeps that copy's slot.
  for (std::size_t p = 0; p < out.parts.size(); ++p) {
    const std::uint32_t o = oc_.embedding_[out.parts[p].minVoxel].element;
    if (!uniform[p] || o >= oldElements_) continue;
    const OctreeElement& oe = oc_.elements_[o];
    if (DeformationOctree::cubeKey(oe.level, oe.coord) != key) continue;
    std::uint32_t held = 0;
    for (std::uint32_t v : out.voxels) held += oc_.embedding_[v].element == o;
    if (held == count[p]) out.parts[p].sameAs = o;
  }
  // A cube coarser than the old elements it is made of (a merge): each corner's node comes
  // from the old element of the part's voxel nearest that corner.
  const int L = keyLevel(key);
  for (std::size_t p = 0; p < out.parts.size(); ++p) {
    if (oc_.elements_[out.parts[p].origin].level >= L) continue;
    std::array<int, 8> best;
    best.fill(std::numeric_limits<int>::max());
    for (std::size_t i = 0; i < out.voxels.size(); ++i) {
      if (out.part[i] != p) continue;
      const Index3 c = grid_.coord(out.voxels[i]);
      for (int k = 0; k < 8; ++k) {
        const Index3 corner = cornerPoint(f, s - 1, k);
        const int d = std::abs(c.x - corner.x) + std::abs(c.y - corner.y) + std::abs(c.z - corner.z);
        if (d < best[static_cast<std::size_t>(k)]) {
          best[static_cast<std::size_t>(k)] = d;
          out.parts[p].cornerOrigin[static_cast<std::size_t>(k)] = oldElementOf(out.voxels[i]);
        }
      }
    }
  }
  return out;
}

void TopologyEditor::partitionPending() {
  std::vector<std::uint64_t> keys(pending_.begin(), pending_.end());
  std::sort(keys.begin(), keys.end());
  pending_.clear();
  std::vector<CubeParts> res(keys.size());
  parallelFor(
      0, keys.size(), 1,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) res[i] = partition(keys[i]);
      },
      threaded_);
  // The old owners of the voxels about to point at provisional copies.
  for (const CubeParts& r : res)
    for (std::uint32_t v : r.voxels) {
      const std::uint32_t e = oc_.embedding_[v].element;
      if (e < oldElements_) oldOwner_.emplace(v, e);
    }
  std::vector<std::uint32_t> base(keys.size());
  for (std::size_t i = 0; i < keys.size(); ++i) {
    base[i] = oldElements_ + static_cast<std::uint32_t>(copies_.size());
    leaves_.set(keys[i], base[i]);
    auto& ids = partitioned_[keys[i]];
    VOXCUT_ASSERT(ids.empty(), "a leaf partitioned twice");
    for (const NewCopy& nc : res[i].parts) {
      ids.push_back(oldElements_ + static_cast<std::uint32_t>(copies_.size()));
      copies_.push_back(nc);
    }
  }
  parallelFor(
      0, keys.size(), 1,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          const Index3 f = keyFirstVoxel(keys[i]);
          for (std::size_t j = 0; j < res[i].voxels.size(); ++j) {
            const std::uint32_t v = res[i].voxels[j];
            const Index3 c = grid_.coord(v);
            VoxelEmbedding& em = oc_.embedding_[v];
            em.element = base[i] + res[i].part[j];
            em.offset = {static_cast<std::uint8_t>(c.x - f.x), static_cast<std::uint8_t>(c.y - f.y),
                         static_cast<std::uint8_t>(c.z - f.z)};
          }
        }
      },
      threaded_);
}

TopologyChange updateCutTopology(DeformationOctree& octree, const VoxelGrid& grid,
                                 const std::vector<std::uint64_t>& newCutLinks,
                                 const CutTopologyParams& params) {
  if (params.finestLevel < 0 || params.finestLevel > 7)
    throw InputError("finest level must be in [0, 7], got " + std::to_string(params.finestLevel));
  TopologyEditor editor(octree, grid, params.threaded);
  editor.seedCuts(newCutLinks, params.finestLevel, params.refineOnly);
  if (editor.anythingDirty()) return editor.run();
  return identityChange(octree);
}

TopologyChange identityChange(const DeformationOctree& octree) {
  TopologyChange same;
  same.elementSource.resize(octree.elementCount());
  for (std::size_t e = 0; e < octree.elementCount(); ++e)
    same.elementSource[e] = static_cast<std::uint32_t>(e);
  same.nodeSource.resize(octree.nodeCount());
  for (std::size_t n = 0; n < octree.nodeCount(); ++n) {
    same.nodeSource[n].count = 1;
    same.nodeSource[n].nodes[0] = static_cast<std::uint32_t>(n);
    same.nodeSource[n].weights[0] = 1.0;
  }
  return same;
}

TopologyChange duplicateByParts(DeformationOctree& octree, const VoxelGrid& grid, bool threaded) {
  TopologyEditor editor(octree, grid, threaded);
  editor.seedAll();
  return editor.run();
}

}  // namespace voxcut
