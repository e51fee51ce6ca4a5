#pragma once
/// @file SurfaceMesh.h
/// Plain surface data shared by the contouring (surface/), the world API and the writers: a
/// compact triangle surface and what each of a contoured surface's triangles shows.

#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

/// What a surface triangle shows: the material on its side (the voxel whose link made it) and
/// whether it lies on a cut (a link cut between two voxels of material) rather than on the
/// material's original boundary.
struct TriangleTag {
  std::uint8_t material = 0;
  std::uint8_t cut = 0;  ///< 1 on a cut surface
};

/// #V positions, #V unit normals, #V owning voxels, #T triangles (counter-clockwise seen from
/// outside the material). A vertex's owning voxel is the voxel whose component it belongs to
/// (what embeds it in the deforming elements).
struct SurfaceMesh {
  std::vector<Vec3d> positions;
  std::vector<Vec3d> normals;
  std::vector<std::uint64_t> vertexVoxel;
  std::vector<std::array<int, 3>> triangles;
  /// #T tags (material side, cut), where the producer knows them (contouring does); else empty.
  std::vector<TriangleTag> triangleTags;
};


}  // namespace voxcut
