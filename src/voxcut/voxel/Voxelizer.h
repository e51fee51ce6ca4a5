#pragma once
/// @file Voxelizer.h
/// Builds the linked voxel model from triangle meshes (docs/algorithms.md, "Voxelization").
///
/// Per material mesh, in order: repairMesh; exact crossings with the grid lines
/// (scanConvert); inside/outside per voxel, from the exact crossing-count winding number when
/// the repaired mesh is watertight and from the generalized winding number (|w| > 1/2)
/// otherwise. Voxel material = the last mesh that holds it. Links between two voxels of the
/// same material are connected; between two materials connected and carrying Hermite data
/// (the interface); between material and empty disconnected with Hermite data. Hermite data
/// come from the crossing of the winning mesh on that link (nearest the link's middle), with
/// the crossed triangle's normal; a link whose labels differ but that has no crossing (a hole)
/// gets the point where the winding number passes 1/2 and the link direction as its normal.

#include <string>
#include <vector>

#include "voxcut/core/Progress.h"
#include "voxcut/core/TriangleMesh.h"
#include "voxcut/voxel/GridFrame.h"
#include "voxcut/voxel/MeshRepair.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Voxelizer settings.
struct VoxelizeParams {
  Resolution resolution;  ///< voxels along the longest side, or voxel size
  std::size_t maxVoxels = VoxelGrid::kDefaultMaxVoxels;  ///< refuse larger grids
  bool threaded = true;                                  ///< run parallel loops on oneTBB
  ProgressCallback progress;                             ///< progress and interruption, optional
};

/// What the voxelizer found, per material mesh.
struct VoxelizeReport {
  std::vector<RepairReport> repairs;
  std::vector<bool> usedWindingNumber;  ///< generalized winding number needed (not watertight)
  std::size_t holeLinks = 0;            ///< links whose crossing came from the winding number
};

/// Voxelizes `materials` (material k+1 = materials[k]). Throws InputError on empty meshes,
/// non-finite coordinates, more than 255 materials or an oversized grid; Interrupted when the
/// progress callback asks to stop. Deterministic for any thread count.
[[nodiscard]] VoxelGrid voxelize(const std::vector<MaterialMesh>& materials,
                                 const VoxelizeParams& params, VoxelizeReport* report = nullptr);

}  // namespace voxcut
