#pragma once
/// @file Model.h
/// A model ready to become a linked voxel grid: material meshes for the voxelizer, or a label
/// volume with the labels chosen as materials for the resampler (docs/algorithms.md,
/// "Voxelization" and "Label volumes").

#include <memory>
#include <string>
#include <vector>

#include "voxcut/core/TriangleMesh.h"
#include "voxcut/voxel/LabelResample.h"
#include "voxcut/voxel/LabelVolume.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {

/// A model: its materials' surfaces in order (metres), or a label volume, and the grid
/// resolution (voxels along the longest side) it is meant to be built at by default.
struct Model {
  std::string name;
  std::vector<MaterialMesh> materials;  ///< meshes; empty for a label volume
  int defaultResolution = 101;
  /// A label volume (null for meshes). Immutable and shared, so that copies of a model (the
  /// scene's bodies, a benchmark's bodies) do not copy its voxels.
  std::shared_ptr<const LabelVolume> volume;
  /// With a volume: the labels made materials, in material order; empty: all of them
  /// (defaultLabelChoices).
  std::vector<LabelChoice> labels;
  int minIsland = 8;  ///< with a volume: LabelResampleParams::minIsland

  [[nodiscard]] bool isVolume() const { return volume != nullptr; }
  /// Material names in material order (1, 2, ...).
  [[nodiscard]] std::vector<std::string> materialNames() const;
};

/// Builds the linked voxel grid of `model`: voxelize for meshes (reporting into `meshReport`),
/// resampleLabels for a volume (reporting into `volumeReport`), with the resolution, voxel
/// limit, threading and progress of `params`. Throws what those throw.
[[nodiscard]] VoxelGrid voxelizeModel(const Model& model, const VoxelizeParams& params,
                                      VoxelizeReport* meshReport = nullptr,
                                      LabelResampleReport* volumeReport = nullptr);

}  // namespace voxcut
