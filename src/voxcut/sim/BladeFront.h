#pragma once
/// @file BladeFront.h
/// A blade's cut front carried along with the material between frames (docs/algorithms.md,
/// "Carried blade front").
///
/// Why: each frame tests the blade's sweep against the voxel positions at the start of the
/// frame, and the material then moves. If the next sweep started where the blade is in the
/// world, material that moved across the blade's plane in between would be cut at a different
/// height in material terms than the strip before it, and the two strips would leave a bridge
/// of connected links along their seam: a part that should come off stays attached. So the
/// blade edge at the end of a frame is sampled at points, each embedded in the element copy
/// that holds it (trilinear coordinates, found by inverting the element's map); the next
/// frame's sweep starts at those points as the material has carried them and ends at the
/// blade's new pose. The strip of sweeps between the two polylines continues the cut surface
/// in the material without a seam. Points outside every element stay where they are.
///
/// Thread-safety: plain data and pure functions.

#include <cstdint>
#include <vector>

#include "voxcut/cutting/Blade.h"
#include "voxcut/topology/DeformationOctree.h"

namespace voxcut {

/// The embedded sample points of a blade edge.
struct BladeFront {
  std::vector<Vec3d> world;            ///< where each point was when embedded (metres)
  std::vector<std::uint32_t> element;  ///< element copy holding it, or kNoElement
  std::vector<Vec3d> local;            ///< trilinear coordinates in that element
  std::vector<std::uint64_t> ids;      ///< symbolic ids the points had as sweep corners
  [[nodiscard]] bool empty() const { return world.empty(); }
};

/// `segments` + 1 points evenly spaced from pose.a to pose.b (the ends exact).
[[nodiscard]] std::vector<Vec3d> sampleBlade(const BladePose& pose, int segments);

/// Embeds `points` (world, current configuration) in `octree`: each point goes to an element
/// copy whose current trilinear map reaches it with coordinates in [0, 1]^3 (the copy owning
/// the voxel there when several do; otherwise the lowest index), or stays unembedded.
/// Deterministic. Cost O(#points x #elements) box tests plus a few Newton steps per candidate.
[[nodiscard]] BladeFront embedFront(const std::vector<Vec3d>& points,
                                    const std::vector<std::uint64_t>& ids,
                                    const DeformationOctree& octree);

/// How far material may carry a front point in one frame and still be followed: at most
/// kFrontFollow voxels, or kFrontFollowBlade times the distance the blade's own sample moved in
/// that frame when that is more. Material at a cut front moves with the body and, as a
/// part loosens while it is cut, can move faster than a fraction of a voxel per frame at fine
/// resolutions; a point that moves much faster than the blade itself is in a part that moves
/// away (a piece already cut off, falling), not at a cut front, and following it would sweep
/// through material the blade never reached.
inline constexpr double kFrontFollow = 0.1;
inline constexpr double kFrontFollowBlade = 2.0;

/// The start polyline of the next sweep and its symbolic ids: an embedded point that the
/// material moved by more than 1e-9 voxel and no further than the limit above (with the
/// blade's samples `end` of the frame, one per point, or the kFrontFollow voxels alone when
/// null) is where its element now puts it, with id `newIdBase` + i; any other point is exactly
/// where it was, with the id it had, so that a blade cutting still material gives consecutive
/// sweeps bit-identical shared corners.
void frontStart(const BladeFront& front, const DeformationOctree& octree, std::uint64_t newIdBase,
                std::vector<Vec3d>& points, std::vector<std::uint64_t>& ids,
                const std::vector<Vec3d>* end = nullptr);

/// The strip of sweeps from the polyline `start` to the polyline `end` (same number of
/// points, >= 2, with their symbolic ids, distinct within each sweep): sweep i has corners
/// start[i], start[i+1], end[i+1], end[i].
[[nodiscard]] std::vector<BladeSweep> sweepStrip(const std::vector<Vec3d>& start,
                                                 const std::vector<std::uint64_t>& startIds,
                                                 const std::vector<Vec3d>& end,
                                                 const std::vector<std::uint64_t>& endIds,
                                                 std::uint64_t frame);

}  // namespace voxcut
