#pragma once
/// @file CutStep.h
/// The cutting tool's collision for one frame (paper §3.1-3.2; docs/algorithms.md, "Blade sweep"):
/// voxel position update and intersection test of the blade sweep against the active connected
/// links near it (culled by the spatial hash of element AABBs, then by blocks of voxels and
/// single voxels against the sweep's OBB enlarged by each element's longest voxel step:
/// cutting/SweepCull.h; docs/algorithms.md, "Culling that follows the sweep"), then, with
/// the octree, subdivision of the cubes the new cuts touch; the deferred updates follow.
/// The baseline ("previous method") is the same code with every link active and no octree.

#include <algorithm>
#include <cstdint>
#include <vector>

#include "voxcut/collision/LayeredHash.h"
#include "voxcut/cutting/Blade.h"
#include "voxcut/octree/OctreeSubdivision.h"
#include "voxcut/octree/VoxelOctree.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/voxel/LinkCut.h"

namespace voxcut {

/// How a body is set up for cutting.
struct CutBodyParams {
  bool useOctree = true;  ///< false: the baseline, every link active
  OctreeParams octree;    ///< per-material levels (filled from defaults when empty)
  DeformationOctreeParams deformation;
  double obbMargin = 0.0;  ///< metres added around the sweep's OBB (0: half a voxel)
};

/// A body being cut: voxels, activity marks, deformation octree and collision structures.
/// Copyable: the single-frame test runs each repetition on a fresh copy.
struct CutBody {
  VoxelGrid grid;
  DeformationOctree deformation;
  VoxelOctree activity;  ///< the pseudo voxel octree, or everything active
  bool useOctree = true;
  double obbMargin = 0.0;
  /// The octree's deferred updates after a subdivision are still to run (see
  /// cutStepLeavingUpdates).
  bool updatesPending = false;
  std::vector<Eigen::AlignedBox3d> elementBoxes;
  LayeredHash hash;
};

/// Builds the deformation octree and the activity marks of `grid`.
[[nodiscard]] CutBody makeCutBody(VoxelGrid grid, const CutBodyParams& params,
                                  bool threaded = true);

/// Builds the body's activity marks afresh from its grid as it is now (cut links are not
/// connected, so no cube spans a cut): the voxel octree with `octree`'s levels (the defaults
/// when empty), or, without it, every link active (the baseline). Either gives the same cuts.
void setActivity(CutBody& body, bool useOctree, const OctreeParams& octree, bool threaded = true);

/// Timings (ms) and counts of one frame's cutting tool collision.
struct CutStepResult {
  std::vector<LinkCut> cuts;  ///< every link cut this frame, sorted by link id
  double positionUpdateMs = 0, intersectionMs = 0, subdivisionMs = 0, deferredMs = 0;
  std::size_t markedElements = 0;     ///< elements under the sweeps' enlarged boxes
  std::size_t positionedVoxels = 0;   ///< active voxels positioned by the culling
  std::size_t candidateVoxels = 0;    ///< of which inside an enlarged box (their links tested)
  std::size_t testedLinks = 0;        ///< in the intersection test
  std::size_t boundarySamples = 0;    ///< points of the sweeps' boundary sampled (with the octree)
  double linkReach = 0.0;             ///< the largest reach of the elements under the sweeps (m)
  SubdivisionStats subdivision;
  [[nodiscard]] double totalMs() const { return positionUpdateMs + intersectionMs + subdivisionMs; }
};

/// The work of a frame's cutting tool collisions, summed over its steps (counts of
/// CutStepResult; the reach is the largest).
struct CutWork {
  std::size_t steps = 0;
  std::size_t markedElements = 0, positionedVoxels = 0, candidateVoxels = 0, testedLinks = 0;
  std::size_t boundarySamples = 0;
  std::size_t subdivisionTestedLinks = 0;  ///< links the octree subdivision examined
  double linkReach = 0.0;
  void add(const CutStepResult& r) {
    ++steps;
    markedElements += r.markedElements;
    positionedVoxels += r.positionedVoxels;
    candidateVoxels += r.candidateVoxels;
    testedLinks += r.testedLinks;
    boundarySamples += r.boundarySamples;
    subdivisionTestedLinks += r.subdivision.testedLinks;
    linkReach = std::max(linkReach, r.linkReach);
  }
};

/// Runs one frame of cutting tool collision on `body` for the blade sweep. Cut links are
/// disconnected and get Hermite data in the rest frame (t along the link; normal pulled back
/// as F^T n, normalised). `workspace`: the subdivision's buffers, held by the caller from one
/// frame to the next (the overload without one makes a fresh one: for a one-off cut).
/// Deterministic for any thread count.
CutStepResult cutStep(CutBody& body, const BladeSweep& sweep, SubdivisionWorkspace& workspace,
                      bool threaded = true);
CutStepResult cutStep(CutBody& body, const BladeSweep& sweep, bool threaded = true);

/// As cutStep for one sweep, for a strip of sweeps that together form the blade's swept
/// surface this frame (a blade whose start edge was carried along with the material, see
/// sim/BladeFront.h): elements under any sweep's OBB are marked, and a link crossing several
/// sweeps takes the hit with the smallest t (ties: the first sweep). Empty: nothing is cut,
/// only the positions are updated.
CutStepResult cutStep(CutBody& body, const std::vector<BladeSweep>& sweeps,
                      SubdivisionWorkspace& workspace, bool threaded = true);
CutStepResult cutStep(CutBody& body, const std::vector<BladeSweep>& sweeps, bool threaded = true);

/// As cutStep for a strip of sweeps, but the octree's deferred updates after its subdivision
/// (new cube frames activated, cubes compacted, the active voxel tables: deferredMs of cutStep)
/// are left pending, for the caller to run with runDeferredUpdates beside other work: they
/// touch only body.activity and read only the grid's geometry, and nothing of a frame after the
/// cut reads body.activity. Pending updates left by an earlier call run first (their time in
/// deferredMs). Until they have run, body.activity's cube map and active tables are not current.
CutStepResult cutStepLeavingUpdates(CutBody& body, const std::vector<BladeSweep>& sweeps,
                                    SubdivisionWorkspace& workspace, bool threaded = true);

/// Runs the deferred updates a cutStepLeavingUpdates left pending (nothing when none are);
/// returns their time in ms. Deterministic for any thread count.
double runDeferredUpdates(CutBody& body, bool threaded = true);

/// 64-bit FNV-1a hash of the cuts sorted by link id, with t and normals rounded to 1e-6.
[[nodiscard]] std::uint64_t cutSetHash(std::vector<LinkCut> cuts);

}  // namespace voxcut
