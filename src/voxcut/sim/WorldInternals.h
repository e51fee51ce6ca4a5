#pragma once
/// @file WorldInternals.h
/// A world's per-body state, for the library's own tests and benchmarks (which check
/// invariants on the deformation octree and the grid). Applications use World.h only: nothing
/// here is a stable interface.

#include "voxcut/sim/SimBody.h"
#include "voxcut/sim/World.h"

namespace voxcut {

/// Read access to a world's bodies.
struct WorldInternals {
  [[nodiscard]] static const SimBody& body(const World& world, BodyId b);
};

}  // namespace voxcut
