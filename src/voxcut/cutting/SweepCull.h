#pragma once
/// @file SweepCull.h
/// The culling of the cutting tool collision (docs/algorithms.md, "Culling that follows the
/// sweep"): the elements under a frame's sweeps, and in each of them the active voxels near
/// enough to a sweep for one of their links to cross it (the candidates), positioned.
///
/// How near is near enough is bounded per element: a voxel step inside element e moves by at
/// most reach(e) (its longest edge over its size in voxels), and a link is at most as long as
/// the larger bound of the two elements holding its ends. So the end in the element with the
/// larger bound lies within that bound of the crossing, and each candidate's links are tested
/// upwards, and downwards where the low end's element has the smaller bound
/// (cutting/CutStep.cpp). One badly stretched element far from the blade then costs nothing;
/// a bound taken over all elements would enlarge every sweep's box to the size of the body.
///
/// Units: metres. Thread-safety: cullSweeps writes the body's element boxes and hash;
/// collectCandidates only reads and may run for several elements at once.

#include <cstdint>
#include <vector>

#include "voxcut/cutting/Blade.h"
#include "voxcut/cutting/CutStep.h"

namespace voxcut {

/// A sweep's oriented box (its OBB enlarged by the body's OBB margin), as the culling tests it.
struct CullBox {
  Vec3d centre;
  Eigen::Matrix3d axes;  ///< orthonormal columns
  Vec3d halfExtents;
  /// Per world axis i, sum_j |axes(i, j)|: how far the box's bounds move out when every half
  /// extent grows by one.
  Vec3d spread;
  std::uint32_t sweep;         ///< the index of the sweep it encloses
  Eigen::AlignedBox3d bounds;  ///< its axis-aligned bounds (padded for rounding)
};

/// The elements under a frame's sweeps.
struct SweepCull {
  std::vector<CullBox> boxes;  ///< one per sweep with finite corners, in sweep order
  /// Per element of the body: how far from a sweep a voxel it owns may lie and still have a
  /// link that crosses the sweep (its longest voxel step, with a rounding allowance).
  std::vector<double> reach;
  std::vector<std::uint32_t> elements;  ///< the elements under some box, ascending
  /// The boxes element elements[k] lies under (indices into boxes, ascending):
  /// boxIndex[boxStart[k]] .. boxIndex[boxStart[k + 1] - 1].
  std::vector<std::uint32_t> boxStart, boxIndex;
};

/// Updates the body's element boxes and hash to the current node positions and finds the
/// elements whose box, grown by their reach, meets a sweep's box. O(#elements) for the boxes
/// and bounds, then per sweep what the hash lists near it. Deterministic.
[[nodiscard]] SweepCull cullSweeps(CutBody& body, const std::vector<BladeSweep>& sweeps,
                                   bool threaded = true);

/// An active voxel near the sweeps: its index in the grid, its current position, and the
/// sweeps whose boxes, grown by its element's reach, hold it (sweepCount indices from
/// firstSweep in its element's list).
struct Candidate {
  std::size_t voxel;
  std::uint32_t firstSweep;
  std::uint32_t sweepCount;
  Vec3d position;
};

/// The candidates of one element and the sweep indices they list.
struct ElementCandidates {
  std::vector<Candidate> voxels;
  std::vector<std::uint32_t> sweeps;
  std::size_t positioned = 0;  ///< active voxels positioned, kept or not
};

/// The candidates among the active voxels that element cull.elements[k] owns, in ascending
/// voxel order within each block of 4^3 voxels and blocks in a fixed order: its voxels are
/// halved into blocks while a block is larger than 4^3 and the hull of its corner voxels'
/// positions meets a box it lies under (grown by the element's reach), then its voxels are
/// positioned and kept when a grown box holds them. Each position is bitwise
/// DeformationOctree::voxelPosition.
void collectCandidates(const CutBody& body, const SweepCull& cull, std::size_t k,
                       ElementCandidates& out);

}  // namespace voxcut
