#pragma once
/// @file TopologyEditor.h
/// Internal to fem: the working state of one topology update of a deformation octree
/// (CutTopology.h holds the rule and the public entry points). Not part of the public API.

#include <array>
#include <cstdint>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "voxcut/core/Error.h"
#include "voxcut/core/FlatHashMap.h"
#include "voxcut/core/UnionFind.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/topology/TopologyChange.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {
namespace topology_detail {

constexpr std::uint64_t kNoKey = ~std::uint64_t{0};
/// Flags a node made by this update in a corner array; the low bits index the new nodes.
constexpr std::uint32_t kTempNode = 0x80000000u;

inline int keyLevel(std::uint64_t k) {
  return static_cast<int>(k >> 60);
}
inline Index3 keyFirstVoxel(std::uint64_t k) {
  const std::uint64_t m = (std::uint64_t{1} << 20) - 1;
  const int L = keyLevel(k);
  return {static_cast<int>((k >> 40) & m) << L, static_cast<int>((k >> 20) & m) << L,
          static_cast<int>(k & m) << L};
}
inline std::uint64_t pointKey(const Index3& p) {
  return (static_cast<std::uint64_t>(p.x) << 42) | (static_cast<std::uint64_t>(p.y) << 21) |
         static_cast<std::uint64_t>(p.z);
}
inline Index3 pointOf(std::uint64_t k) {
  const std::uint64_t m = (std::uint64_t{1} << 21) - 1;
  return {static_cast<int>(k >> 42), static_cast<int>((k >> 21) & m), static_cast<int>(k & m)};
}

/// Node-grid point p against the closed cube [f, f + s]^3: -1 outside, else the number of
/// axes along which p lies strictly inside (0 corner, 1 edge, 2 face, 3 interior).
inline int interiorAxes(const Index3& f, int s, const Index3& p) {
  int n = 0;
  for (int k = 0; k < 3; ++k) {
    if (p[k] < f[k] || p[k] > f[k] + s) return -1;
    n += p[k] != f[k] && p[k] != f[k] + s;
  }
  return n;
}
/// Corner index of p in the cube (p on its closed box): bit k set when p is on the high side.
inline int cornerIndex(const Index3& f, int s, const Index3& p) {
  return (p.x == f.x + s ? 1 : 0) | (p.y == f.y + s ? 2 : 0) | (p.z == f.z + s ? 4 : 0);
}
inline Index3 cornerPoint(const Index3& f, int s, int c) {
  return {f.x + (c & 1) * s, f.y + ((c >> 1) & 1) * s, f.z + ((c >> 2) & 1) * s};
}
/// The corners of the cube's edge (2) or face (4) whose midpoint or centre is p, ascending.
inline int masterCorners(const Index3& f, int s, const Index3& p, std::array<int, 4>& out) {
  int fixed = 0, freeMask = 0;
  for (int k = 0; k < 3; ++k) {
    if (p[k] == f[k] + s)
      fixed |= 1 << k;
    else if (p[k] != f[k]) {
      VOXCUT_ASSERT(2 * (p[k] - f[k]) == s,
                    "hanging node off a coarse edge midpoint or face centre");
      freeMask |= 1 << k;
    }
  }
  int n = 0;
  for (int c = 0; c < 8; ++c)
    if ((c & ~freeMask) == fixed) out[static_cast<std::size_t>(n++)] = c;
  return n;
}

/// A provisional element copy: one connected part of a cube partitioned by this update.
struct NewCopy {
  std::uint64_t key = 0;
  std::uint32_t minVoxel = 0;
  std::uint32_t origin = kNoElement;  ///< old element whose part held these voxels
  std::uint32_t sameAs = kNoElement;  ///< old element with the same cube and voxels
  /// For a cube made by merging finer old elements: per corner, the old element of the part's
  /// voxel nearest that corner, whose node (or map) gives the new corner node's state;
  /// kNoElement elsewhere (the node then comes from `origin`'s map).
  std::array<std::uint32_t, 8> cornerOrigin{kNoElement, kNoElement, kNoElement, kNoElement,
                                            kNoElement, kNoElement, kNoElement, kNoElement};
  bool alive = true;
};

struct CubeParts {
  std::vector<std::uint32_t> voxels;  ///< occupied voxels of the cube, ascending
  std::vector<std::uint32_t> part;    ///< part of each
  std::vector<NewCopy> parts;         ///< in order of their lowest voxel
};

/// One element copy around a node-grid point.
struct GroupMember {
  std::uint32_t copy = 0;
  std::int8_t corner = -1;  ///< its corner index at the point; -1: a coarse copy (p hangs on it)
  bool last = false;        ///< the last member of its group
};
/// The element copies around one node-grid point, group by group: the corner copies of a
/// group share one node copy there, hanging on the group's coarse copies if any. Members keep
/// the order of their cubes and copies within a group; groups come in the order of their
/// first member; only groups with a corner copy are kept.
struct PointGroups {
  Index3 p;
  std::vector<GroupMember> members;
};
/// Buffers reused by groupAt across the points of one task.
struct GroupScratch {
  std::vector<std::uint32_t> members;
  UnionFind sets;
  std::vector<int> groupOf;
};

/// A node made by this update: its node-grid point, where it comes from in the old state, its
/// position, and the coarse copy it hangs on (kNoElement: none).
struct TempNode {
  Index3 p;
  NodeSource src;
  Vec3d pos = Vec3d::Zero();
  std::uint32_t coarse = kNoElement;
};

/// When the leaves below a cube may merge into it (CutTopology.h, CoarsenParams).
struct CoarsenRule {
  int startLevel = 3;    ///< no merge makes a leaf coarser than this
  int surfaceLevel = 3;  ///< up to this level any parent merges; above, only half-full ones
  int frontLevel = 1;    ///< merges that glue a cut link's voxels stop at this level
};

/// What the phases of TopologyEditor::finalize hand on to each other.
struct Finalization {
  std::vector<TempNode> temp;          ///< the nodes made by this update
  std::vector<char> freedElement;      ///< per old element: its slot was freed
  std::vector<char> freedNode;         ///< per old node: its slot was freed
  std::vector<std::uint32_t> alive;    ///< provisional copies kept, by lowest voxel
  std::vector<std::uint32_t> finalId;  ///< per provisional copy: its element slot
  std::vector<std::uint32_t> nodeId;   ///< per new node: its node slot
  std::vector<std::uint32_t> holes;    ///< node slots left free, to fill with the last nodes
  std::uint32_t appended = 0;          ///< elements added after the old ones
  std::uint32_t appendedNodes = 0;     ///< nodes added after the old ones
  std::vector<std::uint32_t> elementHoles;  ///< element slots left free (after merges)
  std::size_t nodeCount = 0;           ///< nodes after the update
  std::vector<std::uint64_t> cubes;    ///< the partitioned cubes, ascending
  bool changed = false;                ///< anything differs from the old octree
  TopologyChange change;
  /// The final element id of element copy `copy` (old ids stay).
  [[nodiscard]] std::uint32_t finalOf(std::uint32_t copy, std::uint32_t oldElements) const {
    return copy < oldElements ? copy : finalId[copy - oldElements];
  }
};

}  // namespace topology_detail

/// The working state of one topology update (friend of DeformationOctree).
class TopologyEditor {
 public:
  TopologyEditor(DeformationOctree& oc, const VoxelGrid& grid, bool threaded)
      : oc_(oc),
        grid_(grid),
        threaded_(threaded),
        oldElements_(static_cast<std::uint32_t>(oc.elements_.size())),
        oldNodes_(static_cast<std::uint32_t>(oc.nodeCoords_.size())),
        leaves_() {
    leaves_.reserve(oc.cubeFirst_.size() + 8);
    for (const auto& [key, first] : oc.cubeFirst_) leaves_.set(key, first);
    VOXCUT_ASSERT(grid.dims() == oc.dims_, "octree and grid differ");
    const Index3 gd = grid.dims();
    tileDims_ = {(gd.x >> kTileLevel) + 2, (gd.y >> kTileLevel) + 2, (gd.z >> kTileLevel) + 2};
    tileIndex_.assign(static_cast<std::size_t>(tileDims_.x) * tileDims_.y * tileDims_.z, -1);
  }

  /// Marks the leaves holding a voxel of a cut link dirty, first refining them (the coarser
  /// of the link's two leaves first, down to `finest`) while the link's two voxels stay glued
  /// there: in one part of their leaf, or in parts of two leaves joined by another connected
  /// link across their shared face (docs/algorithms.md, "Cut topology"). With `refineOnly`,
  /// leaves are not marked dirty, only refined (the refined ones are partitioned).
  void seedCuts(const std::vector<std::uint64_t>& links, int finest, bool refineOnly = false);
  /// Merges, bottom up, the leaves inside each region cube (a cube key) into their parents
  /// where the rule allows (docs/algorithms.md, "Coarsening after cuts"); returns the regions
  /// where a merge was refused only because a finer neighbour breaks 2:1 there.
  std::vector<std::uint64_t> seedMerges(const std::vector<std::uint64_t>& regions,
                                        const topology_detail::CoarsenRule& rule);
  /// Marks every leaf dirty (the load-time rule).
  void seedAll();
  /// Partitions, groups, refines ambiguous cubes until none is left, then writes the octree.
  TopologyChange run();
  [[nodiscard]] bool anythingDirty() const { return !pending_.empty() || !removed_.empty(); }
  /// Cubes that seedMerges merged and run() then split again for an ambiguous hanging node.
  [[nodiscard]] const std::vector<std::uint64_t>& unmerged() const { return unmerged_; }

 private:
  /// The leaf cube holding `voxel` whose level is at least minLevel, kNoKey when none. Reads
  /// the tile of leaf levels when it is built, else probes the levels.
  [[nodiscard]] std::uint64_t leafOf(const Index3& voxel, int minLevel = 0) const;
  [[nodiscard]] std::uint64_t probeLeaf(const Index3& voxel, int minLevel) const;
  /// Fills the tile of leaf levels holding `voxel` unless it is built or off the tile grid.
  /// Serial only.
  void buildTile(const Index3& voxel);
  /// Writes `level` into the built tiles over the cube [first, first + size)^3 (a split).
  void setLeafLevels(const Index3& first, int size, int level);
  void makeDirty(std::uint64_t key);
  void split(std::uint64_t key);
  /// The parts of leaf `key` as they are now (cached by key while it stays a leaf).
  const topology_detail::CubeParts& cachedParts(std::uint64_t key);
  /// Whether cut link v-w (w = v + stride(axis)) in leaves a (holding v) and b (holding w)
  /// still holds its voxels together: the same part of one leaf, or parts of two leaves that
  /// another connected link joins across their shared face.
  [[nodiscard]] bool glued(std::uint64_t a, std::uint64_t b, std::size_t v, std::size_t w,
                           int axis);
  /// How the cube `key` stands after coarsening below it.
  enum class Below { kEmpty, kLeaf, kInner };
  Below coarsenBelow(std::uint64_t key, const topology_detail::CoarsenRule& rule, bool& blocked);
  /// Whether the 8 children of `key` (leaves or empty) may become one leaf; sets `blocked`
  /// when only a finer neighbour (2:1) forbids it.
  bool mayMerge(std::uint64_t key, const topology_detail::CoarsenRule& rule, bool& blocked);
  /// Whether one leaf over cube `key` would hold the two voxels of a cut link in one part.
  [[nodiscard]] bool mergeGlues(std::uint64_t key) const;
  /// Replaces the child leaves of `key` by one dirty leaf.
  void merge(std::uint64_t key);
  /// The old element that held voxel v before this update.
  [[nodiscard]] std::uint32_t oldElementOf(std::size_t v) const {
    const std::uint32_t e = oc_.embedding_[v].element;
    if (e < oldElements_) return e;
    const auto it = oldOwner_.find(static_cast<std::uint32_t>(v));
    return it != oldOwner_.end() ? it->second : origin(e);
  }
  /// The old element a new corner node of `copy` at its corner c takes its state from.
  [[nodiscard]] std::uint32_t originAt(std::uint32_t copy, int c) const {
    if (copy >= oldElements_) {
      const std::uint32_t o = copies_[copy - oldElements_].cornerOrigin[static_cast<std::size_t>(c)];
      if (o != kNoElement) return o;
    }
    return origin(copy);
  }
  void copiesOf(std::uint64_t key, std::vector<std::uint32_t>& out) const;
  [[nodiscard]] std::uint32_t origin(std::uint32_t copy) const {
    return copy < oldElements_ ? copy : copies_[copy - oldElements_].origin;
  }
  [[nodiscard]] topology_detail::CubeParts partition(std::uint64_t key) const;
  void partitionPending();
  /// The node-grid points to regroup (keys ascending) and the leaves around each: the points
  /// of the partitioned and removed cubes, and the edge midpoints and face centres of the
  /// leaves touching those. Builds the tiles they read.
  void dirtyPoints(std::vector<std::uint64_t>& keys,
                   std::vector<std::array<std::uint64_t, 8>>& around);
  /// The leaves holding the 8 voxels around node-grid point p (kNoKey where none), in the
  /// order of the offsets (d & 1, (d >> 1) & 1, d >> 2) - 1.
  [[nodiscard]] std::array<std::uint64_t, 8> leavesAround(const Index3& p) const;
  [[nodiscard]] topology_detail::PointGroups groupAt(const Index3& p,
                                                     const std::array<std::uint64_t, 8>& around,
                                                     topology_detail::GroupScratch& scratch) const;
  void assignTempNodes();
  [[nodiscard]] std::uint32_t cornerNode(std::uint32_t copy, int c) const;
  [[nodiscard]] std::vector<std::uint64_t> ambiguousCubes() const;
  /// Writes the octree from the settled groups, in the phases below (in this order).
  TopologyChange finalize();
  [[nodiscard]] std::vector<topology_detail::TempNode> makeTempNodes() const;
  void assignElementSlots(topology_detail::Finalization& state) const;
  void assignNodeSlots(topology_detail::Finalization& state) const;
  void writeNodes(topology_detail::Finalization& state);
  void writeElements(topology_detail::Finalization& state);
  void renumberEmbedding(const topology_detail::Finalization& state);
  void writeCubeIndex(const topology_detail::Finalization& state);
  [[nodiscard]] std::vector<HangingNode> keptAndNewHangingNodes(
      const topology_detail::Finalization& state) const;
  void fillNodeHoles(topology_detail::Finalization& state, std::vector<HangingNode>& hanging);
  void writeHangingNodes(topology_detail::Finalization& state, std::vector<HangingNode> hanging);
  void writeElementSources(topology_detail::Finalization& state) const;
  void fillElementHoles(topology_detail::Finalization& state);

  DeformationOctree& oc_;
  const VoxelGrid& grid_;
  bool threaded_;
  std::uint32_t oldElements_, oldNodes_;
  /// The leaves: oc_.cubeFirst_ kept in step, except that a partitioned leaf maps to its first
  /// provisional copy (its copies are consecutive in copies_).
  FlatHashMap<std::uint32_t> leaves_;
  /// Level of the leaf holding each voxel (-1: none), in tiles of 8^3 voxels built on demand:
  /// tileIndex_ is -1 or the tile's block of 512 entries in tileLevels_ (x fastest).
  static constexpr int kTileLevel = 3, kTileSize = 1 << kTileLevel;
  Index3 tileDims_;
  std::vector<std::int32_t> tileIndex_;
  std::vector<std::int8_t> tileLevels_;
  std::unordered_set<std::uint64_t> pending_;  ///< leaves to partition
  /// Partitioned leaves and their provisional copies (ids oldElements_ + index in copies_).
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> partitioned_;
  std::vector<topology_detail::NewCopy> copies_;
  std::vector<std::uint32_t> removed_;       ///< old elements whose slots are freed
  std::vector<std::uint64_t> removedCubes_;  ///< old leaves split or repartitioned
  std::vector<std::uint64_t>
      seenPoints_;  ///< dirtyPoints' bitmap over the node grid, clear between calls
  std::vector<topology_detail::PointGroups> points_;
  std::vector<std::uint64_t> lastPoints_;                 ///< keys of points_, ascending
  std::vector<std::array<std::uint64_t, 8>> lastAround_;  ///< their leaves
  std::unordered_map<std::uint32_t, std::array<std::uint32_t, 8>> cornerNodes_;
  std::unordered_set<std::uint64_t> merged_;  ///< cubes seedMerges made leaves
  std::vector<std::uint64_t> unmerged_;       ///< of those, the ones run() split again
  /// Old owners of voxels whose embedding this update has pointed at provisional copies.
  std::unordered_map<std::uint32_t, std::uint32_t> oldOwner_;
  /// Parts of leaves looked at by seedCuts, by cube key.
  std::unordered_map<std::uint64_t, topology_detail::CubeParts> partCache_;
  /// (point, its group's first member) of each node made by this update.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> tempNodes_;
};

}  // namespace voxcut
