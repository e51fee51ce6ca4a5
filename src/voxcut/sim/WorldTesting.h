#pragma once
/// @file WorldTesting.h
/// A hook for the tests of the world's error policy (sim/World.h): it makes a step fail as a
/// diverged solve would, where no real input makes one fail on purpose. Not for applications.

#include "voxcut/sim/World.h"

namespace voxcut {

struct WorldTesting {
  /// The next step fails in the solve of `body` (World::step throws StepError naming it), after
  /// the cutting stage and the bodies before it have run. Throws InputError for a body the
  /// world does not hold.
  static void failNextStep(World& world, BodyId body);
};

}  // namespace voxcut
