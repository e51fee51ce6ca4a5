#pragma once
/// @file SingleFrameCut.h
/// The paper's single-frame cutting test (§4.1): the blade starts on one side of the model and
/// reaches the other side in one frame; the cutting tool collision steps are timed. Used by
/// `voxcut cut`, `voxcut bench single-frame` and the tests.

#include <optional>
#include <utility>
#include <vector>

#include "voxcut/cutting/CutStep.h"
#include "voxcut/surface/SurfaceMesh.h"
#include "voxcut/topology/PrescribedDeformation.h"

namespace voxcut {

/// The blade's start and end poses.
struct BladeMotion {
  BladePose from, to;
};

/// A blade spanning the model's (current) bounding box along its longest axis, moving across
/// its thinnest axis from one side to the other, through the middle of the remaining axis.
[[nodiscard]] BladeMotion defaultBladeMotion(const CutBody& body);

/// Settings of one single-frame test.
struct SingleFrameParams {
  int repeat = 1;       ///< runs on fresh copies of the body; timings are the medians
  bool contour = true;  ///< count pieces and contour the cut surface afterwards
  bool threaded = true;
};

/// What one single-frame test measured.
struct SingleFrameResult {
  CutStepResult step;  ///< the last run's cuts and counts, median timings
  std::uint64_t cutHash = 0;
  std::size_t activeVoxelsBefore = 0, activeVoxelsAfter = 0;
  int pieces = 0;
  SurfaceTopology topology;
  SurfaceMesh surface;  ///< rest frame, when contoured
  CutBody body;         ///< the body after the (last) cut
};

/// Runs the test on copies of `prepared` (already deformed). Deterministic cuts for any
/// thread count; the timings are wall-clock medians.
[[nodiscard]] SingleFrameResult runSingleFrameCut(const CutBody& prepared, const BladeMotion& blade,
                                                  const SingleFrameParams& params);

/// As runSingleFrameCut for several bodies (the same model with and without the octree), their
/// runs interleaved (one run of each, then the next round), so that a slow spell of the
/// machine weighs on all of them alike and their ratios hold; one result per body, in order.
[[nodiscard]] std::vector<SingleFrameResult> runSingleFrameCuts(
    const std::vector<const CutBody*>& prepared, const BladeMotion& blade,
    const SingleFrameParams& params);

}  // namespace voxcut
