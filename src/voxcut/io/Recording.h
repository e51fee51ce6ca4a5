#pragma once
/// @file Recording.h
/// Tool recordings as files (format: docs/scenes.md, "Recordings"): every tool of a world with
/// the poses World::setRecording kept, in the JSON a scene tool's "trajectory" plays back.
///
/// Thread-safety: reads the world; no shared state.

#include <string>

#include "voxcut/sim/World.h"

namespace voxcut {

/// The recording of every tool of `world` as JSON text: {"time_step", "tools": [{"type",
/// "radius" (probes), "keys": [{"t", "a", "b"} or {"t", "p"} for a sphere]}]}, numbers
/// written so that they read back exactly. A tool with nothing recorded gets its current pose
/// at the world's time as its one key.
[[nodiscard]] std::string recordingText(const World& world);

}  // namespace voxcut
