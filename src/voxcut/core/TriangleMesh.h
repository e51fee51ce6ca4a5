#pragma once
/// @file TriangleMesh.h
/// An indexed triangle mesh: #V positions (metres) and #F index triples.

#include <string>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

/// Indexed triangle soup or mesh. Faces index into `vertices`; winding is counter-clockwise
/// seen from outside when the mesh is oriented.
struct TriangleMesh {
  std::vector<Vec3d> vertices;
  std::vector<std::array<int, 3>> faces;

  /// Axis-aligned bounds {min, max}; {+inf, -inf} when empty.
  [[nodiscard]] std::array<Vec3d, 2> bounds() const;
  /// Signed volume by the divergence theorem (exact for a closed oriented mesh).
  [[nodiscard]] double signedVolume() const;
};

/// A named material's surface: the input of the voxelizer (one per material, in order).
struct MaterialMesh {
  std::string name;
  TriangleMesh mesh;
};

}  // namespace voxcut
