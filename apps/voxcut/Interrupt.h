#pragma once
// SIGINT and SIGTERM as a request to stop at the next safe point (a frame boundary, a stage
// of the voxelizer), instead of killing the program with files half-written.

#include <string>

namespace voxcut::app {

/// While alive, SIGINT and SIGTERM set a flag instead of ending the program. A second signal
/// is the same request (`timeout` signals its command and then the command's process group, so
/// one timeout delivers two SIGTERMs) and only says on stderr that a third ends the program at
/// once; the third removes the temporary files registered with TemporaryFileGuard and ends the
/// program by its signal, as without the guard. The previous handlers come back on
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

/// While alive, the file at `path` (a temporary that its writer renames or removes) is
/// removed if a signal ends the program at once (the third; InterruptGuard), so that not even
/// then is a temporary left behind. The path is copied now, into storage the signal handler
/// reads without allocating; at most 64 are registered at a time, each at most 4095 bytes
/// long (others are not removed). Thread-safe.
class TemporaryFileGuard {
 public:
  explicit TemporaryFileGuard(const std::string& path);
  ~TemporaryFileGuard();
  TemporaryFileGuard(const TemporaryFileGuard&) = delete;
  TemporaryFileGuard& operator=(const TemporaryFileGuard&) = delete;

 private:
  int slot_ = -1;
};

/// Exit status of an interrupted command.
inline constexpr int kInterruptedStatus = 130;

}  // namespace voxcut::app
