#pragma once
/// @file SimRunner.h
/// The simulation on its own thread (docs/viewer.md, "Threads"): it runs a Session's frames
/// (paced to real time, or as fast as they come), applies the input layer's tool commands
/// between frames, and after each frame builds the frame's DrawData and publishes it. The
/// window's thread takes the newest published frame whenever it draws: a finished frame is
/// handed over whole (two buffers: the one drawn and the one being built), so drawing never
/// waits for a frame and a frame never waits for drawing.

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "DrawData.h"
#include "Session.h"

namespace voxcut::view {

class SimRunner {
 public:
  /// Starts the thread, paused, and publishes the first frame. The session must outlive it.
  explicit SimRunner(Session& session, const DrawOptions& options = {});
  ~SimRunner();
  SimRunner(const SimRunner&) = delete;
  SimRunner& operator=(const SimRunner&) = delete;

  void setPlaying(bool on);
  [[nodiscard]] bool playing() const { return playing_.load(); }
  /// Runs one frame (when paused).
  void stepOnce();
  /// Real-time pacing (default) or as fast as frames come.
  void setRealTime(bool on) { realTime_ = on; }
  void reset();
  /// Undoes the last cut between frames (Session::undoCut).
  void undoCut();
  void setUseOctree(bool on);
  void setDrawOptions(const DrawOptions& options);
  void send(std::vector<ToolCommand> commands);
  /// Runs `fn` on the simulation's thread between frames and waits for it (saving).
  void runBetweenFrames(const std::function<void(Session&)>& fn);

  /// The newest published frame (never null).
  [[nodiscard]] std::shared_ptr<const DrawData> latest() const;
  /// The last error a frame threw (empty when none); the run pauses on one.
  [[nodiscard]] std::string error() const;

 private:
  void loop();
  void publish(const FrameReport* report);
  void record(const FrameReport& report);
  void fail(const char* what);

  Session& session_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::shared_ptr<const DrawData> latest_;
  /// Whether latest_ has been taken since it was published: frames that run faster than the
  /// window draws are not made drawable (only their figures are kept).
  mutable bool taken_ = true;
  std::vector<ToolCommand> commands_;
  std::deque<std::function<void(Session&)>> tasks_;
  DrawOptions options_;
  bool optionsChanged_ = false;
  int steps_ = 0;
  bool reset_ = false, undo_ = false, stop_ = false;
  int octree_ = -1;  // -1: no change asked; else the setting asked for
  std::string error_;
  std::atomic<bool> playing_{false};
  std::atomic<bool> realTime_{true};
  // Kept by the thread: FPS history and the figures that are costly to recount.
  std::vector<float> fpsTime_, fps_;
  int pieces_ = 0;
  std::optional<FrameReport> last_;  ///< the report of the frame run last (none after reset)
  std::size_t cutLinks_ = static_cast<std::size_t>(-1);
  std::thread thread_;
};

}  // namespace voxcut::view
