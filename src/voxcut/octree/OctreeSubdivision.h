#pragma once
/// @file OctreeSubdivision.h
/// Recursive subdivision of voxel octree cubes with newly cut links on their boundary
/// (paper §3.2, sub-steps (1)-(6) and (5-1)-(5-6)). After the blade has been tested against
/// the active links, every cube of level >= 1 with a newly disconnected link on an edge or a
/// face is split until no cube has one or level 0 is reached; the voxels and links uncovered
/// on the way are positioned and tested against the blade, so the cut is exactly as detailed
/// as without the octree. On each face and mid-plane the blade's trace is followed from the
/// cut links on its border, unit cell by unit cell (a cell's untested links are tested, the
/// cells across its cut links come next): the tests grow with the length of the trace, a
/// few per link it crosses, not with the area. Squares of 2 x 2 cells test their 4 inside
/// links directly, level-1 cubes the pairs of centre links whose two mid-planes have a cut on
/// their border. A face is traced once: by the first of two affected cubes of the same size
/// that share it, by the larger of two that share part of it (docs/algorithms.md, "Trace
/// following"; the links tested on the bunny: docs/performance.md). Beyond the paper: where
/// the sweep's boundary lies inside the model, the cubes it reaches into are split too and their
/// traces seeded along it (SweepBoundary), so the cut stays exact there as well
/// (docs/algorithms.md, "Sweep boundary").

#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include "voxcut/octree/VoxelOctree.h"
#include "voxcut/voxel/LinkCut.h"

namespace voxcut {

/// Voxel positions the link test computed, kept for the next calls of the same task (the
/// trace following meets a voxel from up to four links of a face, and from two mid-planes):
/// a direct-mapped table by voxel index, so a lookup is one probe and a clash overwrites.
/// Valid for one subdivision run (the positions do not change during it). A voxel and its
/// position share a 32-byte slot (one cache line holds both), and the table is small (8 KB):
/// it stays in the first-level cache even when two threads share it (a larger one hit about
/// as often in the single-frame cuts).
class VoxelPositionCache {
 public:
  /// The position stored for voxel v, or nullptr.
  [[nodiscard]] const Vec3d* find(std::size_t v) const {
    const Slot& s = slots_[slot(v)];
    return s.voxel == v ? &s.position : nullptr;
  }
  void put(std::size_t v, const Vec3d& p) {
    Slot& s = slots_[slot(v)];
    s.voxel = v;
    s.position = p;
  }

 private:
  static constexpr int kBits = 8;
  struct alignas(32) Slot {
    std::size_t voxel = ~std::size_t{0};
    Vec3d position = Vec3d::Zero();
  };
  static std::size_t slot(std::size_t v) {
    return static_cast<std::size_t>((static_cast<std::uint64_t>(v) * 0x9E3779B97F4A7C15ULL) >>
                                    (64 - kBits));
  }
  std::vector<Slot> slots_ = std::vector<Slot>(std::size_t{1} << kBits);
};

/// What subdivision needs from the cutting step.
struct SubdivisionHooks {
  /// Blade test of the connected link (v, a): its Hermite data in the rest frame if the blade
  /// crosses it. The hook computes the current positions of v and v + stride(a) itself
  /// (bitwise as for the main test; it may keep them in `cache`, the calling task's own).
  /// May be called from several threads at once.
  std::function<std::optional<Hermite>(std::size_t v, int a, VoxelPositionCache& cache)> testLink;
};

/// The boundary of a frame's sweeps as the subdivision needs it (subdivideCutCubes).
struct SweepBoundary {
  /// Points along the boundary, in rest voxel coordinates (voxel (i, j, k)'s centre is
  /// (i, j, k)), at most half a voxel apart along each boundary curve inside the model.
  std::vector<Vec3d> points;
  /// The cubes over the unit cells within one cell of a point, ascending.
  std::vector<std::uint32_t> cubes;
};

/// Memory that the subdivision's workers keep from one run to the next: their buffers keep
/// their capacity, so a frame does not grow them from nothing. Whoever runs subdivideCutCubes
/// frame after frame holds one and passes it to every run (its contents between runs mean
/// nothing; a fresh workspace gives the same results). A copy is a fresh workspace and
/// assigning one keeps this one's buffers (a body copied for a snapshot copies no scratch). One
/// run at a time may use it.
class SubdivisionWorkspace {
 public:
  SubdivisionWorkspace();
  ~SubdivisionWorkspace();
  SubdivisionWorkspace(SubdivisionWorkspace&&) noexcept;
  SubdivisionWorkspace& operator=(SubdivisionWorkspace&&) noexcept;
  SubdivisionWorkspace(const SubdivisionWorkspace&);
  SubdivisionWorkspace& operator=(const SubdivisionWorkspace&);

  /// One worker's buffers (defined in octree/SubdivisionWorker.h).
  struct WorkerMemory;
  /// Per worker of a run (a thread slot of its parallel loops).
  std::vector<WorkerMemory> workers;
};

/// Counts of one subdivision run.
struct SubdivisionStats {
  int rounds = 0;                 ///< passes through sub-steps (1)-(6)
  std::size_t affectedCubes = 0;  ///< cubes marked in sub-step (1), summed over rounds
  std::size_t boundaryCubes = 0;  ///< of which the sweep's boundary reaches into (first round)
  std::size_t testedLinks = 0;    ///< links the subdivision examined (tested unless already cut)
  std::size_t cutLinks = 0;       ///< of which crossed
  double facesMs = 0;             ///< wall time in sub-steps (2)-(4), the affected cubes' faces
  double splitMs = 0;             ///< in sub-step (5), the splits
  double bookkeepingMs = 0;       ///< the rest: marking, gathering, storing the sub-cubes
};

/// Sub-step (1) for one newly cut link: raises marked[cube] (to 1) for each cube (level >= 1)
/// around the link (one byte per cube of octree.cubes), atomically: callable from several
/// threads at once. prefetchCubesAroundLink asks the processor for the cube map's cells it will
/// read (the map is large and cut links are scattered).
void markCubesAroundLink(const VoxelOctree& octree, const VoxelGrid& grid, std::uint64_t link,
                         std::vector<std::uint8_t>& marked);
void prefetchCubesAroundLink(const VoxelOctree& octree, const VoxelGrid& grid, std::uint64_t link);

/// Runs sub-steps (1)-(6), its workers' buffers taken from and left in `workspace`. `cuts` holds
/// the links cut so far this frame (already disconnected in `grid`; their Hermite data set, unless
/// `givenStored` is false: then this step sets it, beside its first phase, which does not read it;
/// `givenMarked`, if set, holds the cubes around them marked with markCubesAroundLink already, and
/// is taken over); the links this step cuts are disconnected, given Hermite data and appended, each
/// once, in an order that depends on the schedule (sort them for a deterministic order). Cubes are
/// split in place: a split cube keeps its slot for its first remaining sub-cube, new sub-cubes are
/// appended and listed in octree.newCubes, level-1 cubes that split are marked deleted and listed
/// in octree.openedCubes (their 27 voxels and 54 links are activated by activateNewCubeFrames). The
/// deferred updates (activateNewCubeFrames, then compactCubes, rebuildActiveVoxels) are left to the
/// caller, and must run before the next call: the last round leaves the cube map of its sub-cubes
/// (octree.unmappedCubes) and opened cubes to activateNewCubeFrames. Otherwise deterministic for
/// any thread count: the cut set, the grid, the octree (up to the order of openedCubes) and the
/// counts.
///
/// `boundary`: where the blade's edge or the path of its tips ends inside the model, the sweep
/// can cross links of a cube, on its faces and inside it, without crossing any link on its
/// border, and a trace followed from the border would not find them. The cubes the sweep's
/// boundary reaches into are split in the first round even without a cut on their border,
/// and on their faces and mid-planes (and their sub-cubes') the trace also starts at the
/// cells where the boundary's points cross the plane.
SubdivisionStats subdivideCutCubes(VoxelOctree& octree, VoxelGrid& grid, std::vector<LinkCut>& cuts,
                                   const SubdivisionHooks& hooks, SubdivisionWorkspace& workspace,
                                   bool threaded = true, const SweepBoundary& boundary = {},
                                   bool givenStored = true,
                                   std::vector<std::uint8_t>* givenMarked = nullptr);

}  // namespace voxcut
