#pragma once
/// @file PyWorld.h
/// The world as the Python module holds it (docs/python.md, "How the module wraps the world"):
/// a voxcut::World with what Python needs around it and the C++ API leaves to its embedder:
/// - one lock per world, so that step(), which runs without the GIL, never meets another call
///   on the same world from another thread (that call is refused, not queued);
/// - a second lock that the haptic call only tries, so that it never blocks or throws while
///   tools are added, removed or restored;
/// - a count of the zero-copy surface views alive, while which the calls that would move the
///   memory they show (step, restore, body edits) are refused;
/// - each body's description (a scene body), so that a run can be saved as a scene that
///   `voxcut run` replays, and whether the run since recording started can be replayed.
///
/// No pybind11 here: this is plain C++ over the public API of the library.

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <string>
#include <utility>
#include <vector>

#include "voxcut/sim/Scene.h"
#include "voxcut/sim/World.h"

namespace voxcut::python {

/// A call refused because another thread is stepping the world (or a view is held).
class BusyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A handle that names nothing alive in its world (removed, or from another world's restore).
class StaleHandleError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class PyWorld;

/// A snapshot with the body descriptions of its time.
struct PySnapshot {
  WorldSnapshot snapshot;
  std::vector<std::pair<BodyId, SceneBody>> bodies;
  const PyWorld* owner = nullptr;  ///< the world it was taken of (restore accepts any world)
};

class PyWorld {
 public:
  explicit PyWorld(const WorldSettings& settings);
  /// The world of a scene file, as `voxcut run` builds it (settings from `base` for what a
  /// scene does not hold).
  static std::shared_ptr<PyWorld> fromScene(const std::string& path, const WorldSettings& base);

  /// Holds the world's lock for one call; throws BusyError when another thread has it.
  class Guard {
   public:
    explicit Guard(PyWorld& w);
    Guard(const Guard&) = delete;
    Guard& operator=(const Guard&) = delete;

   private:
    std::unique_lock<std::mutex> lock_;
  };
  /// Holds both locks for an edit of the tools (haptic calls answer "busy" meanwhile).
  class ToolEdit {
   public:
    explicit ToolEdit(PyWorld& w);

   private:
    Guard guard_;
    std::unique_lock<std::shared_mutex> tools_;
  };

  /// Throws BusyError when a zero-copy view is alive: `what` names the refused call.
  void refuseWhileViewed(const char* what) const;
  void viewOpened() { ++views_; }
  void viewClosed() { --views_; }
  [[nodiscard]] int views() const { return views_.load(); }

  // Handles: checked before use, so that a stale one is a StaleHandleError (Python KeyError).
  void check(BodyId id) const;
  void check(ToolId id) const;
  void check(ObstacleId id) const;

  /// Adds the body a scene body describes (model file, built-in model, or in-memory volume),
  /// built as `voxcut run` builds it.
  BodyId addBody(SceneBody spec);
  void removeBody(BodyId id);
  /// The body's material `name` as set (or the defaults).
  [[nodiscard]] SceneMaterial material(BodyId id, const std::string& name) const;
  void setMaterial(BodyId id, const SceneMaterial& material);
  void setFixed(BodyId id, std::vector<FixedBox> fixed);
  ToolId addBlade(const BladePose& pose);
  ToolId addProbe(double radius, const BladePose& pose, double friction);
  void removeTool(ToolId id);
  ObstacleId addObstacle(const Obstacle& obstacle);
  void removeObstacle(ObstacleId id);
  void setToolTrajectory(ToolId id, std::vector<ToolKey> keys);

  /// Runs `frames` frames (>= 1); the caller has released the GIL. Returns the last report.
  FrameReport step(int frames);
  [[nodiscard]] HapticAnswer haptic(ToolId id, const BladePose& pose, bool& busy) const noexcept;

  [[nodiscard]] PySnapshot snapshot();
  void restore(const PySnapshot& snapshot);

  void setRecording(bool on);
  [[nodiscard]] bool recording() const { return recording_; }
  /// Writes the run recorded so far as a scene file at `path` (and each body made from an
  /// in-memory label volume as a NRRD file beside it); throws InputError when the run cannot
  /// be replayed from a scene (see docs/python.md, "Saving a run").
  void saveScene(const std::string& path, int frames) const;

  [[nodiscard]] const SceneBody& bodySpec(BodyId id) const;
  /// A probe's own Coulomb coefficient as given (negative: the world's default).
  [[nodiscard]] double toolFriction(ToolId id) const;

  World world;

 private:
  void notReplayable(const std::string& why);

  mutable std::mutex mutex_;
  mutable std::shared_mutex tools_;
  std::atomic<int> views_{0};
  std::vector<std::pair<BodyId, SceneBody>> bodies_;
  std::vector<std::pair<ToolId, double>> frictions_;  ///< probes' own friction as given
  bool recording_ = false;
  int recordingStart = 0;
  std::string notReplayable_;  ///< why the run since recording started cannot be replayed
  std::string sceneSource_;    ///< the scene file it was built from, if any

  friend class Guard;
  friend class ToolEdit;
};

}  // namespace voxcut::python
