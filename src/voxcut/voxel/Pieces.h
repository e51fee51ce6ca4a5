#pragma once
/// @file Pieces.h
/// Pieces of a linked voxel model: connected components of occupied voxels through connected
/// links.

#include <cstdint>
#include <vector>

#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Labels of the pieces.
struct PieceLabels {
  int count = 0;
  std::vector<std::int32_t> label;  ///< per voxel: piece 0..count-1, -1 when empty
  std::vector<std::size_t> voxels;  ///< voxels per piece
};

/// Connected components, numbered in order of their lowest voxel index (deterministic).
[[nodiscard]] PieceLabels findPieces(const VoxelGrid& grid);

}  // namespace voxcut
