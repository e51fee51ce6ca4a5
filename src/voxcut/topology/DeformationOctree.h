#pragma once
/// @file DeformationOctree.h
/// The deformation octree (docs/algorithms.md, "Deformation octree"), structure only: a
/// restricted (2:1) octree of hexahedral elements on the voxel grid offset by half a voxel, its
/// corner nodes with rest and current positions, hanging-node constraints, and each occupied
/// voxel's embedding (owning element and trilinear coordinates). The dynamics (stiffness, mass,
/// solver) live elsewhere.
///
/// Geometry. Element-grid node (i, j, k) sits at origin + h * ((i, j, k) - 0.5), h the voxel
/// size (metres). A level-L element with integer coordinates E covers the voxels
/// [E * 2^L, (E + 1) * 2^L) along each axis and has its corner nodes at node-grid coordinates
/// E * 2^L and (E + 1) * 2^L. A level-0 element is one voxel, centred on the voxel's centre.
/// Corner c in 0..7 of an element is offset by (c & 1, (c >> 1) & 1, (c >> 2) & 1).
///
/// 2:1 rule: the levels of two elements that touch at all (share a face, an edge or only a
/// vertex) differ by at most one (vertex adjacency, the strictest choice). It makes every fine
/// element's corner that lies on a coarse neighbour sit at that neighbour's edge midpoint or
/// face centre, so hanging nodes have 2 or 4 masters. A master can itself be hanging (next to
/// empty space the 2:1 rule does not rule this out); hangingNodes() is ordered so that
/// resolving it front to back sees masters already resolved.
///
/// Copies (docs/algorithms.md, "Element copies and the node rule"). A leaf cube of the
/// octree whose occupied voxels form several connected parts (connected links inside the cube)
/// is one element *copy* per part: copies share the cube (level, coord) and own disjoint voxels.
/// Nodes are copies too: several nodes may sit at one node-grid point, one per group of the
/// element copies around it that stay connected there (rule in CutTopology.h). A hanging node
/// copy's masters are the corner node copies of the coarse element copy it lies on. Element
/// cubes of copies overlap; cubes of different leaves do not.
///
/// Thread-safety: const member functions may run concurrently with each other; anything that
/// moves nodes (positions(), updateHangingNodes()) must not run concurrently with readers.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "voxcut/core/Error.h"
#include "voxcut/core/Types.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Marks a voxel without an owning element (an empty voxel).
inline constexpr std::uint32_t kNoElement = 0xffffffffu;

/// 2^-L for L in [0, 31).
inline constexpr std::array<double, 31> kInverseSizes = [] {
  std::array<double, 31> t{};
  double x = 1.0;
  for (double& v : t) {
    v = x;
    x *= 0.5;
  }
  return t;
}();

/// One hexahedral element of the deformation octree.
struct OctreeElement {
  Index3 coord;   ///< integer coordinates at its level
  int level = 0;  ///< edge length 2^level voxels
  /// Corner node ids; corner c sits at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1).
  std::array<std::uint32_t, 8> nodes{};

  /// Edge length in voxels.
  [[nodiscard]] int size() const { return 1 << level; }
  /// 1 / size(), exact (a power of two), from a table: a voxel's position needs it, and a
  /// division there costs more than the rest of the arithmetic.
  [[nodiscard]] double inverseSize() const {
    return kInverseSizes[static_cast<std::size_t>(level)];
  }
  /// Grid coordinates of the first voxel it covers (also its corner node 0's node coordinates).
  [[nodiscard]] Index3 firstVoxel() const {
    return {coord.x << level, coord.y << level, coord.z << level};
  }
};

/// A node constrained to the mean of its masters: the midpoint of a coarse element's edge
/// (2 masters, the edge's ends) or the centre of its face (4 masters, the face's corners).
struct HangingNode {
  std::uint32_t node = 0;
  std::uint32_t element = kNoElement;      ///< the coarse element copy it lies on
  std::uint8_t masterCount = 0;            ///< 2 or 4
  std::uint8_t coarseLevel = 0;            ///< level of the element whose edge or face it lies on
  std::array<std::uint32_t, 4> masters{};  ///< the first masterCount entries are used
};

namespace detail {

/// The segment of an element with corner `nodes` at trilinear (ty, tz): its ends on the x = 0
/// and x = 1 faces (bilinear in y, then z). pointInElement, voxelPosition and
/// updateVoxelPositions all go through it, so a voxel's position is bitwise the same whichever
/// computes it. Always inlined: as a call (GCC left `face` out of line) it slows the position
/// update markedly (docs/performance.md, "Single-frame cutting test").
struct RowSegment {
  Vec3d start;
  Vec3d delta;
};

[[gnu::always_inline]] inline RowSegment rowSegment(const std::vector<Vec3d>& p,
                                                    const std::array<std::uint32_t, 8>& n,
                                                    double ty, double tz) {
  auto face = [&](std::size_t c) __attribute__((always_inline)) {
    const Vec3d y0 = p[n[c]] + ty * (p[n[c + 2]] - p[n[c]]);
    const Vec3d y1 = p[n[c + 4]] + ty * (p[n[c + 6]] - p[n[c + 4]]);
    return Vec3d(y0 + tz * (y1 - y0));
  };
  const Vec3d a = face(0);
  return {a, face(1) - a};
}

}  // namespace detail

/// Where an occupied voxel lives: its owning element and its offset in voxels from the
/// element's first voxel (each in [0, 2^level)). Its trilinear (local) coordinates are
/// (offset + 0.5) / 2^level, exact in floating point.
struct VoxelEmbedding {
  std::uint32_t element = kNoElement;
  std::array<std::uint8_t, 3> offset{};
};

/// The 8 trilinear weights of the point with trilinear coordinates `t` in an element, for its
/// corners 0..7 (corner c lies at bit a of c along axis a); they sum to 1.
[[nodiscard]] inline std::array<double, 8> trilinearWeights(const Vec3d& t) {
  std::array<double, 8> w{};
  for (int c = 0; c < 8; ++c)
    w[static_cast<std::size_t>(c)] = ((c & 1) ? t.x() : 1 - t.x()) * ((c & 2) ? t.y() : 1 - t.y()) *
                                     ((c & 4) ? t.z() : 1 - t.z());
  return w;
}

/// The surface level a build uses unless told otherwise, for a grid whose longest side is
/// `longestSide` voxels: the coarsest level whose elements span at most an eighth of that
/// side, but not finer than level 3 (8 voxels) nor coarser than `startLevel`. So elements of
/// start levels above 3 that are less than half full are split where they would be coarser
/// than an eighth of the body (docs/algorithms.md, "Composite elements").
[[nodiscard]] constexpr int defaultSurfaceLevel(int startLevel, int longestSide) {
  int level = 3;
  while (level < startLevel && (8 << (level + 1)) <= longestSide) ++level;
  return level < startLevel ? level : startLevel;
}

/// The level of the finest elements a build on a grid with longest side `longestSide` starts
/// with: `surfaceLevel` (-1: the default) capped at `startLevel`.
[[nodiscard]] constexpr int initialFinestLevel(int startLevel, int surfaceLevel, int longestSide) {
  const int s = surfaceLevel < 0 ? defaultSurfaceLevel(startLevel, longestSide) : surfaceLevel;
  return s < startLevel ? s : startLevel;
}

/// Build settings.
struct DeformationOctreeParams {
  int startLevel = 3;  ///< level of the elements that first cover the occupied voxels
  int maxLevel = 4;    ///< coarsest level merging may reach (>= startLevel)
  /// Elements of a level above this one that are less than half full (at the surface, in
  /// thin parts) are split into their occupied children, down to this level at most; no
  /// effect when >= startLevel; -1: defaultSurfaceLevel for the grid. Coarse trilinear
  /// elements cannot bend the thin parts they embed (docs/algorithms.md, "Composite
  /// elements").
  int surfaceLevel = -1;
  bool merge = true;  ///< merge 8 full siblings into their parent, up to maxLevel
  /// Duplicate elements per connected voxel part and nodes per connected group (the rule of
  /// CutTopology.h), so lobes that pass through one element are not glued together. Off: one
  /// element per leaf cube, one node per node-grid point.
  bool splitParts = true;
  bool threaded = true;
};

class TopologyEditor;

/// The deformation octree. Owns its arrays; copyable (tests and later cut steps copy it).
class DeformationOctree {
 public:
  DeformationOctree() = default;
  /// Assembles an octree from its parts (the builder's job; checks sizes by assertion).
  /// `grid` gives the geometry and dims; `nodeCoords` are node-grid coordinates; rest and
  /// current positions are set from them; `embedding` has one entry per grid voxel;
  /// `maxLevel` is the coarsest level the build allowed (sizes the per-level counts).
  DeformationOctree(const VoxelGrid& grid, int maxLevel, std::vector<OctreeElement> elements,
                    std::vector<Index3> nodeCoords, std::vector<HangingNode> hanging,
                    std::vector<VoxelEmbedding> embedding);

  [[nodiscard]] const std::vector<OctreeElement>& elements() const { return elements_; }
  [[nodiscard]] const OctreeElement& element(std::uint32_t e) const { return elements_[e]; }
  [[nodiscard]] std::size_t elementCount() const { return elements_.size(); }
  [[nodiscard]] std::size_t nodeCount() const { return nodeCoords_.size(); }

  /// Node-grid coordinates of node n.
  [[nodiscard]] const Index3& nodeCoord(std::uint32_t n) const { return nodeCoords_[n]; }
  /// Rest positions of the nodes (metres), #nodes.
  [[nodiscard]] const std::vector<Vec3d>& restPositions() const { return restPositions_; }
  /// Current positions of the nodes (metres), #nodes. Move free nodes through the mutable
  /// overload, then call updateHangingNodes().
  [[nodiscard]] const std::vector<Vec3d>& positions() const { return positions_; }
  std::vector<Vec3d>& positions() { return positions_; }

  /// Hanging nodes, ordered by coarseLevel descending then node id (masters before dependants).
  [[nodiscard]] const std::vector<HangingNode>& hangingNodes() const { return hanging_; }
  [[nodiscard]] bool isHanging(std::uint32_t n) const { return hangingFlag_[n] != 0; }
  /// Sets every hanging node's current position to the mean of its masters', so voxel
  /// positions are continuous across fine/coarse faces. Serial; O(#hanging).
  void updateHangingNodes();

  /// Embedding of grid voxel v (element kNoElement for an empty voxel).
  [[nodiscard]] const VoxelEmbedding& embedding(std::size_t v) const { return embedding_[v]; }
  [[nodiscard]] std::uint32_t owner(std::size_t v) const { return embedding_[v].element; }
  /// Trilinear coordinates of occupied voxel v in its owning element, each in (0, 1).
  [[nodiscard]] Vec3d localCoordinates(std::size_t v) const {
    return localCoordinates(embedding_[v]);
  }
  /// The same for the occupied voxel whose embedding is `em`.
  [[nodiscard]] Vec3d localCoordinates(const VoxelEmbedding& em) const {
    VOXCUT_ASSERT(em.element != kNoElement, "voxel is empty");
    const double inv = elements_[em.element].inverseSize();
    return {(em.offset[0] + 0.5) * inv, (em.offset[1] + 0.5) * inv, (em.offset[2] + 0.5) * inv};
  }
  /// The 8 trilinear weights of occupied voxel v, for the element's corners 0..7; sum 1.
  [[nodiscard]] std::array<double, 8> weights(std::size_t v) const;
  /// Current position of occupied voxel v (metres): sum of weights * current corner positions.
  [[nodiscard]] Vec3d voxelPosition(std::size_t v) const { return voxelPosition(embedding_[v]); }
  /// Current position of a point with trilinear coordinates `t` in element e (metres).
  [[nodiscard]] Vec3d pointInElement(std::uint32_t e, const Vec3d& t) const {
    const detail::RowSegment r = detail::rowSegment(positions_, elements_[e].nodes, t.y(), t.z());
    return r.start + t.x() * r.delta;
  }
  /// The inverse: trilinear coordinates `t` of the current point p (metres) in element e, by
  /// Newton's method from `start` (default: the centre). False when they do not settle inside
  /// [0, 1]^3 (with an allowance of 1e-9) within 1e-6 voxel of p: the point is not in the
  /// element.
  [[nodiscard]] bool trilinearCoordinates(std::uint32_t e, const Vec3d& p, Vec3d& t,
                                          const Vec3d& start = Vec3d::Constant(0.5)) const;
  /// out[i] = voxelPosition(voxels[i]) for every i (out is resized), in parallel; every
  /// listed voxel must be occupied. Deterministic for any thread count.
  void updateVoxelPositions(const std::vector<std::uint32_t>& voxels, std::vector<Vec3d>& out,
                            bool threaded = true) const;

  /// Position of the occupied voxel whose embedding is `em` (bitwise voxelPosition).
  /// Inline (as are localCoordinates and pointInElement): the subdivision positions thousands
  /// of scattered voxels one by one.
  [[nodiscard]] Vec3d voxelPosition(const VoxelEmbedding& em) const {
    return pointInElement(em.element, localCoordinates(em));
  }
  /// Axis-aligned bounds of element e's current corners (metres); they hold all its voxels.
  [[nodiscard]] Eigen::AlignedBox3d elementBounds(std::uint32_t e) const;
  /// out[e] = elementBounds(e) for every element (out is resized), in parallel.
  void updateElementBounds(std::vector<Eigen::AlignedBox3d>& out, bool threaded = true) const;

  /// Elements per level, indexed by level; size: the build's effective maxLevel + 1
  /// (startLevel + 1 without merging).
  [[nodiscard]] std::vector<std::size_t> elementCountPerLevel() const;
  /// Nodes per level: entry L counts the nodes whose finest adjacent element has level L
  /// (sums to nodeCount()).
  [[nodiscard]] std::vector<std::size_t> nodeCountPerLevel() const;
  [[nodiscard]] std::size_t hangingNodeCount() const { return hanging_.size(); }
  /// The finest level any element may have is 0; this is the coarsest (sizes per-level counts).
  [[nodiscard]] int maxLevel() const { return maxLevel_; }

  /// Key of the cube (level, coord): level in bits 60..63, coordinates (each < 2^20) in
  /// bits 40..59, 20..39, 0..19.
  [[nodiscard]] static std::uint64_t cubeKey(int level, const Index3& c) {
    return (static_cast<std::uint64_t>(level) << 60) | (static_cast<std::uint64_t>(c.x) << 40) |
           (static_cast<std::uint64_t>(c.y) << 20) | static_cast<std::uint64_t>(c.z);
  }
  /// The first element copy of leaf cube (level, coord), kNoElement when it is not a leaf.
  /// Copies of one cube follow through nextCopy() in ascending id order. O(1) expected.
  [[nodiscard]] std::uint32_t firstCopy(int level, const Index3& c) const;
  /// The next copy of element e's cube after e, kNoElement after the last.
  [[nodiscard]] std::uint32_t nextCopy(std::uint32_t e) const { return nextCopy_[e]; }
  /// The element copies of leaf cube (level, coord) (empty when it is not a leaf).
  [[nodiscard]] std::vector<std::uint32_t> cubeCopies(int level, const Index3& c) const;
  [[nodiscard]] std::size_t occupiedVoxelCount() const { return occupiedVoxels_; }

  /// Grid geometry the octree was built on.
  [[nodiscard]] const Index3& gridDims() const { return dims_; }
  [[nodiscard]] const Vec3d& origin() const { return origin_; }
  [[nodiscard]] double voxelSize() const { return voxelSize_; }
  /// Rest position of node-grid point (i, j, k): origin + h * ((i, j, k) - 0.5).
  [[nodiscard]] Vec3d nodeGridPosition(const Index3& c) const {
    return origin_ + voxelSize_ * (Vec3d(c.x, c.y, c.z) - Vec3d::Constant(0.5));
  }
  /// Bounds of the occupied voxels' rest centres (metres); empty box when none.
  [[nodiscard]] const Eigen::AlignedBox3d& restVoxelBounds() const { return restVoxelBounds_; }

 private:
  friend class TopologyEditor;
  void rebuildCubeIndex();

  Index3 dims_;
  Vec3d origin_ = Vec3d::Zero();
  double voxelSize_ = 1.0;
  int maxLevel_ = 0;
  std::vector<OctreeElement> elements_;
  std::vector<Index3> nodeCoords_;
  std::vector<Vec3d> restPositions_;
  std::vector<Vec3d> positions_;
  std::vector<HangingNode> hanging_;
  std::vector<std::uint8_t> hangingFlag_;
  std::vector<VoxelEmbedding> embedding_;
  std::size_t occupiedVoxels_ = 0;
  Eigen::AlignedBox3d restVoxelBounds_;
  std::unordered_map<std::uint64_t, std::uint32_t> cubeFirst_;  ///< leaf cube key -> first copy
  std::vector<std::uint32_t> nextCopy_;                         ///< per element
};

/// Builds the deformation octree over the occupied voxels of `grid`: elements of level
/// startLevel over every occupied voxel; 8 full siblings (every voxel they cover occupied)
/// merged into their parent, repeatedly up to maxLevel when `merge`; elements less than half
/// full split into their occupied children, repeatedly down to surfaceLevel; then coarse
/// elements refined until the 2:1 rule holds (vertex adjacency). Elements are ordered by their
/// first voxel's index, nodes by their node-grid index. With params.splitParts, elements are then
/// duplicated per connected voxel part and nodes per connected group (duplicateByParts in
/// CutTopology.h; a few cubes may be refined where a hanging node would otherwise be
/// ambiguous); copies take the slots after the existing ones. The result is deterministic
/// for any thread count. Throws InputError for startLevel outside [0, 7] or maxLevel outside
/// [startLevel, 7] or surfaceLevel outside [-1, 7]. Thread-safe (reads `grid` only).
[[nodiscard]] DeformationOctree buildDeformationOctree(const VoxelGrid& grid,
                                                       const DeformationOctreeParams& params = {});

}  // namespace voxcut
