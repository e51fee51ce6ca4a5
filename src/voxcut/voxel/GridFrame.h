#pragma once
/// @file GridFrame.h
/// Placement of a voxel grid around a model: dimensions, origin (centre of voxel 0) and voxel
/// size, with one layer of empty padding on every side.

#include <array>

#include "voxcut/core/Types.h"

namespace voxcut {

/// Where a voxel grid sits in space.
struct GridFrame {
  Index3 dims;
  Vec3d origin = Vec3d::Zero();  ///< centre of voxel (0,0,0), metres
  double voxelSize = 1.0;        ///< metres
};

/// How the grid resolution is chosen: `voxelSize` > 0 wins; otherwise `resolution` voxels
/// along the longest side of the grid, padding included (the model spans resolution - 2).
struct Resolution {
  int resolution = 101;
  double voxelSize = 0.0;
};

/// Grid frame for models within `bounds` ({min, max}, metres), centred on them: along each
/// axis the number of voxel centres inside the bounds is the nearest achievable to
/// extent / voxel size, and one more voxel on each side is padding, outside the bounds. Throws
/// InputError for a resolution below 3, a non-positive or non-finite voxel size, empty or
/// non-finite bounds, or a grid over `maxVoxels` voxels.
[[nodiscard]] GridFrame gridFrameFor(const std::array<Vec3d, 2>& bounds, const Resolution& res,
                                     std::size_t maxVoxels);

}  // namespace voxcut
