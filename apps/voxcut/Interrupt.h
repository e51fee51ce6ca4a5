#pragma once
// SIGINT and SIGTERM as a request to stop at the next safe point (a frame boundary, a stage
// of the voxelizer), instead of killing the program with files half-written.

namespace voxcut::app {

/// While alive, SIGINT and SIGTERM set a flag instead of ending the program; a second signal
/// ends it as usual (the handler resets itself). The previous handlers come back on
/// destruction. One at a time.
class InterruptGuard {
 public:
  InterruptGuard();
  ~InterruptGuard();
  InterruptGuard(const InterruptGuard&) = delete;
  InterruptGuard& operator=(const InterruptGuard&) = delete;
};

/// Whether a signal asked to stop since the guard was made.
[[nodiscard]] bool interruptRequested();

/// Exit status of an interrupted command.
inline constexpr int kInterruptedStatus = 130;

}  // namespace voxcut::app
