#pragma once
/// @file PrescribedDeformation.h
/// Prescribed deformations of the deformation octree's nodes, so that collision and cutting can
/// be tested on deformed objects without running the dynamics. Each is a smooth,
/// invertible map of space applied to the free nodes' rest positions; hanging nodes are then
/// set from their masters, so voxel positions stay continuous across fine/coarse faces.
///
/// Frame: c is the centre of the occupied voxels' rest bounding box; a is its longest axis
/// (ties go to the lower axis index), b its second longest; s = (x - c)·e_a.
///   - Rigid: rotation by 30° · amount about the oblique axis (1, 2, 3)/√14 through c.
///   - Bend:  the a axis bent in the (a, b) plane into a circular arc of total angle
///            60° · amount (curvature κ = (π/3) · amount / length along a), centre of curvature
///            on the +b side; lengths along the central axis are preserved.
///   - Twist: rotation about the central axis (through c along e_a) by θ(s) = 30° · amount ·
///            s / (half length along a), so ±30° · amount at the ends.
/// All keep the object around its rest bounding box (bend moves the ends by about a quarter of
/// the half length towards +b; rigid and twist move no point farther from c).

#include <string_view>

#include "voxcut/core/Types.h"
#include "voxcut/topology/DeformationOctree.h"

namespace voxcut {

/// A prescribed deformation.
enum class Deformation { None, Rigid, Bend, Twist };

/// Parses "rigid", "bend" or "twist" (also "none"). Throws InputError naming the text for
/// anything else. Thread-safe.
[[nodiscard]] Deformation parseDeformation(std::string_view text);

/// The name parseDeformation accepts for `d` ("none", "rigid", "bend", "twist").
[[nodiscard]] std::string_view deformationName(Deformation d);

/// The map of space (metres to metres) that `d` applies to `octree` (its frame is taken from
/// octree.restVoxelBounds()). Identity for None or amount 0. Thread-safe.
[[nodiscard]] Vec3d deformedPoint(const DeformationOctree& octree, Deformation d, double amount,
                                  const Vec3d& rest);

/// Sets every free node's current position to deformedPoint(its rest position), then every
/// hanging node from its masters. amount scales the angles (1 = the values above); None or
/// amount 0 restores every node's rest position exactly.
/// Not thread-safe with readers of `octree`; runs its loop in parallel, deterministically.
void applyDeformation(DeformationOctree& octree, Deformation d, double amount = 1.0);

}  // namespace voxcut
