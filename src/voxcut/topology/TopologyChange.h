#pragma once
/// @file TopologyChange.h
/// How a deformation octree changed in one topology update (refinement of elements around new
/// cuts, duplication of elements per connected voxel part): the map from the old elements and
/// nodes to the new ones, so that whoever holds per-element or per-node state (the solver's
/// element matrices, node velocities) updates only what changed instead of rebuilding.

#include <array>
#include <cstdint>
#include <vector>

namespace voxcut {

/// Where a node of the updated octree takes its state from: the weighted mean of up to 8 old
/// nodes (weights sum to 1). One source with weight 1 for a node that was kept or duplicated;
/// 2, 4 or 8 sources for a node that refinement created at an old element's edge midpoint,
/// face centre or centre (its old element's corner nodes with the trilinear weights there).
struct NodeSource {
  std::uint8_t count = 0;                ///< number of sources used, 1..8
  std::array<std::uint32_t, 8> nodes{};  ///< old node ids, the first `count` entries are used
  std::array<double, 8> weights{};       ///< their weights, the first `count` entries are used
};

/// The map from an octree before an update to the octree after it.
struct TopologyChange {
  /// One entry per element after the update: the index the same element had before (same
  /// level, same cube, same voxels; its node ids may have been renumbered), or 0xffffffff
  /// when it is new (a refined child or a copy made for one voxel part) and its matrices must
  /// be computed.
  std::vector<std::uint32_t> elementSource;
  /// One entry per node after the update.
  std::vector<NodeSource> nodeSource;

  /// Whether anything changed (false: the octree is exactly as before and both maps are
  /// the identity).
  bool changed = false;
};

/// Marks a new element in TopologyChange::elementSource.
inline constexpr std::uint32_t kNewElement = 0xffffffffu;

}  // namespace voxcut
