#pragma once
/// @file Corotation.h
/// The corotated frame of one element of a deformation octree: the rotation of its deformation
/// gradient averaged over its material and its displacement in that frame, what the elastic
/// forces, the energy and the implicit step all start from (docs/algorithms.md, "Corotation
/// from the material"). Pure; safe to call concurrently.

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "voxcut/topology/DeformationOctree.h"

namespace voxcut {

/// An element's rotation and corotated displacement.
struct Corotation {
  /// R = polarRotation(F), F the deformation gradient averaged over the element's material
  /// (materialDeformationGradient, HexElement.h).
  Eigen::Matrix3d rotation;
  /// y_c = R^T (x_c - xbar) - (X_c - Xbar), 24 entries (3 * corner + axis, metres):
  /// corotatedDisplacement (HexElement.h) of the element's current and rest corners.
  Eigen::Matrix<double, 24, 1> displacement;
};

/// The corotation of element e of `octree` (e < elementCount()), from the current and rest
/// positions of its 8 nodes and its mean shape-function gradients `gradientMean`
/// (ElementMatrices::gradientMean).
[[nodiscard]] Corotation corotation(const DeformationOctree& octree, std::uint32_t e,
                                    const std::array<Vec3d, 8>& gradientMean);

}  // namespace voxcut
