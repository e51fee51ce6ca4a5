#pragma once
/// @file BladePose.h
/// Where a tool's segment is at one instant: the value type the cutting stage, the world API
/// and scene files share.

#include "voxcut/core/Types.h"

namespace voxcut {

/// A tool's segment at one instant, from a to b (metres, world frame): a blade's edge, or the
/// axis of a probe (a sphere where a == b).
struct BladePose {
  Vec3d a = Vec3d::Zero();
  Vec3d b = Vec3d::Zero();
};

}  // namespace voxcut
