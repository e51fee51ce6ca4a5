// The last step of a topology update: TopologyEditor::finalize writes the deformation octree
// from the settled groups, in phases (nodes made, element and node slots, the arrays, the
// embedding, the cube index, hanging nodes, the element map).
#include <algorithm>

#include "voxcut/core/Parallel.h"
#include "voxcut/topology/TopologyEditor.h"

namespace voxcut {

using namespace topology_detail;

TopologyChange TopologyEditor::finalize() {
  Finalization state;
  state.temp = makeTempNodes();
  assignElementSlots(state);
  assignNodeSlots(state);
  writeNodes(state);
  writeElements(state);
  // The partitioned cubes, ascending.
  for (const auto& kv : partitioned_) state.cubes.push_back(kv.first);
  std::sort(state.cubes.begin(), state.cubes.end());
  renumberEmbedding(state);
  writeCubeIndex(state);
  std::vector<HangingNode> hanging = keptAndNewHangingNodes(state);
  fillNodeHoles(state, hanging);
  writeHangingNodes(state, std::move(hanging));
  writeElementSources(state);
  fillElementHoles(state);
  state.change.changed = state.changed;
  return std::move(state.change);
}

// New nodes, from the old state: a member's old element's node at p when p is one of its
// corners, else that element's trilinear map at p (p was made by refinement).
std::vector<TempNode> TopologyEditor::makeTempNodes() const {
  const std::vector<OctreeElement>& E = oc_.elements_;
  std::vector<TempNode> temp(tempNodes_.size());
  for (std::size_t t = 0; t < temp.size(); ++t) {
    const PointGroups& pg = points_[tempNodes_[t].first];
    TempNode& tn = temp[t];
    tn.p = pg.p;
    for (std::size_t b = tempNodes_[t].second;; ++b) {
      if (pg.members[b].corner < 0) {
        tn.coarse = pg.members[b].copy;
        break;
      }
      if (pg.members[b].last) break;
    }
    std::uint32_t fallback = kNoElement;
    for (std::size_t b = tempNodes_[t].second;; ++b) {
      const GroupMember& gm = pg.members[b];
      if (gm.corner < 0) {
        if (gm.last) break;
        continue;
      }
      const std::uint32_t copy = gm.copy;
      const OctreeElement& oe = E[originAt(copy, gm.corner)];
      if (interiorAxes(oe.firstVoxel(), oe.size(), pg.p) == 0) {
        tn.src.count = 1;
        tn.src.nodes[0] =
            oe.nodes[static_cast<std::size_t>(cornerIndex(oe.firstVoxel(), oe.size(), pg.p))];
        tn.src.weights[0] = 1.0;
        break;
      }
      if (fallback == kNoElement) fallback = originAt(copy, gm.corner);
      if (gm.last) break;
    }
    if (tn.src.count == 0) {
      const OctreeElement& oe = E[fallback];
      const Index3 f = oe.firstVoxel();
      const double inv = 1.0 / static_cast<double>(oe.size());
      const Vec3d x((pg.p.x - f.x) * inv, (pg.p.y - f.y) * inv, (pg.p.z - f.z) * inv);
      for (int c = 0; c < 8; ++c) {
        const double w = ((c & 1) ? x.x() : 1 - x.x()) * ((c & 2) ? x.y() : 1 - x.y()) *
                         ((c & 4) ? x.z() : 1 - x.z());
        if (w == 0.0) continue;
        tn.src.nodes[tn.src.count] = oe.nodes[static_cast<std::size_t>(c)];
        tn.src.weights[tn.src.count++] = w;
      }
    }
    for (int i = 0; i < tn.src.count; ++i)
      tn.pos += tn.src.weights[static_cast<std::size_t>(i)] *
                oc_.positions_[tn.src.nodes[static_cast<std::size_t>(i)]];
  }
  return temp;
}

// Element slots: a copy equal to an old one keeps its slot; the others fill the freed slots in
// order of their lowest voxel, then are appended.
void TopologyEditor::assignElementSlots(Finalization& state) const {
  std::vector<char>& freedElement = state.freedElement;
  freedElement.assign(oldElements_, 0);
  std::vector<char> taken(oldElements_, 0);
  for (std::uint32_t e : removed_) freedElement[e] = 1;
  std::vector<std::uint32_t>& alive = state.alive;
  for (std::uint32_t i = 0; i < copies_.size(); ++i)
    if (copies_[i].alive) alive.push_back(i);
  std::sort(alive.begin(), alive.end(), [&](std::uint32_t a, std::uint32_t b) {
    return copies_[a].minVoxel < copies_[b].minVoxel;
  });
  std::vector<std::uint32_t>& finalId = state.finalId;
  finalId.assign(copies_.size(), kNoElement);
  for (std::uint32_t i : alive)
    if (copies_[i].sameAs != kNoElement) {
      finalId[i] = copies_[i].sameAs;
      taken[copies_[i].sameAs] = 1;
    }
  std::vector<std::uint32_t> freeSlots;
  for (std::uint32_t e : removed_)
    if (!taken[e]) freeSlots.push_back(e);
  std::sort(freeSlots.begin(), freeSlots.end());
  std::size_t next = 0;
  for (std::uint32_t i : alive) {
    if (finalId[i] != kNoElement) continue;
    state.changed = true;
    finalId[i] = next < freeSlots.size() ? freeSlots[next++] : oldElements_ + state.appended++;
  }
  // Fewer copies than freed slots (after merges): the last elements fill the holes at the end.
  state.elementHoles.assign(freeSlots.begin() + static_cast<std::ptrdiff_t>(next), freeSlots.end());
  state.changed = state.changed || !state.elementHoles.empty();
}

// Node slots: nodes at the regrouped points are freed; a new node reuses the slot of its single
// source when that sits at the same point, else the lowest free slot.
void TopologyEditor::assignNodeSlots(Finalization& state) const {
  const std::vector<OctreeElement>& E = oc_.elements_;
  const std::vector<TempNode>& temp = state.temp;
  std::vector<char>& freedNode = state.freedNode;
  freedNode.assign(oldNodes_, 0);
  std::vector<char> claimed(oldNodes_, 0);
  for (std::uint32_t e : removed_)
    for (std::uint32_t n : E[e].nodes) freedNode[n] = 1;
  for (const PointGroups& pg : points_)
    for (const GroupMember& gm : pg.members)
      if (gm.corner >= 0 && gm.copy < oldElements_)
        freedNode[E[gm.copy].nodes[static_cast<std::size_t>(gm.corner)]] = 1;
  std::vector<std::uint32_t>& nodeId = state.nodeId;
  nodeId.assign(temp.size(), kNoElement);
  for (std::size_t t = 0; t < temp.size(); ++t) {
    const std::uint32_t s = temp[t].src.nodes[0];
    if (temp[t].src.count == 1 && freedNode[s] && !claimed[s] && oc_.nodeCoords_[s] == temp[t].p) {
      nodeId[t] = s;
      claimed[s] = 1;
    }
  }
  std::vector<std::uint32_t> freeNodes;
  for (std::uint32_t n = 0; n < oldNodes_; ++n)
    if (freedNode[n] && !claimed[n]) freeNodes.push_back(n);
  std::size_t next = 0;
  for (std::size_t t = 0; t < temp.size(); ++t) {
    if (nodeId[t] != kNoElement) continue;
    state.changed = true;
    nodeId[t] = next < freeNodes.size() ? freeNodes[next++] : oldNodes_ + state.appendedNodes++;
  }
  state.holes.assign(freeNodes.begin() + static_cast<std::ptrdiff_t>(next), freeNodes.end());
  state.changed = state.changed || !state.holes.empty() || state.appended > 0;
}

// The node arrays (coordinates, rest and current positions) and the nodes' sources.
void TopologyEditor::writeNodes(Finalization& state) {
  const std::vector<TempNode>& temp = state.temp;
  TopologyChange& tc = state.change;
  const std::size_t nodeCount = state.nodeCount = oldNodes_ + state.appendedNodes;
  oc_.nodeCoords_.resize(nodeCount);
  oc_.restPositions_.resize(nodeCount);
  oc_.positions_.resize(nodeCount);
  tc.nodeSource.resize(nodeCount);
  for (std::uint32_t n = 0; n < oldNodes_; ++n) {
    tc.nodeSource[n].count = 1;
    tc.nodeSource[n].nodes[0] = n;
    tc.nodeSource[n].weights[0] = 1.0;
  }
  for (std::size_t t = 0; t < temp.size(); ++t) {
    const std::uint32_t id = state.nodeId[t];
    oc_.nodeCoords_[id] = temp[t].p;
    oc_.restPositions_[id] = oc_.nodeGridPosition(temp[t].p);
    oc_.positions_[id] = temp[t].pos;
    tc.nodeSource[id] = temp[t].src;
  }
}

// Elements: corners of untouched copies at regrouped points, then the new copies.
void TopologyEditor::writeElements(Finalization& state) {
  std::vector<OctreeElement>& E = oc_.elements_;
  auto resolve = [&](std::uint32_t ref) {
    return (ref & kTempNode) ? state.nodeId[ref & ~kTempNode] : ref;
  };
  auto resolved = [&](const std::array<std::uint32_t, 8>& refs) {
    std::array<std::uint32_t, 8> out{};
    for (std::size_t c = 0; c < 8; ++c) out[c] = resolve(refs[c]);
    return out;
  };
  E.resize(oldElements_ + state.appended);
  for (const auto& [copy, refs] : cornerNodes_) {
    if (copy >= oldElements_) continue;
    const auto nodes = resolved(refs);
    state.changed = state.changed || nodes != E[copy].nodes;
    E[copy].nodes = nodes;
  }
  for (std::uint32_t i : state.alive) {
    const std::uint32_t id = state.finalId[i];
    OctreeElement el;
    el.level = keyLevel(copies_[i].key);
    const Index3 f = keyFirstVoxel(copies_[i].key);
    el.coord = {f.x >> el.level, f.y >> el.level, f.z >> el.level};
    el.nodes = resolved(cornerNodes_.at(oldElements_ + i));
    state.changed = state.changed || id >= oldElements_ || el.nodes != E[id].nodes;
    E[id] = el;
  }
}

// The embedding of the partitioned cubes' voxels: provisional element ids to final ones.
void TopologyEditor::renumberEmbedding(const Finalization& state) {
  const std::vector<std::uint64_t>& keys = state.cubes;
  const Index3 gd = grid_.dims();
  parallelFor(
      0, keys.size(), 4,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          const Index3 f = keyFirstVoxel(keys[i]);
          const int s = 1 << keyLevel(keys[i]);
          for (int z = f.z; z < std::min(f.z + s, gd.z); ++z)
            for (int y = f.y; y < std::min(f.y + s, gd.y); ++y)
              for (int x = f.x; x < std::min(f.x + s, gd.x); ++x) {
                VoxelEmbedding& em = oc_.embedding_[grid_.index(x, y, z)];
                if (em.element != kNoElement) em.element = state.finalOf(em.element, oldElements_);
              }
        }
      },
      threaded_);
}

// The cube index: each partitioned cube's first copy and the chain of its copies.
void TopologyEditor::writeCubeIndex(const Finalization& state) {
  oc_.nextCopy_.resize(oc_.elements_.size(), kNoElement);
  for (std::uint64_t k : state.cubes) {
    std::vector<std::uint32_t> ids;
    for (std::uint32_t copy : partitioned_.at(k)) ids.push_back(state.finalOf(copy, oldElements_));
    std::sort(ids.begin(), ids.end());
    oc_.cubeFirst_[k] = ids.front();
    for (std::size_t j = 0; j < ids.size(); ++j)
      oc_.nextCopy_[ids[j]] = j + 1 < ids.size() ? ids[j + 1] : kNoElement;
  }
}

// Hanging nodes: the old ones away from the regrouped points, and the new ones (their masters
// are filled in by writeHangingNodes).
std::vector<HangingNode> TopologyEditor::keptAndNewHangingNodes(const Finalization& state) const {
  std::vector<HangingNode> hanging;
  for (const HangingNode& h : oc_.hanging_)
    if (!state.freedNode[h.node]) hanging.push_back(h);
  for (std::size_t t = 0; t < state.temp.size(); ++t)
    if (state.temp[t].coarse != kNoElement) {
      HangingNode h;
      h.node = state.nodeId[t];
      h.element = state.finalOf(state.temp[t].coarse, oldElements_);
      hanging.push_back(h);
    }
  return hanging;
}

// Fills the node slots left free with the last nodes, renumbering elements and hanging nodes.
void TopologyEditor::fillNodeHoles(Finalization& state, std::vector<HangingNode>& hanging) {
  if (state.holes.empty()) return;
  std::size_t& nodeCount = state.nodeCount;
  TopologyChange& tc = state.change;
  {
    std::vector<std::uint32_t> remap(nodeCount);
    for (std::uint32_t n = 0; n < nodeCount; ++n) remap[n] = n;
    std::vector<char> hole(nodeCount, 0);
    for (std::uint32_t h : state.holes) hole[h] = 1;
    for (std::uint32_t h : state.holes) {
      while (nodeCount > 0 && hole[nodeCount - 1]) --nodeCount;
      if (h >= nodeCount) break;
      const std::size_t last = nodeCount - 1;
      oc_.nodeCoords_[h] = oc_.nodeCoords_[last];
      oc_.restPositions_[h] = oc_.restPositions_[last];
      oc_.positions_[h] = oc_.positions_[last];
      tc.nodeSource[h] = tc.nodeSource[last];
      remap[last] = h;
      hole[h] = 0;
      hole[last] = 1;
      --nodeCount;
    }
    while (nodeCount > 0 && hole[nodeCount - 1]) --nodeCount;
    oc_.nodeCoords_.resize(nodeCount);
    oc_.restPositions_.resize(nodeCount);
    oc_.positions_.resize(nodeCount);
    tc.nodeSource.resize(nodeCount);
    for (OctreeElement& el : oc_.elements_)
      for (std::uint32_t& n : el.nodes) n = remap[n];
    for (HangingNode& h : hanging) h.node = remap[h.node];
  }
}

// The hanging nodes' masters from the coarse copies' corners, coarse first; writes them to the
// octree.
void TopologyEditor::writeHangingNodes(Finalization& state, std::vector<HangingNode> hanging) {
  for (HangingNode& h : hanging) {
    const OctreeElement& ce = oc_.elements_[h.element];
    std::array<int, 4> mc{};
    h.masterCount = static_cast<std::uint8_t>(
        masterCorners(ce.firstVoxel(), ce.size(), oc_.nodeCoords_[h.node], mc));
    h.coarseLevel = static_cast<std::uint8_t>(ce.level);
    for (int m = 0; m < h.masterCount; ++m)
      h.masters[static_cast<std::size_t>(m)] =
          ce.nodes[static_cast<std::size_t>(mc[static_cast<std::size_t>(m)])];
  }
  std::sort(hanging.begin(), hanging.end(), [](const HangingNode& a, const HangingNode& b) {
    return a.coarseLevel != b.coarseLevel ? a.coarseLevel > b.coarseLevel : a.node < b.node;
  });
  if (!state.changed) {
    state.changed = hanging.size() != oc_.hanging_.size();
    for (std::size_t i = 0; i < hanging.size() && !state.changed; ++i)
      state.changed = hanging[i].node != oc_.hanging_[i].node ||
                      hanging[i].masters != oc_.hanging_[i].masters ||
                      hanging[i].element != oc_.hanging_[i].element;
  }
  oc_.hanging_ = std::move(hanging);
  oc_.hangingFlag_.assign(state.nodeCount, 0);
  for (const HangingNode& h : oc_.hanging_) oc_.hangingFlag_[h.node] = 1;
}

// The element map: each element's old slot, or kNewElement.
void TopologyEditor::writeElementSources(Finalization& state) const {
  TopologyChange& tc = state.change;
  const std::size_t elements = oc_.elements_.size();
  tc.elementSource.resize(elements);
  for (std::uint32_t e = 0; e < elements; ++e)
    tc.elementSource[e] = e < oldElements_ && !state.freedElement[e] ? e : kNewElement;
  for (std::uint32_t i : state.alive)
    if (copies_[i].sameAs != kNoElement) tc.elementSource[state.finalId[i]] = copies_[i].sameAs;
}

// Fills the element slots left free with the last elements (after merges), renumbering the
// embedding of their voxels, the cube index and the hanging nodes' coarse elements.
void TopologyEditor::fillElementHoles(Finalization& state) {
  if (state.elementHoles.empty()) return;
  std::vector<OctreeElement>& E = oc_.elements_;
  std::vector<std::uint32_t>& source = state.change.elementSource;
  std::size_t count = E.size();
  std::vector<std::uint32_t> remap(count);
  for (std::uint32_t e = 0; e < count; ++e) remap[e] = e;
  std::vector<char> hole(count, 0);
  for (std::uint32_t h : state.elementHoles) hole[h] = 1;
  std::vector<std::uint64_t> movedCubes;
  for (std::uint32_t h : state.elementHoles) {
    while (count > 0 && hole[count - 1]) --count;
    if (h >= count) break;
    const std::size_t last = count - 1;
    E[h] = E[last];
    source[h] = source[last];
    remap[last] = h;
    hole[h] = 0;
    hole[last] = 1;
    --count;
    movedCubes.push_back(DeformationOctree::cubeKey(E[h].level, E[h].coord));
  }
  while (count > 0 && hole[count - 1]) --count;
  // The moved elements' voxels, and their cubes' chains of copies (ascending ids).
  std::sort(movedCubes.begin(), movedCubes.end());
  movedCubes.erase(std::unique(movedCubes.begin(), movedCubes.end()), movedCubes.end());
  const Index3 gd = grid_.dims();
  for (std::uint64_t k : movedCubes) {
    std::vector<std::uint32_t> ids;
    for (std::uint32_t e = oc_.cubeFirst_.at(k); e != kNoElement; e = oc_.nextCopy_[e])
      ids.push_back(remap[e]);
    std::sort(ids.begin(), ids.end());
    oc_.cubeFirst_[k] = ids.front();
    for (std::size_t j = 0; j < ids.size(); ++j)
      oc_.nextCopy_[ids[j]] = j + 1 < ids.size() ? ids[j + 1] : kNoElement;
    const Index3 f = keyFirstVoxel(k);
    const int s = 1 << keyLevel(k);
    for (int z = f.z; z < std::min(f.z + s, gd.z); ++z)
      for (int y = f.y; y < std::min(f.y + s, gd.y); ++y)
        for (int x = f.x; x < std::min(f.x + s, gd.x); ++x) {
          VoxelEmbedding& em = oc_.embedding_[grid_.index(x, y, z)];
          if (em.element != kNoElement) em.element = remap[em.element];
        }
  }
  E.resize(count);
  oc_.nextCopy_.resize(count);
  source.resize(count);
  for (HangingNode& hn : oc_.hanging_) hn.element = remap[hn.element];
}

}  // namespace voxcut
