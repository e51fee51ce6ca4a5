#pragma once
/// @file PlaneCut.h
/// Planar cuts: disconnect every connected link that a plane crosses, with Hermite data.
/// What `voxcut info --cut-plane` and `voxcut surface --cut-plane` apply, and what tests of cut
/// surfaces and pieces use; the blade (cutting/) is the general tool.

#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// The plane n.x = d (n need not be unit length; it is normalised).
struct Plane {
  Vec3d normal = Vec3d::UnitX();
  double offset = 0.0;
};

/// Cuts `grid` with `plane`; returns the number of links disconnected. A link is crossed when
/// its end voxels lie strictly on opposite sides, counting a voxel on the plane as being on
/// the positive side. Throws InputError for a zero or non-finite normal or offset.
std::size_t cutWithPlane(VoxelGrid& grid, const Plane& plane, bool threaded = true);

}  // namespace voxcut
