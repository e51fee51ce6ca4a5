#pragma once
/// @file SurfaceMesh.h
/// A triangle surface produced by dual contouring, with per-vertex normals and, for each
/// vertex, the voxel whose component it belongs to (used to embed it in deforming elements).

#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/core/SurfaceMesh.h"

namespace voxcut {

/// Topology summary of a surface.
struct SurfaceTopology {
  bool closed = false;    ///< every edge used once in each direction
  bool manifold = false;  ///< closed, and every vertex's triangle fan is a single disk
  int pieces = 0;         ///< connected components (through shared vertices)
  int genusSum = 0;       ///< sum of genera of the pieces (0 for spheres)
};

/// Checks closedness, vertex-manifoldness and counts pieces and genus. O(T log T).
[[nodiscard]] SurfaceTopology surfaceTopology(const SurfaceMesh& mesh);

}  // namespace voxcut
