#pragma once
/// @file ScanConvert.h
/// Exact crossings of a triangle mesh with the grid lines of a voxel grid: for each axis a,
/// the lines through voxel centres along a. Vertices are snapped to a lattice of 2^-20 voxel
/// so that the point-in-triangle tests run in exact integer arithmetic; a top-left rule
/// (equivalently a symbolic perturbation of the line) makes a line through a shared edge or
/// vertex cross exactly one of the triangles there.

#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/core/TriangleMesh.h"
#include "voxcut/voxel/GridFrame.h"

namespace voxcut {

/// One surface crossing on a grid line.
struct LineCrossing {
  double s;  ///< coordinate along the line in voxel units (voxel k is at s = k)
  int face;  ///< crossed triangle
  int sign;  ///< +1 when the face normal points along +axis, -1 otherwise
};

/// Crossings of all lines along one axis a; lines are numbered iu + nu * iw with
/// u = (a+1)%3, w = (a+2)%3; each line's crossings are sorted by (s, face).
struct AxisCrossings {
  int axis = 0;
  int nu = 0, nw = 0;
  std::vector<std::uint32_t> offsets;  ///< nu*nw + 1 entries
  std::vector<LineCrossing> crossings;

  [[nodiscard]] std::size_t line(const Index3& voxel) const {
    return static_cast<std::size_t>(voxel[(axis + 1) % 3]) +
           static_cast<std::size_t>(nu) * static_cast<std::size_t>(voxel[(axis + 2) % 3]);
  }
  [[nodiscard]] const LineCrossing* begin(std::size_t line) const {
    return crossings.data() + offsets[line];
  }
  [[nodiscard]] const LineCrossing* end(std::size_t line) const {
    return crossings.data() + offsets[line + 1];
  }
};

/// Crossings along x, y and z lines. Deterministic for any thread count.
[[nodiscard]] std::array<AxisCrossings, 3> scanConvert(const TriangleMesh& mesh,
                                                       const GridFrame& frame,
                                                       bool threaded = true);

}  // namespace voxcut
