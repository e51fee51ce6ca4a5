#pragma once
/// @file World.h
/// The embeddable simulation (docs/architecture.md, "The world API"): a world holds deformable
/// bodies, tools (blades that cut, probes that push) and static obstacles; step() runs one frame
/// (docs/architecture.md, "One frame") and reports it. The application moves tools between
/// frames (or lets a key-framed trajectory drive them), reads each body's deformed surface
/// without copying it and, per tool, the force and torque the bodies push back with. Bodies'
/// internals are private.
///
/// Units: SI, world frame. Results (cuts, positions, surfaces, forces) do not depend on the
/// thread count. Thread-safety: one call at a time per World (the frame runs its loops in
/// parallel inside), except hapticForce, which any thread may call at any time; readers of
/// surface() hold references that the next step() or edit invalidates.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/sim/Scene.h"
#include "voxcut/surface/ContouredSurface.h"
#include "voxcut/surface/SurfaceMesh.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Settings of a world that do not belong to one body or tool.
struct WorldSettings {
  double timeStep = 0.004;         ///< s, > 0
  Vec3d gravity{0.0, -9.81, 0.0};  ///< m/s^2
  SolverSettings solver;
  ContactSettings contact;
  bool useOctree = true;  ///< false: the baseline, every link active, no voxel octree
  bool threaded = true;
  /// Least number of segments of a blade's edge carried with the material between frames
  /// (BladeFront.h); more where the blade is longer than this many voxels (one per voxel).
  /// 0 sweeps from the blade's previous pose in the world instead (parts moving across the
  /// blade's plane during a cut can then stay attached by bridges along the frames' seams).
  int bladeSegments = 16;
  /// Cuts that would leave a fragment of fewer voxels than this are undone
  /// (cutting/Fragments.h); 0 or 1 keeps every cut.
  std::size_t minFragmentVoxels = 8;
};

/// How a body is discretised and what it is made of; SceneBody without the model's source.
struct BodySettings {
  int elementLevel = 3;   ///< starting level of the deformation octree, 0..6
  /// Finest level refinement reaches where a blade's front rests in an element whose cut
  /// sides stay glued there (docs/algorithms.md, "Cut topology"), <= elementLevel; -1:
  /// elementLevel - 2 (at least 0).
  int finestLevel = -1;
  /// Level a cut's front coarsens back to once the cuts have left it (docs/algorithms.md,
  /// "Coarsening after cuts"), in [finestLevel, elementLevel]; -1: elementLevel (the front
  /// then opens to within one start-level element of its end).
  int frontLevel = -1;
  int surfaceLevel = -1;  ///< see SceneBody::surfaceLevel
  /// Materials by the grid's material names; the grid's others take SceneMaterial's defaults.
  std::vector<SceneMaterial> materials;
  std::vector<FixedBox> fixed;  ///< world frame
};

/// A body's size and cut state.
struct BodyInfo {
  std::size_t elements = 0;  ///< deformation octree elements (copies after cuts)
  std::size_t nodes = 0;
  std::size_t cutLinks = 0;  ///< links cut so far
  std::size_t surfaceVertices = 0;
  std::size_t surfaceTriangles = 0;
  double voxelSize = 0.0;                  ///< m
  std::vector<std::string> materialNames;  ///< of materials 1..N (element 0 is material 1)
};

/// A body's deformed surface, read in place: arrays indexed by slot, where a removed vertex
/// or triangle leaves a dead slot that a later one may reuse. Valid until the next step() or
/// edit of the world.
struct SurfaceView {
  std::span<const Vec3d> positions;  ///< per vertex slot, current (m); dead slots: stale
  std::span<const Vec3d> normals;    ///< per vertex slot, unit, area-weighted; dead: zero
  /// Per triangle slot, vertex slots, counter-clockwise seen from outside; dead: {-1, -1, -1}.
  std::span<const std::array<int, 3>> triangles;
  /// Per triangle slot, the material on its side (an index into BodyInfo::materialNames,
  /// from 1) and whether it lies on a cut; dead slots: stale.
  std::span<const TriangleTag> triangleTags;
  std::uint64_t revision = 0;  ///< of the topology (slots); positions change every frame
};

/// The topology changes of a body's surface between two revisions: the vertex and triangle
/// slots that were added (or reused) and those that died, each ascending and unique. A slot
/// can be in both lists (died, then reused): its current content is in the view.
struct SurfaceChanges {
  std::uint64_t from = 0, to = 0;
  bool full = false;  ///< the changes since `from` are no longer kept: read everything again
  std::vector<std::int32_t> addedVertices, removedVertices;
  std::vector<std::int32_t> addedTriangles, removedTriangles;
};

/// The pseudo voxel octree of a body made visible, at the deformed positions of its voxels:
/// the links that take part in the cutting tool's collision (active and connected; all
/// connected links without the octree), and the octree's cubes by their corners.
struct ActivityView {
  std::size_t activeLinks = 0;  ///< all of the body's active links that are still connected
  /// Segments between the voxels of active links: all of them, or every k-th in voxel order
  /// when there are more than asked for.
  std::vector<std::array<Vec3d, 2>> links;
  /// Per cube its 8 corner voxels' positions, corner c at offset ((c & 1), (c >> 1 & 1),
  /// (c >> 2)) times the cube's side; with its level (side 2^level voxels).
  std::vector<std::array<Vec3d, 8>> cubes;
  std::vector<std::uint8_t> cubeLevels;
};

/// The force and torque the bodies exert on a tool at the end of the last frame (N, N m; the
/// torque about the midpoint of the tool's segment). A blade's are zero.
struct ToolReaction {
  Vec3d force = Vec3d::Zero();
  Vec3d torque = Vec3d::Zero();
};

/// The stages of a frame, in order; FrameReport::stageMs follows this order.
[[nodiscard]] const std::vector<std::string>& frameStageNames();

/// What one frame did (summed over bodies).
struct FrameReport {
  int frame = 0;                 ///< index of the frame just run (0 first)
  double time = 0.0;             ///< simulated time at its end (s)
  std::vector<double> stageMs;   ///< per frameStageNames() entry, wall-clock ms
  double totalMs = 0.0;          ///< wall-clock ms of the whole frame
  std::size_t cutLinks = 0;      ///< links cut in this frame
  /// The cutting tool collision's work this frame: voxels it positioned to cull the links
  /// near the blades, and links it tested against them (intersection test and octree
  /// subdivision).
  std::size_t positionedVoxels = 0;
  std::size_t testedLinks = 0;
  int solverIterations = 0;      ///< summed over bodies
  int solverFactorisations = 0;  ///< bodies whose step computed a new Cholesky factor
  bool converged = true;         ///< every body's solve converged
  std::size_t contacts = 0;      ///< point contacts of surface vertices with obstacles and probes
  /// The deepest any surface vertex lies inside an obstacle or probe at the frame's end (m).
  double maxPenetration = 0.0;
  /// Per obstacle, the force the bodies press on it with at the frame's end (N).
  std::vector<Vec3d> obstacleForces;
  /// Per tool, the bodies' reaction on it at the frame's end (World::toolReaction).
  std::vector<ToolReaction> toolReactions;
};

// ---- energy ----
/// A body's mechanical energy (J): what a soak or a test watches for energy the contacts
/// create. The contact springs' own energy is not counted.
struct BodyEnergy {
  double kinetic = 0.0;  ///< 1/2 sum_n m_n |v_n|^2, lumped node masses
  /// -sum_n m_n g . x_n: zero at the world's origin, growing against gravity
  double gravitational = 0.0;
  double elastic = 0.0;  ///< corotated strain energy, sum_e 1/2 y_e^T K_e y_e
  [[nodiscard]] double total() const { return kinetic + gravitational + elastic; }
};
// ---- end energy ----

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
  /// Adds a body made of `grid`'s occupied voxels, in the world frame; returns its index.
  /// Builds its deformation octree, voxel octree (or every link active), element matrices,
  /// fixed nodes and surface. Throws InputError when a material is invalid.
  std::size_t addBody(VoxelGrid grid, const BodySettings& settings = {});
  [[nodiscard]] std::size_t bodyCount() const;
  /// Replaces the body's fixed boxes; nodes leaving them move from where they are, at rest.
  void setFixed(std::size_t body, std::vector<FixedBox> fixed);
  /// Sets one of the body's materials (by name; an unknown name is an InputError) and
  /// recomputes its element matrices; the voxel octree's levels do not change after the start.
  void setMaterial(std::size_t body, const SceneMaterial& material);
  [[nodiscard]] BodyInfo bodyInfo(std::size_t body) const;
  /// The body's active links (at most `maxLinks` of them drawn) and octree cubes, where they
  /// are now; with `within`, only the links with both ends in that box and the cubes that
  /// overlap it (counted and drawn). O(voxels).
  [[nodiscard]] ActivityView activity(std::size_t body,
                                      std::size_t maxLinks = static_cast<std::size_t>(-1),
                                      const Eigen::AlignedBox3d* within = nullptr) const;
  /// Switches every body's voxel octree on (built afresh from the body as it is now, cuts
  /// included) or off (every link active: the baseline). Cuts are the same either way; only
  /// the cutting tool collision's cost changes. O(voxels).
  void setUseOctree(bool on);
  /// Connected voxel pieces of the body (through connected links). O(voxels).
  [[nodiscard]] int pieces(std::size_t body) const;
  /// The body's deformed surface in place, with normals of the current positions (computed
  /// here once per frame). O(surface) the first time after a step, O(1) after.
  [[nodiscard]] SurfaceView surface(std::size_t body);
  /// The slots that changed between revision `since` and now (SurfaceView::revision).
  [[nodiscard]] SurfaceChanges surfaceChanges(std::size_t body, std::uint64_t since) const;
  /// A compact copy of the body's deformed surface, with normals. O(surface).
  [[nodiscard]] SurfaceMesh surfaceMesh(std::size_t body) const;
  /// The largest distance of any material point (occupied voxel centre) from its rest
  /// position, over all bodies (m; docs/algorithms.md, "What max_displacement measures").
  [[nodiscard]] double maxDisplacement() const;
  /// Order-independent hash of every body's cut links with their Hermite data (equal for equal
  /// cuts, whatever the thread count or octree setting).
  [[nodiscard]] std::uint64_t cutSetHash() const;
  // ---- energy ----
  /// The body's kinetic, gravitational and elastic energy at the end of the last frame (all
  /// zero kinetic before the first). Deterministic for any thread count. O(elements + nodes).
  /// Thread-safety: like every reader, not concurrently with step() or edits.
  [[nodiscard]] BodyEnergy energy(std::size_t body) const;
  // ---- end energy ----

  // ---- tools ----
  /// Adds a blade with its edge from pose.a to pose.b; returns the tool's index.
  std::size_t addBlade(const BladePose& pose);
  /// Adds a probe of `radius` (m, > 0) around the segment pose.a-pose.b (a sphere when a == b),
  /// with the Coulomb coefficient `friction` for its contacts (negative: the world's default).
  std::size_t addProbe(double radius, const BladePose& pose, double friction = -1.0);
  [[nodiscard]] std::size_t toolCount() const;
  [[nodiscard]] ToolKind toolKind(std::size_t tool) const;
  [[nodiscard]] double toolRadius(std::size_t tool) const;  ///< 0 for a blade
  /// Where the tool is now (at the end of the last frame, or as set since).
  [[nodiscard]] BladePose toolPose(std::size_t tool) const;
  /// The pose the tool reaches at the end of the next frame, moving linearly from its current
  /// pose over the frame; stops a trajectory. Asserts finite coordinates.
  void setToolPose(std::size_t tool, const BladePose& pose);
  /// Puts the tool at `pose` now, without moving it there: a blade cuts nothing and a probe
  /// pushes nothing on the way (a hand that lifts the tool off and sets it down elsewhere).
  /// A blade's cut fronts and a probe's force model start afresh, as for a new tool. Stops a
  /// trajectory; recorded as a jump key (ToolKey::jump). Asserts finite coordinates.
  void placeTool(std::size_t tool, const BladePose& pose);
  /// Drives the tool by key frames (times on the world's clock, in order as keysInOrder
  /// checks, at least one): each frame it moves to the trajectory's pose at the frame's end
  /// (bladePoseBefore), after a jump key in the frame's span has placed it (placeTool). Its
  /// current pose jumps to the trajectory's pose now.
  void setToolTrajectory(std::size_t tool, std::vector<ToolKey> keys);
  /// The bodies' reaction on the tool at the end of the last frame.
  [[nodiscard]] ToolReaction toolReaction(std::size_t tool) const;
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
  /// O(1).
  [[nodiscard]] ToolReaction hapticForce(std::size_t tool, const BladePose& pose) const;
  /// Starts (clearing what was kept) or stops recording every tool's pose once per frame.
  void setRecording(bool on);
  /// The recorded poses of the tool: one key at the time recording started, then one per frame
  /// at its end; times strictly increasing. A scene tool with these keys replays the motion.
  [[nodiscard]] const std::vector<ToolKey>& recording(std::size_t tool) const;

  // ---- obstacles ----
  /// Adds a static obstacle (a plane, a box, or a mesh from meshObstacle; collision/Obstacle.h)
  /// and returns its index in FrameReport::obstacleForces. A mesh obstacle's hierarchies are
  /// shared with the caller's copy, not rebuilt.
  std::size_t addObstacle(const Obstacle& obstacle);
  [[nodiscard]] std::size_t obstacleCount() const;

  // ---- time ----
  /// Runs one frame from time() to time() + timeStep. Throws InputError naming the frame when
  /// a node position becomes non-finite.
  FrameReport step();
  [[nodiscard]] int frame() const;
  [[nodiscard]] double time() const;  ///< frame() * timeStep (s)
  [[nodiscard]] const WorldSettings& settings() const;

 private:
  struct Impl;
  friend struct WorldInternals;
  std::unique_ptr<Impl> impl_;
};

}  // namespace voxcut
