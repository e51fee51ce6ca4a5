#pragma once
/// @file World.h
/// The embeddable simulation (docs/architecture.md, "The world API"): a world holds deformable
/// bodies, tools (blades that cut, probes that push) and static obstacles, each named by a
/// typed handle (BodyId, ToolId, ObstacleId); step() runs one frame (docs/architecture.md, "One
/// frame") and reports it. The application moves tools between frames (or lets a key-framed
/// trajectory drive them), reads each body's deformed surface without copying it, its nodes,
/// the frame's contacts and, per tool, the force and torque the bodies push back with. Bodies'
/// internals are private: this header includes only the value types of sim/WorldTypes.h.
///
/// Errors (one policy for every call; docs/architecture.md, "Errors"):
/// - An invalid argument (an unknown or stale handle, a non-finite or out-of-range pose,
///   radius, material value or box, a trajectory out of order) throws voxcut::InputError
///   naming the argument, and the world is left as it was. No call aborts the process.
/// - A step that cannot finish (a solve that diverges, a non-finite state, memory running out)
///   throws voxcut::StepError naming the body, the frame and the reason, and leaves the world
///   exactly as it was before the step (cuts, octrees' deferred updates, tools, solver state);
///   it can be stepped again or restored.
/// - hapticForce never throws: a non-finite pose or a handle that names no probe gets a zero
///   force and a status saying why.
///
/// Units: SI, world frame. Results (cuts, positions, surfaces, forces) do not depend on the
/// thread count. Thread-safety: one call at a time per World (the frame runs its loops in
/// parallel inside), except hapticForce, which any thread may call at any time; readers of
/// surface() hold references that the next step() or edit invalidates.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "voxcut/sim/WorldTypes.h"

namespace voxcut {

class VoxelGrid;     // voxel/VoxelGrid.h
struct Obstacle;     // collision/Obstacle.h
struct Scene;        // sim/Scene.h
struct WorldState;   // sim/WorldImpl.h
struct WorldTesting; // sim/WorldTesting.h

/// A world's complete state between two frames (World::snapshot): every body's nodes,
/// velocities, cuts, octrees, surfaces and solver state, the tools' poses, trajectories and
/// force models, the obstacles, the contacts, the handles and the clock. World::restore brings
/// it back. Immutable: copies share it (cheap), and it stays valid after its world changes or
/// is gone. Empty when default-made.
class WorldSnapshot {
 public:
  WorldSnapshot();
  ~WorldSnapshot();
  WorldSnapshot(const WorldSnapshot&);
  WorldSnapshot& operator=(const WorldSnapshot&);
  WorldSnapshot(WorldSnapshot&&) noexcept;
  WorldSnapshot& operator=(WorldSnapshot&&) noexcept;

  [[nodiscard]] bool empty() const;
  /// The world's frame() and time() when it was taken (0 for an empty one).
  [[nodiscard]] int frame() const;
  [[nodiscard]] double time() const;

 private:
  friend class World;
  std::shared_ptr<const WorldState> state_;
};

/// A world in motion. Movable, not copyable.
class World {
 public:
  explicit World(const WorldSettings& settings = {});
  ~World();
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  /// The world of a scene: its settings, bodies (grids[i] for scene.bodies[i], in the world
  /// frame), tools driven by their key frames, and obstacles. `useOctree`, `threaded`,
  /// `bladeSegments` and `minFragmentVoxels` come from `base`, the rest from the scene. Throws
  /// InputError (prefixed with scene.source) when the counts differ or a material is invalid.
  [[nodiscard]] static World fromScene(const Scene& scene, std::vector<VoxelGrid> grids,
                                       const WorldSettings& base = {});

  // ---- bodies ----
  /// Adds a body made of `grid`'s occupied voxels, in the world frame; returns its handle.
  /// Builds its deformation octree, voxel octree (or every link active), element matrices,
  /// fixed nodes and surface. Throws InputError when a setting or material is invalid.
  BodyId addBody(VoxelGrid grid, const BodySettings& settings = {});
  /// Removes the body; its handle (and every copy of it) is refused from then on.
  void removeBody(BodyId body);
  [[nodiscard]] std::size_t bodyCount() const;
  /// The live bodies' handles, in the order they were added.
  [[nodiscard]] std::vector<BodyId> bodies() const;
  /// Whether the handle names a live body of this world.
  [[nodiscard]] bool contains(BodyId body) const;
  /// Replaces the body's fixed boxes; nodes leaving them move from where they are, at rest.
  void setFixed(BodyId body, std::vector<FixedBox> fixed);
  /// Sets one of the body's materials (by name; an unknown name is an InputError) and
  /// recomputes its element matrices; the voxel octree's levels do not change after the start.
  void setMaterial(BodyId body, const SceneMaterial& material);
  [[nodiscard]] BodyInfo bodyInfo(BodyId body) const;
  /// The body's active links (at most `maxLinks` of them drawn) and octree cubes, where they
  /// are now; with `within`, only the links with both ends in that box and the cubes that
  /// overlap it (counted and drawn). O(voxels).
  [[nodiscard]] ActivityView activity(BodyId body,
                                      std::size_t maxLinks = static_cast<std::size_t>(-1),
                                      const Eigen::AlignedBox3d* within = nullptr) const;
  /// Switches every body's voxel octree on (built afresh from the body as it is now, cuts
  /// included) or off (every link active: the baseline). Cuts are the same either way; only
  /// the cutting tool collision's cost changes. O(voxels).
  void setUseOctree(bool on);
  /// Connected voxel pieces of the body (through connected links). O(voxels).
  [[nodiscard]] int pieces(BodyId body) const;
  /// The body's deformed surface in place, with normals of the current positions (computed
  /// here once per frame). O(surface) the first time after a step, O(1) after.
  [[nodiscard]] SurfaceView surface(BodyId body);
  /// The slots that changed between revision `since` and now (SurfaceView::revision).
  [[nodiscard]] SurfaceChanges surfaceChanges(BodyId body, std::uint64_t since) const;
  /// A compact copy of the body's deformed surface, with normals and triangle tags. O(surface).
  [[nodiscard]] SurfaceMesh surfaceMesh(BodyId body) const;
  /// The largest distance of any material point (occupied voxel centre) from its rest
  /// position, over all bodies (m; docs/algorithms.md, "What max_displacement measures").
  [[nodiscard]] double maxDisplacement() const;
  /// Order-independent hash of every body's cut links with their Hermite data (equal for equal
  /// cuts, whatever the thread count or octree setting).
  [[nodiscard]] std::uint64_t cutSetHash() const;
  /// The body's nodes at the end of the last frame: positions, velocities, lumped masses.
  /// O(nodes).
  [[nodiscard]] NodeState nodes(BodyId body) const;
  /// Every contact at the end of the last frame, bodies in order, within a body obstacles and
  /// probes first (by vertex), then other bodies and itself (empty before the first frame).
  [[nodiscard]] const std::vector<Contact>& contacts() const;
  // ---- energy ----
  /// The body's kinetic, gravitational and elastic energy at the end of the last frame (all
  /// zero kinetic before the first). Deterministic for any thread count. O(elements + nodes).
  /// Thread-safety: like every reader, not concurrently with step() or edits.
  [[nodiscard]] BodyEnergy energy(BodyId body) const;
  // ---- end energy ----

  // ---- inspection ----
  /// The body's occupied voxels where they are at rest and now, and the piece each belongs to
  /// (numbered as World::pieces counts them). O(voxels).
  [[nodiscard]] BodyVoxels voxels(BodyId body) const;
  /// The deepest any surface vertex of `body` lies inside the material of `other` now (m, >= 0;
  /// `other` == `body`: inside itself, away from each vertex's own neighbourhood; the other
  /// side of a cut counts), measured in other's rest frame; what contact keeps below half a
  /// voxel. Found afresh, whatever the contact settings. O(surface + elements).
  [[nodiscard]] double penetration(BodyId body, BodyId other) const;
  /// Checks the body's invariants and returns "" when they hold, else what is broken, first
  /// failure only: every occupied voxel lies in an element copy that covers it; hanging nodes
  /// lie where their coarse element puts them and the element copies on the two sides of every
  /// connected link agree on the face between them (no gap opens where no link was cut), both
  /// to 1e-9 of the body's size; the deformation mesh (elements joined by shared nodes) falls
  /// apart into as many parts as the voxels (World::pieces); every live surface vertex is
  /// embedded in the element copy owning its voxel, at that copy's trilinear coordinates of its
  /// rest position; the surface is closed. For tests and debugging. O(voxels + elements +
  /// surface log surface).
  [[nodiscard]] std::string selfCheck(BodyId body) const;

  // ---- tools ----
  /// Adds a blade with its edge from pose.a to pose.b; returns its handle.
  ToolId addBlade(const BladePose& pose);
  /// Adds a probe of `radius` (m, > 0) around the segment pose.a-pose.b (a sphere when a == b),
  /// with the Coulomb coefficient `friction` for its contacts (negative: the world's default).
  ToolId addProbe(double radius, const BladePose& pose, double friction = -1.0);
  /// Removes the tool (its cuts stay); its handle is refused from then on. Not concurrently
  /// with hapticForce.
  void removeTool(ToolId tool);
  [[nodiscard]] std::size_t toolCount() const;
  /// The live tools' handles, in the order they were added (FrameReport::toolReactions'
  /// order).
  [[nodiscard]] std::vector<ToolId> tools() const;
  [[nodiscard]] bool contains(ToolId tool) const;
  [[nodiscard]] ToolKind toolKind(ToolId tool) const;
  [[nodiscard]] double toolRadius(ToolId tool) const;  ///< 0 for a blade
  /// Where the tool is now (at the end of the last frame, or as set since).
  [[nodiscard]] BladePose toolPose(ToolId tool) const;
  /// The pose the tool reaches at the end of the next frame, moving linearly from its current
  /// pose over the frame; stops a trajectory. Coordinates within core/CoordinateRange.h's range.
  void setToolPose(ToolId tool, const BladePose& pose);
  /// Puts the tool at `pose` now, without moving it there: a blade cuts nothing and a probe
  /// pushes nothing on the way (a hand that lifts the tool off and sets it down elsewhere).
  /// A blade's cut fronts and a probe's force model start afresh, as for a new tool. Stops a
  /// trajectory; recorded as a jump key (ToolKey::jump). Coordinates as for setToolPose.
  void placeTool(ToolId tool, const BladePose& pose);
  /// Drives the tool by key frames (times on the world's clock, in order as keysInOrder
  /// checks, at least one): each frame it moves to the trajectory's pose at the frame's end
  /// (bladePoseBefore), after a jump key in the frame's span has placed it (placeTool). Its
  /// current pose jumps to the trajectory's pose now.
  void setToolTrajectory(ToolId tool, std::vector<ToolKey> keys);
  /// The bodies' reaction on the tool at the end of the last frame.
  [[nodiscard]] ToolReaction toolReaction(ToolId tool) const;
  /// The force and torque a probe at `pose` would feel now, for a haptic loop that runs faster
  /// than the frames (docs/algorithms.md, "Forces at haptic rate"): the last frame's reaction
  /// extrapolated by the probe's force Jacobian, estimated from the frames' reactions and the
  /// probe's motion (a secant update), within the last frame's motion of the probe (at most
  /// half its radius; held there beyond), never pulling, and fading to nothing as the probe is
  /// pulled out from one to two radii. Each frame's model takes over from the one before it
  /// over one frame period of wall-clock time (the time between the last two frames, held
  /// between the time step and 50 ms; longer, up to 50 ms, where the step would change the
  /// force by more than 8 % of itself per millisecond), so the force does not step when a frame
  /// arrives; it is the last frame's model alone once that time has passed. Thread-safe: it may be
  /// called from any thread at any time, also while step() runs (it reads a snapshot published at
  /// each frame's end, under a lock held only to copy it); not concurrently with adding tools.
  /// O(1). Never throws: a pose with a non-finite or out-of-range coordinate, or a handle that
  /// names no live probe, gets a zero force and a status saying so.
  [[nodiscard]] HapticAnswer hapticForce(ToolId tool, const BladePose& pose) const noexcept;
  /// Starts (clearing what was kept) or stops recording every tool's pose once per frame.
  void setRecording(bool on);
  /// The recorded poses of the tool: one key at the time recording started, then one per frame
  /// at its end; times strictly increasing. A scene tool with these keys replays the motion.
  [[nodiscard]] const std::vector<ToolKey>& recording(ToolId tool) const;

  // ---- obstacles ----
  /// Adds a static obstacle (a plane, a box, or a mesh from meshObstacle; collision/Obstacle.h)
  /// and returns its handle. A mesh obstacle's hierarchies are shared with the caller's copy,
  /// not rebuilt. Throws InputError for a non-finite or degenerate shape.
  ObstacleId addObstacle(const Obstacle& obstacle);
  void removeObstacle(ObstacleId obstacle);
  [[nodiscard]] std::size_t obstacleCount() const;
  /// The live obstacles' handles, in the order they were added (FrameReport::obstacleForces'
  /// order).
  [[nodiscard]] std::vector<ObstacleId> obstacles() const;
  [[nodiscard]] bool contains(ObstacleId obstacle) const;
  [[nodiscard]] const Obstacle& obstacle(ObstacleId obstacle) const;

  // ---- time ----
  /// Runs one frame from time() to time() + timeStep. A frame that cannot finish throws
  /// StepError and leaves the world as it was before the call (the error policy above).
  FrameReport step();
  [[nodiscard]] int frame() const;
  [[nodiscard]] double time() const;  ///< frame() * timeStep (s)
  [[nodiscard]] const WorldSettings& settings() const;

  // ---- snapshots ----
  /// The world as it is now (docs/architecture.md, "Snapshots"). O(state): a copy of every
  /// body; the world keeps sharing it as its rollback point until the next edit.
  [[nodiscard]] WorldSnapshot snapshot();
  /// Brings back the world a snapshot was taken of, completely: stepping on gives, bit for
  /// bit, what the world gave after the snapshot was taken (for the same tool poses). The
  /// handles of its bodies, tools and obstacles are valid again; handles made since are
  /// refused. Readers' surface revisions start afresh (SurfaceChanges::full). O(state),
  /// reusing this world's memory. Throws InputError for an empty snapshot. Not concurrently
  /// with hapticForce.
  void restore(const WorldSnapshot& snapshot);

 private:
  struct Impl;
  friend struct WorldTesting;
  std::unique_ptr<Impl> impl_;
};

}  // namespace voxcut
