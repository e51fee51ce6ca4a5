#pragma once
/// @file LabelResample.h
/// From a segmented label volume to the linked voxel model (docs/algorithms.md, "Label
/// volumes"): the selected labels become materials; the volume, in any orientation and
/// spacing, is resampled onto voxcut's cubic grid, axis-aligned in world space, with Hermite
/// data from a smoothed indicator of each label so that surfaces contour smooth rather than
/// as a staircase of the file's voxel faces.
///
/// The smoothed indicator of material m at a point with continuous voxel index u of the file
/// is the kernel-weighted share of the file's voxels holding m,
///     f_m(u) = sum_{j: label(j) = m} W(u - j) / sum_j W(u - j),
/// with the separable kernel W(x) = prod_a (1 - (x_a / R)^2)^3 for |x_a| < R (R = `kernelRadius`
/// file voxels; outside the volume counts as background). The f_m sum to 1 with background,
/// are twice differentiable, and their boundaries average the staircase of the labels over a
/// few voxels. A grid voxel takes the material with the largest f at its centre; a link whose
/// ends differ gets the point where f_{m0} = f_{m1} along it and the normal of that level set,
/// from the exact gradient of the kernel sums. Where grid voxels are about the file's size,
/// that crossing and normal are then refined by a quadric height field fitted to the file's
/// own boundary links around it, which places boundaries that run nearly parallel to the
/// file's lattice planes (where the average cannot) to a fraction of a voxel.

#include <cstdint>
#include <string>
#include <vector>

#include "voxcut/core/Progress.h"
#include "voxcut/voxel/GridFrame.h"
#include "voxcut/voxel/LabelVolume.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// One label made a material.
struct LabelChoice {
  std::int64_t value = 0;  ///< the label's value in the file
  std::string name;        ///< the material's name
};

/// Settings of resampleLabels.
struct LabelResampleParams {
  /// Voxels along the longest side of the selected labels' bounding box, one voxel of padding
  /// included on each side as for meshes (GridFrame.h), or a voxel size in metres.
  Resolution resolution;
  /// Labels to make materials, material k+1 = labels[k]; empty: every non-zero label of the
  /// volume, in ascending value, named as `defaultLabelChoices` names them.
  std::vector<LabelChoice> labels;
  /// Connected pieces of one material smaller than this many grid voxels are dropped: their
  /// voxels take the material that surrounds them most (background included). 0 keeps all.
  int minIsland = 8;
  /// R above, in file voxels, in [1, 4]. Larger is smoother and erodes more: a structure
  /// thinner than about 2R/3 file voxels fades below its neighbours and is lost.
  double kernelRadius = 3.0;
  std::size_t maxVoxels = VoxelGrid::kDefaultMaxVoxels;  ///< refuse larger grids
  bool threaded = true;
  ProgressCallback progress;  ///< progress and interruption, optional
};

/// What the resampling did.
struct LabelResampleReport {
  std::size_t islandsDropped = 0;  ///< pieces under minIsland
  std::size_t islandVoxels = 0;    ///< voxels they held
  /// Selected labels left with no grid voxel (too small for the grid), by material name.
  std::vector<std::string> vanished;
  std::vector<std::string> warnings;  ///< one line each, for the user
};

/// Every non-zero label of `volume` as a choice: named by the file (LabelInfo::name) or
/// `label_<value>`.
[[nodiscard]] std::vector<LabelChoice> defaultLabelChoices(const LabelVolume& volume);

/// Checks `choices` against `volume`: throws InputError naming `source` and the label for a
/// value the volume does not hold, a value chosen twice, an empty name, a name given twice
/// (naming both values), and more than 255 choices.
void checkLabelChoices(const LabelVolume& volume, const std::vector<LabelChoice>& choices,
                       const std::string& source);

/// The world bounding box ({min, max}, metres) of the file voxels holding a chosen label
/// (each voxel as its full cell). Throws InputError when no voxel holds one.
[[nodiscard]] std::array<Vec3d, 2> labelBounds(const LabelVolume& volume,
                                               const std::vector<LabelChoice>& choices);

/// Resamples `volume` into a linked voxel grid (material names = the choices' names).
/// Throws InputError for bad choices (checkLabelChoices), a kernel radius outside [1, 4], a
/// grid the resolution refuses (gridFrameFor) and Interrupted when the progress callback asks
/// to stop. Deterministic for any thread count. Time: linear in the grid's voxels plus the
/// file voxels of the chosen labels' bounding box, plus a constant per boundary link (larger
/// where the link fit runs).
[[nodiscard]] VoxelGrid resampleLabels(const LabelVolume& volume,
                                       const LabelResampleParams& params,
                                       LabelResampleReport* report = nullptr);

}  // namespace voxcut
