#pragma once
/// @file VoxelOctree.h
/// The pseudo voxel octree (paper §3.1): cubes of 2^L voxels on a side, built bottom-up on the
/// linked voxel grid, used only to mark which voxels and links take part in the cutting tool's
/// collision. Voxels and links inside cubes of level >= 1 are inactive; links that are not
/// completely surrounded by such cubes (the protective shell) and links on cube edges (the
/// protective frame) are active, and so are the voxels they touch.
///
/// A level-L cube with origin o (voxel coordinates, multiples of 2^L) holds voxels o..o+2^L on
/// each axis and covers the 2^L unit cells (cubes of 8 voxels, indexed by their min voxel)
/// starting at o. Level-0 cubes are not stored.

#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Per-material level limits (paper §3.1), indexed by material - 1.
struct OctreeParams {
  std::vector<int> maxInternalLevel;  ///< largest level of a cube of that material alone
  std::vector<int> maxBoundaryLevel;  ///< largest level of a cube mixing it with others
  /// The same limits for every material: internal `internal`, boundary `boundary`.
  static OctreeParams uniform(std::size_t materials, int internal, int boundary);
};

/// One stored cube (level >= 1).
struct OctreeCube {
  Index3 origin;
  std::uint8_t level = 1;
  bool deleted = false;
};

/// activeNext entry of a link that is not active.
inline constexpr std::uint32_t kNoActive = 0xffffffffu;

/// Per-voxel state bits.
enum VoxelState : std::uint8_t {
  kActiveLinkX = 1u << 0,  ///< link (v, 0) is active
  kActiveLinkY = 1u << 1,
  kActiveLinkZ = 1u << 2,
  kActiveVoxel = 1u << 3,
  kListedVoxel = 1u << 5,  ///< listed in VoxelOctree::changed (cleared by rebuildActiveVoxels)
};

/// The octree and the activity marks it implies. Owns its arrays; not thread-safe for writes
/// except through the atomic helpers the subdivision uses.
struct VoxelOctree {
  Index3 dims;
  std::vector<OctreeCube> cubes;            ///< stored cubes; deleted ones until compaction
  std::vector<std::int32_t> cellCube;       ///< per unit cell (its min voxel): covering cube or -1
  std::vector<std::uint8_t> state;          ///< per voxel: VoxelState bits
  std::vector<std::uint32_t> activeVoxels;  ///< sorted indices of active voxels
  /// Per entry i of activeVoxels and axis a: the entry of the voxel across link
  /// (activeVoxels[i], a) when that link is active (its far voxel is then active too), else
  /// kNoActive. Lets a pass over the active voxels keep per-voxel data in active order.
  std::vector<std::array<std::uint32_t, 3>> activeNext;
  std::vector<std::uint32_t> activeIndex;  ///< per voxel: its entry in activeVoxels, or kNoActive
  /// Voxels whose state bits were raised since the last rebuildActiveVoxels, each once (in
  /// any order; see markChanged): activateNewCubeFrames lists those of the new frames and
  /// the opened level-1 cubes. Code that changes `state` otherwise must clear activeIndex,
  /// which makes the next rebuild a full one.
  std::vector<std::uint32_t> changed;

  /// Scratch of rebuildActiveVoxels (kept to reuse their memory).
  std::vector<std::uint32_t> spareVoxels, spareMap;
  std::vector<std::array<std::uint32_t, 3>> spareNext;

  /// Sets cellCube over the unit cells of the level-`level` cube at `origin` to `value` (a cube
  /// id, or -1). Cubes of different calls running at once must not overlap.
  void setCubeCells(const Index3& origin, int level, std::int32_t value);

  /// Lists voxel v in `changed` unless it is already (not thread-safe).
  void markChanged(std::size_t v) {
    if (state[v] & kListedVoxel) return;
    state[v] = static_cast<std::uint8_t>(state[v] | kListedVoxel);
    changed.push_back(static_cast<std::uint32_t>(v));
  }
  std::vector<std::uint32_t> newCubes;  ///< cubes created since the last frame activation
  /// Of those, the ones whose cells in cellCube still hold the id of the cube they were split
  /// from (the subdivision's last round leaves the map to activateNewCubeFrames).
  std::vector<std::uint32_t> unmappedCubes;
  /// Origins of the level-1 cubes split since the last frame activation (paper (5-3)): their
  /// 8 level-0 sub-cubes are not stored, and activateNewCubeFrames activates their frames,
  /// which are all 27 voxels and 54 links of the cube.
  std::vector<Index3> openedCubes;

  [[nodiscard]] bool linkActive(std::size_t v, int a) const { return (state[v] >> a) & 1u; }
  [[nodiscard]] bool voxelActive(std::size_t v) const { return state[v] & kActiveVoxel; }
  /// Cubes per level: element L-1 counts level L (L >= 1). Deleted cubes are not counted.
  [[nodiscard]] std::vector<std::size_t> cubesPerLevel() const;
  /// Active links (all three bits over all voxels).
  [[nodiscard]] std::size_t activeLinkCount() const;
};

/// Calls fn(cell) for each of the up to 4 unit cells (by their min voxel) that border the link
/// from `voxel` along axis a and lie inside a grid of `dims`; returns how many there were.
template <class Fn>
int forEachCellAroundLink(const Index3& dims, const Index3& voxel, int a, Fn&& fn) {
  const int u = (a + 1) % 3, w = (a + 2) % 3;
  int n = 0;
  for (int k = 0; k < 4; ++k) {
    Index3 cell = voxel;
    cell[u] -= k & 1;
    cell[w] -= k >> 1;
    if (cell[u] < 0 || cell[w] < 0 || cell[u] + 1 >= dims[u] || cell[w] + 1 >= dims[w]) continue;
    fn(cell);
    ++n;
  }
  return n;
}

/// Builds the octree (paper §3.1): a level-L cube exists where all (2^L+1)^3 voxels are
/// occupied and all its links connected, and L is within the material limits; only the
/// largest cubes are kept. Then marks active links and voxels (steps (1)-(4)). Deterministic.
[[nodiscard]] VoxelOctree buildVoxelOctree(const VoxelGrid& grid, const OctreeParams& params,
                                           bool threaded = true);

/// All links active and all occupied voxels active: the baseline without an octree.
[[nodiscard]] VoxelOctree allActive(const VoxelGrid& grid, bool threaded = true);

/// Deferred update (a): removes deleted cubes, each deleted slot (ascending) taking the last
/// live cube, and rewrites the cube map where cubes moved.
void compactCubes(VoxelOctree& octree, bool threaded = true);
/// Deferred update (b): activates the voxels and links on the edges of cubes created since the
/// last call (the protective frame of new cubes), and of the level-0 cubes of the level-1 cubes
/// split since then (openedCubes: every voxel and link of such a cube). Brings the cube map
/// up to date with them: the cells of unmappedCubes get their ids, those of openedCubes none.
void activateNewCubeFrames(VoxelOctree& octree, const VoxelGrid& grid, bool threaded = true);
/// Deferred update (c): rebuilds the sorted active voxel index array, its link table
/// (activeNext) and the index map (activeIndex): from the previous tables and the `changed`
/// voxels when those tables exist (work in proportion to the active voxels, not the grid), else
/// from a scan of the grid. Clears `changed`.
void rebuildActiveVoxels(VoxelOctree& octree, bool threaded = true);

/// Activates the links on the 12 edges of a cube and their voxels (atomic: callable from
/// several threads on cubes that share edges).
void activateCubeFrame(VoxelOctree& octree, const VoxelGrid& grid, const OctreeCube& cube);

}  // namespace voxcut
