#include "voxcut/topology/DeformationOctree.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <string>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/topology/CutTopology.h"

namespace voxcut {

// ---------------------------------------------------------------------------------------------
// DeformationOctree
// ---------------------------------------------------------------------------------------------

DeformationOctree::DeformationOctree(const VoxelGrid& grid, int maxLevel,
                                     std::vector<OctreeElement> elements,
                                     std::vector<Index3> nodeCoords,
                                     std::vector<HangingNode> hanging,
                                     std::vector<VoxelEmbedding> embedding)
    : dims_(grid.dims()),
      origin_(grid.origin()),
      voxelSize_(grid.voxelSize()),
      maxLevel_(maxLevel),
      elements_(std::move(elements)),
      nodeCoords_(std::move(nodeCoords)),
      hanging_(std::move(hanging)),
      embedding_(std::move(embedding)) {
  VOXCUT_ASSERT(embedding_.size() == grid.voxelCount(), "one embedding per grid voxel");
  restPositions_.resize(nodeCoords_.size());
  for (std::size_t n = 0; n < nodeCoords_.size(); ++n)
    restPositions_[n] = nodeGridPosition(nodeCoords_[n]);
  positions_ = restPositions_;
  hangingFlag_.assign(nodeCoords_.size(), 0);
  for (const HangingNode& hn : hanging_) {
    VOXCUT_ASSERT(hn.node < nodeCoords_.size(), "hanging node id out of range");
    VOXCUT_ASSERT(hn.masterCount == 2 || hn.masterCount == 4, "a hanging node has 2 or 4 masters");
    hangingFlag_[hn.node] = 1;
  }
  for (const OctreeElement& e : elements_) {
    VOXCUT_ASSERT(e.level >= 0 && e.level <= maxLevel_, "element level out of range");
    for (std::uint32_t n : e.nodes)
      VOXCUT_ASSERT(n < nodeCoords_.size(), "element node id out of range");
  }
  for (std::size_t v = 0; v < embedding_.size(); ++v) {
    if (embedding_[v].element == kNoElement) continue;
    VOXCUT_ASSERT(embedding_[v].element < elements_.size(), "voxel owner out of range");
    ++occupiedVoxels_;
    restVoxelBounds_.extend(grid.position(v));
  }
  rebuildCubeIndex();
}

void DeformationOctree::rebuildCubeIndex() {
  cubeFirst_.clear();
  cubeFirst_.reserve(elements_.size());
  nextCopy_.assign(elements_.size(), kNoElement);
  // Backwards, so that each chain ends up in ascending id order.
  for (std::size_t i = elements_.size(); i-- > 0;) {
    const OctreeElement& e = elements_[i];
    auto [it, fresh] =
        cubeFirst_.try_emplace(cubeKey(e.level, e.coord), static_cast<std::uint32_t>(i));
    if (!fresh) {
      nextCopy_[i] = it->second;
      it->second = static_cast<std::uint32_t>(i);
    }
  }
}

std::uint32_t DeformationOctree::firstCopy(int level, const Index3& c) const {
  const auto it = cubeFirst_.find(cubeKey(level, c));
  return it == cubeFirst_.end() ? kNoElement : it->second;
}

std::vector<std::uint32_t> DeformationOctree::cubeCopies(int level, const Index3& c) const {
  std::vector<std::uint32_t> out;
  for (std::uint32_t e = firstCopy(level, c); e != kNoElement; e = nextCopy_[e]) out.push_back(e);
  return out;
}

void DeformationOctree::updateHangingNodes() {
  // Ordered coarse first: a master that is itself hanging is already resolved.
  for (const HangingNode& hn : hanging_) {
    Vec3d sum = Vec3d::Zero();
    for (int m = 0; m < hn.masterCount; ++m) sum += positions_[hn.masters[m]];
    positions_[hn.node] = sum / static_cast<double>(hn.masterCount);
  }
}

std::array<double, 8> DeformationOctree::weights(std::size_t v) const {
  return trilinearWeights(localCoordinates(v));
}

namespace {

/// The trilinear map of an element in monomial form,
///   x(u, v, w) = c0 + c1 u + c2 v + c3 w + c4 u v + c5 u w + c6 v w + c7 u v w,
/// from its eight corners (corner bit i set: high along axis i). Its value and Jacobian then
/// cost a few multiply-adds per Newton step instead of a pass over the corners.
struct TrilinearMap {
  std::array<Vec3d, 8> c;

  TrilinearMap(const std::vector<Vec3d>& positions, const std::array<std::uint32_t, 8>& nodes) {
    const Vec3d& p0 = positions[nodes[0]];
    const Vec3d& p1 = positions[nodes[1]];
    const Vec3d& p2 = positions[nodes[2]];
    const Vec3d& p3 = positions[nodes[3]];
    const Vec3d& p4 = positions[nodes[4]];
    const Vec3d& p5 = positions[nodes[5]];
    const Vec3d& p6 = positions[nodes[6]];
    const Vec3d& p7 = positions[nodes[7]];
    c[0] = p0;
    c[1] = p1 - p0;
    c[2] = p2 - p0;
    c[3] = p4 - p0;
    c[4] = p3 - p2 - p1 + p0;
    c[5] = p5 - p4 - p1 + p0;
    c[6] = p6 - p4 - p2 + p0;
    c[7] = p7 - p6 - p5 - p3 + p4 + p2 + p1 - p0;
  }

  /// x at t and the Jacobian's columns d x / d t_i.
  void evaluate(const Vec3d& t, Vec3d& x, Eigen::Matrix3d& jacobian) const {
    const double u = t.x(), v = t.y(), w = t.z();
    x = c[0] + u * c[1] + v * c[2] + w * c[3] + (u * v) * c[4] + (u * w) * c[5] + (v * w) * c[6] +
        (u * v * w) * c[7];
    jacobian.col(0) = c[1] + v * c[4] + w * c[5] + (v * w) * c[7];
    jacobian.col(1) = c[2] + u * c[4] + w * c[6] + (u * w) * c[7];
    jacobian.col(2) = c[3] + u * c[5] + v * c[6] + (u * v) * c[7];
  }
};

}  // namespace

bool DeformationOctree::trilinearCoordinates(std::uint32_t e, const Vec3d& p, Vec3d& t,
                                             const Vec3d& start) const {
  const TrilinearMap map(positions_, elements_[e].nodes);
  t = start;
  const double tol = 1e-12 * voxelSize_ * elements_[e].size();
  Vec3d x;
  Eigen::Matrix3d jacobian;
  for (int it = 0; it < 20; ++it) {
    map.evaluate(t, x, jacobian);
    const Vec3d r = x - p;
    if (r.norm() <= tol) break;
    // J^-1 r by the adjugate (the rows of J^-1 are the cross products of J's columns over det).
    const Vec3d a0 = jacobian.col(1).cross(jacobian.col(2));
    const Vec3d a1 = jacobian.col(2).cross(jacobian.col(0));
    const Vec3d a2 = jacobian.col(0).cross(jacobian.col(1));
    const double det = jacobian.col(0).dot(a0);
    if (!(std::abs(det) > 0) || !std::isfinite(det)) return false;
    t -= Vec3d(a0.dot(r), a1.dot(r), a2.dot(r)) / det;
    if (!t.allFinite() || t.cwiseAbs().maxCoeff() > 4.0) return false;
  }
  map.evaluate(t, x, jacobian);
  constexpr double kSlack = 1e-9;
  return (x - p).norm() <= 1e-6 * voxelSize_ && (t.array() >= -kSlack).all() &&
         (t.array() <= 1.0 + kSlack).all();
}

void DeformationOctree::updateVoxelPositions(const std::vector<std::uint32_t>& voxels,
                                             std::vector<Vec3d>& out, bool threaded) const {
  out.resize(voxels.size());
  // Voxels listed in index order come in runs along x through one element: the row segment
  // is computed once per run (element, y offset, z offset) and each voxel costs one lerp. The
  // voxels may be sparse (the octree's active ones): their embeddings are fetched ahead.
  parallelFor(
      0, voxels.size(), 4096,
      [&](std::size_t b, std::size_t e) {
        std::uint32_t element = kNoElement;
        std::uint8_t oy = 0, oz = 0;
        double inv = 1.0;
        detail::RowSegment row{Vec3d::Zero(), Vec3d::Zero()};
        for (std::size_t i = b; i < e; ++i) {
          if (i + 16 < e) __builtin_prefetch(&embedding_[voxels[i + 16]]);
          const VoxelEmbedding& em = embedding_[voxels[i]];
          VOXCUT_ASSERT(em.element != kNoElement, "voxel is empty");
          if (em.element != element || em.offset[1] != oy || em.offset[2] != oz) {
            element = em.element;
            oy = em.offset[1];
            oz = em.offset[2];
            inv = elements_[element].inverseSize();
            row = detail::rowSegment(positions_, elements_[element].nodes, (oy + 0.5) * inv,
                                     (oz + 0.5) * inv);
          }
          out[i] = row.start + ((em.offset[0] + 0.5) * inv) * row.delta;
        }
      },
      threaded);
}

Eigen::AlignedBox3d DeformationOctree::elementBounds(std::uint32_t e) const {
  Eigen::AlignedBox3d box;
  for (std::uint32_t n : elements_[e].nodes) box.extend(positions_[n]);
  return box;
}

void DeformationOctree::updateElementBounds(std::vector<Eigen::AlignedBox3d>& out,
                                            bool threaded) const {
  out.resize(elements_.size());
  // Serial for a few thousand elements: the pass is shorter than waking the workers.
  parallelFor(
      0, elements_.size(), 2048,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) out[i] = elementBounds(static_cast<std::uint32_t>(i));
      },
      threaded);
}

std::vector<std::size_t> DeformationOctree::elementCountPerLevel() const {
  std::vector<std::size_t> count(static_cast<std::size_t>(maxLevel_) + 1, 0);
  for (const OctreeElement& e : elements_) ++count[static_cast<std::size_t>(e.level)];
  return count;
}

std::vector<std::size_t> DeformationOctree::nodeCountPerLevel() const {
  std::vector<int> finest(nodeCoords_.size(), maxLevel_);
  for (const OctreeElement& e : elements_)
    for (std::uint32_t n : e.nodes) finest[n] = std::min(finest[n], e.level);
  std::vector<std::size_t> count(static_cast<std::size_t>(maxLevel_) + 1, 0);
  for (int l : finest) ++count[static_cast<std::size_t>(l)];
  return count;
}

// ---------------------------------------------------------------------------------------------
// Build
// ---------------------------------------------------------------------------------------------

namespace {

/// A dense grid of per-block flags at one level.
struct LevelGrid {
  Index3 dims;
  std::vector<std::uint8_t> flag;
  [[nodiscard]] bool inside(const Index3& b) const {
    return b.x >= 0 && b.y >= 0 && b.z >= 0 && b.x < dims.x && b.y < dims.y && b.z < dims.z;
  }
  [[nodiscard]] std::size_t index(const Index3& b) const {
    return static_cast<std::size_t>(b.x) +
           static_cast<std::size_t>(dims.x) *
               (static_cast<std::size_t>(b.y) +
                static_cast<std::size_t>(dims.y) * static_cast<std::size_t>(b.z));
  }
  [[nodiscard]] bool at(const Index3& b) const { return inside(b) && flag[index(b)] != 0; }
  [[nodiscard]] Index3 coord(std::size_t i) const {
    const auto nx = static_cast<std::size_t>(dims.x), ny = static_cast<std::size_t>(dims.y);
    return {static_cast<int>(i % nx), static_cast<int>((i / nx) % ny),
            static_cast<int>(i / (nx * ny))};
  }
};

int ceilShift(int n, int level) {
  return (n + (1 << level) - 1) >> level;
}
Index3 shiftDown(const Index3& c, int s) {
  return {c.x >> s, c.y >> s, c.z >> s};
}
Index3 child(const Index3& p, int c) {
  return {2 * p.x + (c & 1), 2 * p.y + ((c >> 1) & 1), 2 * p.z + ((c >> 2) & 1)};
}

/// leaf[L] flags the elements of level L (L in [F, M]; entries below F are unused).
struct Leaves {
  int F = 0, M = 0;
  std::vector<LevelGrid> leaf;
  std::vector<std::vector<std::uint32_t>> count;  ///< occupied voxels per block, per level
};

/// The leaves before balancing, top down: a block of level L in (S, M] is an element when it
/// is full (every voxel it covers occupied) and no coarser element covers it; an occupied
/// block of level L in [F, S] not covered by a coarser element is one when L = F or it is at
/// least half full, else its occupied children are looked at in turn.
Leaves initialLeaves(const VoxelGrid& grid, int F, int S, int M, bool threaded) {
  Leaves lv;
  lv.F = F;
  lv.M = M;
  lv.leaf.resize(static_cast<std::size_t>(M) + 1);
  lv.count.resize(static_cast<std::size_t>(M) + 1);
  for (int L = F; L <= M; ++L) {
    LevelGrid& g = lv.leaf[static_cast<std::size_t>(L)];
    g.dims = {ceilShift(grid.dims().x, L), ceilShift(grid.dims().y, L),
              ceilShift(grid.dims().z, L)};
    g.flag.assign(static_cast<std::size_t>(g.dims.x) * g.dims.y * g.dims.z, 0);
    lv.count[static_cast<std::size_t>(L)].assign(g.flag.size(), 0);
  }
  // Occupied-voxel counts per level-F block; one task per block slab in z, so each block is
  // written by one task only. A coarser block's count sums its 8 children's.
  const LevelGrid& base = lv.leaf[static_cast<std::size_t>(F)];
  std::vector<std::uint32_t>& baseCount = lv.count[static_cast<std::size_t>(F)];
  const Index3 gd = grid.dims();
  parallelFor(
      0, static_cast<std::size_t>(base.dims.z), 1,
      [&](std::size_t zb, std::size_t ze) {
        for (int z = static_cast<int>(zb) << F; z < std::min(gd.z, static_cast<int>(ze) << F); ++z)
          for (int y = 0; y < gd.y; ++y)
            for (int x = 0; x < gd.x; ++x)
              if (grid.occupied(grid.index(x, y, z)))
                ++baseCount[base.index({x >> F, y >> F, z >> F})];
      },
      threaded);
  for (int L = F + 1; L <= M; ++L) {
    const LevelGrid& g = lv.leaf[static_cast<std::size_t>(L)];
    const LevelGrid& fine = lv.leaf[static_cast<std::size_t>(L) - 1];
    const std::vector<std::uint32_t>& fineCount = lv.count[static_cast<std::size_t>(L) - 1];
    std::vector<std::uint32_t>& c = lv.count[static_cast<std::size_t>(L)];
    for (std::size_t b = 0; b < g.flag.size(); ++b)
      for (int k = 0; k < 8; ++k) {
        const Index3 ch = child(g.coord(b), k);
        if (fine.inside(ch)) c[b] += fineCount[fine.index(ch)];
      }
  }
  for (int L = M; L >= F; --L) {
    LevelGrid& g = lv.leaf[static_cast<std::size_t>(L)];
    const std::vector<std::uint32_t>& c = lv.count[static_cast<std::size_t>(L)];
    const std::uint32_t full = 1u << (3 * L);
    for (std::size_t b = 0; b < g.flag.size(); ++b) {
      if (c[b] == 0) continue;
      const bool accept = L > S ? c[b] == full : (L == F || 2 * c[b] >= full);
      if (!accept) continue;
      bool covered = false;
      for (int m = L + 1; m <= M && !covered; ++m)
        covered = lv.leaf[static_cast<std::size_t>(m)].at(shiftDown(g.coord(b), m - L));
      g.flag[b] = !covered;
    }
  }
  return lv;
}

/// Refines coarse elements until every two touching elements differ by at most one level.
/// Checked from the finer side: for each element and each of its 26 neighbouring blocks of
/// the same size, an element two or more levels coarser containing that block is split into
/// its occupied children. Repeats until nothing changes.
void balance(Leaves& lv) {
  bool changed = true;
  while (changed) {
    changed = false;
    for (int L = lv.F; L + 2 <= lv.M; ++L) {
      const LevelGrid& g = lv.leaf[static_cast<std::size_t>(L)];
      for (std::size_t b = 0; b < g.flag.size(); ++b) {
        if (!g.flag[b]) continue;
        const Index3 c = g.coord(b);
        for (int d = 0; d < 27; ++d) {
          if (d == 13) continue;
          const Index3 nb{c.x + d % 3 - 1, c.y + (d / 3) % 3 - 1, c.z + d / 9 - 1};
          if (!g.inside(nb)) continue;
          for (int m = L + 2; m <= lv.M; ++m) {
            LevelGrid& coarse = lv.leaf[static_cast<std::size_t>(m)];
            const Index3 p = shiftDown(nb, m - L);
            if (!coarse.at(p)) continue;
            coarse.flag[coarse.index(p)] = 0;
            LevelGrid& fine = lv.leaf[static_cast<std::size_t>(m) - 1];
            const std::vector<std::uint32_t>& fineCount = lv.count[static_cast<std::size_t>(m) - 1];
            for (int k = 0; k < 8; ++k) {
              const Index3 ch = child(p, k);
              if (fine.inside(ch) && fineCount[fine.index(ch)] > 0) fine.flag[fine.index(ch)] = 1;
            }
            changed = true;
          }
        }
      }
    }
  }
}

/// Checks the levels of `params` (start, max and surface level in their ranges).
void checkLevels(const DeformationOctreeParams& params) {
  const int S = params.startLevel;
  if (S < 0 || S > 7)
    throw InputError("deformation octree start level must be in [0, 7], got " + std::to_string(S));
  if (params.maxLevel < S || params.maxLevel > 7)
    throw InputError("deformation octree max level must be in [start level, 7], got " +
                     std::to_string(params.maxLevel));

  if (params.surfaceLevel < -1 || params.surfaceLevel > 7)
    throw InputError("deformation octree surface level must be in [-1, 7], got " +
                     std::to_string(params.surfaceLevel));
}

/// The elements of the leaves, ordered by their first voxel's index (unique: elements do not
/// overlap).
std::vector<OctreeElement> sortedElements(const Leaves& lv, const VoxelGrid& grid) {
  std::vector<std::pair<std::size_t, OctreeElement>> keyed;
  for (int L = lv.F; L <= lv.M; ++L) {
    const LevelGrid& g = lv.leaf[static_cast<std::size_t>(L)];
    for (std::size_t b = 0; b < g.flag.size(); ++b) {
      if (!g.flag[b]) continue;
      OctreeElement e;
      e.coord = g.coord(b);
      e.level = L;
      keyed.emplace_back(grid.index(e.firstVoxel()), e);
    }
  }
  std::sort(keyed.begin(), keyed.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<OctreeElement> elements(keyed.size());
  for (std::size_t i = 0; i < keyed.size(); ++i) elements[i] = keyed[i].second;
  return elements;
}

/// Corner c (bit i set: high along axis i) of element e, in node-grid coordinates.
Index3 elementCorner(const OctreeElement& e, int c) {
  const Index3 f = e.firstVoxel();
  const int s = e.size();
  return Index3{f.x + (c & 1) * s, f.y + ((c >> 1) & 1) * s, f.z + ((c >> 2) & 1) * s};
}

/// The node grid and, per point of it, its node id (kNoElement: no node there).
struct NodeNumbers {
  LevelGrid grid;
  std::vector<std::uint32_t> id;
};

/// Numbers the element corners in node-grid order (their coordinates into `nodeCoords`) and
/// sets each element's nodes. The node grid spans every startLevel block (elements may
/// overhang the voxel grid).
NodeNumbers numberNodes(const VoxelGrid& grid, int S, std::vector<OctreeElement>& elements,
                        std::vector<Index3>& nodeCoords) {
  NodeNumbers nn;
  LevelGrid& nodeGrid = nn.grid;
  nodeGrid.dims = {(ceilShift(grid.dims().x, S) << S) + 1, (ceilShift(grid.dims().y, S) << S) + 1,
                   (ceilShift(grid.dims().z, S) << S) + 1};
  std::vector<std::uint32_t>& nodeId = nn.id;
  nodeId.assign(static_cast<std::size_t>(nodeGrid.dims.x) * nodeGrid.dims.y * nodeGrid.dims.z,
                kNoElement);
  for (const OctreeElement& e : elements)
    for (int c = 0; c < 8; ++c) nodeId[nodeGrid.index(elementCorner(e, c))] = 0;
  for (std::size_t i = 0; i < nodeId.size(); ++i) {
    if (nodeId[i] == kNoElement) continue;
    nodeId[i] = static_cast<std::uint32_t>(nodeCoords.size());
    nodeCoords.push_back(nodeGrid.coord(i));
  }
  for (OctreeElement& e : elements)
    for (int c = 0; c < 8; ++c)
      e.nodes[static_cast<std::size_t>(c)] = nodeId[nodeGrid.index(elementCorner(e, c))];
  return nn;
}

/// Hanging nodes: a node at a coarse element's edge midpoint or face centre, coarse levels
/// descending, then by node. Only a finer element can put a corner there, and the point's
/// coordinates fix the coarse level, so every record of one node is the same; keep the first.
std::vector<HangingNode> hangingNodes(const std::vector<OctreeElement>& elements,
                                      const NodeNumbers& nodes, std::size_t nodeCount) {
  std::vector<HangingNode> hanging;
  std::vector<std::uint8_t> seen(nodeCount, 0);
  auto record = [&](const OctreeElement& e, std::initializer_list<int> cs) {
    Index3 sum{0, 0, 0};
    for (int c : cs) {
      const Index3 p = elementCorner(e, c);
      sum = {sum.x + p.x, sum.y + p.y, sum.z + p.z};
    }
    const int k = static_cast<int>(cs.size());
    const std::uint32_t n = nodes.id[nodes.grid.index({sum.x / k, sum.y / k, sum.z / k})];
    if (n == kNoElement || seen[n]) return;
    seen[n] = 1;
    HangingNode hn;
    hn.node = n;
    hn.element = static_cast<std::uint32_t>(&e - elements.data());
    hn.masterCount = static_cast<std::uint8_t>(k);
    hn.coarseLevel = static_cast<std::uint8_t>(e.level);
    int i = 0;
    for (int c : cs)
      hn.masters[static_cast<std::size_t>(i++)] = e.nodes[static_cast<std::size_t>(c)];
    hanging.push_back(hn);
  };
  for (const OctreeElement& e : elements) {
    if (e.level == 0) continue;
    for (int a = 0; a < 3; ++a) {
      const int u = 1 << ((a + 1) % 3), w = 1 << ((a + 2) % 3), s = 1 << a;
      for (int c : {0, u, w, u | w}) record(e, {c, c | s});  // the 4 edges along axis a
      for (int side : {0, s}) record(e, {side, side | u, side | w, side | u | w});  // 2 faces
    }
  }
  std::sort(hanging.begin(), hanging.end(), [](const HangingNode& a, const HangingNode& b) {
    return a.coarseLevel != b.coarseLevel ? a.coarseLevel > b.coarseLevel : a.node < b.node;
  });
  return hanging;
}

/// Embedding: each element writes the occupied voxels it covers, so no two tasks write one
/// voxel.
std::vector<VoxelEmbedding> embedVoxels(const VoxelGrid& grid,
                                        const std::vector<OctreeElement>& elements,
                                        bool threaded) {
  std::vector<VoxelEmbedding> embedding(grid.voxelCount());
  const Index3 gd = grid.dims();
  parallelFor(
      0, elements.size(), 16,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t i = b; i < end; ++i) {
          const OctreeElement& e = elements[i];
          const Index3 f = e.firstVoxel();
          const int s = e.size();
          for (int z = f.z; z < std::min(f.z + s, gd.z); ++z)
            for (int y = f.y; y < std::min(f.y + s, gd.y); ++y)
              for (int x = f.x; x < std::min(f.x + s, gd.x); ++x) {
                const std::size_t v = grid.index(x, y, z);
                if (!grid.occupied(v)) continue;
                embedding[v].element = static_cast<std::uint32_t>(i);
                embedding[v].offset = {static_cast<std::uint8_t>(x - f.x),
                                       static_cast<std::uint8_t>(y - f.y),
                                       static_cast<std::uint8_t>(z - f.z)};
              }
        }
      },
      threaded);
  return embedding;
}

}  // namespace

DeformationOctree buildDeformationOctree(const VoxelGrid& grid,
                                         const DeformationOctreeParams& params) {
  checkLevels(params);
  const int S = params.startLevel;
  const int M = params.merge ? params.maxLevel : params.startLevel;
  const int F = initialFinestLevel(S, params.surfaceLevel,
                                   std::max({grid.dims().x, grid.dims().y, grid.dims().z}));
  Leaves lv = initialLeaves(grid, F, S, M, params.threaded);
  balance(lv);
  std::vector<OctreeElement> elements = sortedElements(lv, grid);
  std::vector<Index3> nodeCoords;
  const NodeNumbers nodes = numberNodes(grid, S, elements, nodeCoords);
  std::vector<HangingNode> hanging = hangingNodes(elements, nodes, nodeCoords.size());
  std::vector<VoxelEmbedding> embedding = embedVoxels(grid, elements, params.threaded);

  DeformationOctree oc(grid, M, std::move(elements), std::move(nodeCoords), std::move(hanging),
                       std::move(embedding));
  if (params.splitParts) duplicateByParts(oc, grid, params.threaded);
  return oc;
}

}  // namespace voxcut
