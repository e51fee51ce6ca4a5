#pragma once
/// @file Session.h
/// What the viewer simulates (docs/viewer.md): a world opened from a scene file, a built-in
/// model or a mesh file, with a blade and a probe the mouse can drive (the scene's first of
/// each, or ones added out of the way), every tool's poses recorded from the start, and the
/// run saved as a scene that `voxcut run` replays to the same cuts. Uses the library's public
/// API only. Not thread-safe: one thread drives it (SimRunner, or a test).

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "voxcut/core/Progress.h"
#include "voxcut/sim/Scene.h"
#include "voxcut/sim/World.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut::view {

/// How to open what the viewer is given.
struct OpenOptions {
  /// Voxels along the longest side of a model or mesh opened alone (a scene sets its own).
  int resolution = 64;
  bool useOctree = true;
  ProgressCallback progress;  ///< voxelizing's progress, optional
};

/// A tool command from the input layer: move the tool to `pose` by the end of the next
/// frame (it sweeps and pushes on the way), or put it there now without moving (place).
struct ToolCommand {
  ToolId tool;
  BladePose pose;
  bool place = false;
};

class Session {
 public:
  /// Opens `what`: a scene (a path ending in .json), a built-in model name or primitive
  /// (bunny, liver, starfish, box:..., sphere:...), or a mesh file. A model or mesh alone lies
  /// on a floor plane under gravity. Throws InputError with one line saying what is wrong.
  [[nodiscard]] static Session open(const std::string& what, const OpenOptions& options = {});

  [[nodiscard]] World& world() { return world_; }
  [[nodiscard]] const World& world() const { return world_; }
  [[nodiscard]] const Scene& scene() const { return scene_; }
  [[nodiscard]] const std::string& source() const { return source_; }
  /// The tools the mouse drives.
  [[nodiscard]] ToolId blade() const { return blade_; }
  [[nodiscard]] ToolId probe() const { return probe_; }
  /// Where the driven tools wait, out of everything's way.
  [[nodiscard]] BladePose bladePark() const { return bladePark_; }
  [[nodiscard]] BladePose probePark() const { return probePark_; }
  /// Length of the blade the mouse drives (m).
  [[nodiscard]] double bladeLength() const { return bladeLength_; }
  /// The bodies' bounds at the start.
  [[nodiscard]] const Eigen::AlignedBox3d& startBounds() const { return bounds_; }

  /// Applies the input layer's commands, in order, before the next frame.
  void apply(const std::vector<ToolCommand>& commands);
  FrameReport step();
  /// Back to the start: the world built again from the scene (the voxel grids are kept).
  void reset();
  /// Undoes the last cut (Ctrl-Z): the world restored to a snapshot taken before the frame
  /// the cut began in, at most kUndoEvery frames before it (the session takes one every
  /// kUndoEvery frames while nothing is being cut; docs/viewer.md, "Undo"). One level: a
  /// second call undoes nothing more. Returns false when there is no cut to undo.
  bool undoCut();
  [[nodiscard]] bool canUndoCut() const { return !undo_.empty(); }
  /// Frames between the session's snapshots: a snapshot costs about a frame (copied into
  /// memory kept from the one before), so this keeps them near 3 % of the frames' time.
  static constexpr int kUndoEvery = 30;
  /// Switches the voxel octree on or off now and after resets.
  void setUseOctree(bool on);
  [[nodiscard]] bool useOctree() const { return useOctree_; }

  /// The run so far as a scene: the opened scene (or model) with every tool replaced by its
  /// recorded poses and `frames` set to the frames run. Paths are made absolute, so that the
  /// file can be saved anywhere.
  [[nodiscard]] std::string recordedScene() const;
  /// Writes recordedScene() to `path` (through a temporary file, so that an interrupted save
  /// leaves no half file). Throws InputError when it cannot be written.
  void saveRecordedScene(const std::string& path) const;

 private:
  Session() = default;
  void build();

  std::string source_;
  nlohmann::ordered_json json_;  // the scene as opened (paths made absolute)
  Scene scene_;
  std::vector<VoxelGrid> grids_;
  World world_;
  std::size_t sceneTools_ = 0;
  ToolId blade_, probe_;
  bool addBlade_ = false, addProbe_ = false;
  double probeRadius_ = 0.0, bladeLength_ = 0.0;
  BladePose bladePark_, probePark_;
  Eigen::AlignedBox3d bounds_;
  bool useOctree_ = true;
  /// The latest snapshot taken between frames that cut nothing, and the one that was latest
  /// when the last cut began (what undoCut restores).
  WorldSnapshot recent_, undo_;
  bool cutting_ = false;  ///< the last frame cut links
};

}  // namespace voxcut::view
