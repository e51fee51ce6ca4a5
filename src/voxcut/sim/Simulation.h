#pragma once
/// @file Simulation.h
/// A running scene (docs/architecture.md, "One frame"): deformable bodies cut by key-framed
/// blades and resting on static obstacles. Each frame, per body: cutting tool collision (voxel
/// positions, blade x active links, octree subdivision, deferred updates), cut topology
/// (refinement, duplication per voxel part) and the solver's structures for what changed, the
/// local surface update, object collision (surface vertices against the obstacles, as point
/// contacts of the step), one implicit Euler step, and the surface vertices by trilinear
/// interpolation in their element copies.
///
/// Units: SI, world frame. Results (cuts, node positions, surfaces) do not depend on the thread
/// count. Thread-safety: one call at a time; the steps run their loops in parallel.

#include <optional>
#include <string>
#include <vector>

#include "voxcut/core/Timer.h"
#include "voxcut/cutting/CutStep.h"
#include "voxcut/fem/CutTopology.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEuler.h"
#include "voxcut/sim/BladeFront.h"
#include "voxcut/sim/Scene.h"
#include "voxcut/surface/ContouredSurface.h"

namespace voxcut {

/// Settings of a simulation that the scene does not hold.
struct SimulationParams {
  bool useOctree = true;  ///< false: the baseline, every link active, no voxel octree
  bool threaded = true;
  /// Least number of segments of the blade edge carried with the material between frames
  /// (BladeFront.h); more where the blade is longer than this many voxels (one per voxel).
  /// 0 sweeps from the blade's previous pose in the world instead (parts moving across the
  /// blade's plane during a cut can then stay attached by bridges along the frames' seams).
  int bladeSegments = 16;
  /// Cuts that would leave a fragment of fewer voxels than this are undone
  /// (cutting/Fragments.h); 0 or 1 keeps every cut.
  std::size_t minFragmentVoxels = 8;
};

/// Where a surface vertex lives: its element copy and trilinear coordinates there.
struct VertexEmbedding {
  std::uint32_t element = kNoElement;
  Vec3d local = Vec3d::Zero();
};

/// One deformable body of a running scene.
struct SimBody {
  CutBody cut;               ///< grid, deformation octree, voxel octree, collision structures
  ElasticModel model;        ///< element matrices, constraints
  ImplicitEuler solver;      ///< velocities
  ContouredSurface surface;  ///< rest frame, updated locally after cuts
  std::vector<VertexEmbedding> embedding;  ///< per surface vertex id
  std::vector<Vec3d> vertexPositions;      ///< per surface vertex id, current (metres)
  std::vector<FixedBox> fixedBoxes;
  std::vector<BladeFront> fronts;  ///< per scene tool: its cut front in this body
  int finestLevel = 0;
  double contactStiffness = 0.0;     ///< penalty stiffness per surface vertex (N/m)
  std::size_t cutLinks = 0;          ///< links cut so far
  SubdivisionWorkspace subdivision;  ///< the cutting step's buffers, kept between frames
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
  int solverIterations = 0;      ///< summed over bodies
  int solverFactorisations = 0;  ///< bodies whose step computed a new Cholesky factor
  bool converged = true;         ///< every body's solve converged
  std::size_t contacts = 0;      ///< point contacts of surface vertices with obstacles
  /// The deepest any surface vertex lies inside an obstacle at the frame's end (m).
  double maxPenetration = 0.0;
  /// Per scene obstacle, the force the bodies press on it with at the frame's end (N).
  std::vector<Vec3d> obstacleForces;
};

/// A scene in motion. Movable, not copyable.
class Simulation {
 public:
  /// Sets up every body of `scene` from its voxel grid (grids[i] for scene.bodies[i], in the
  /// world frame): deformation octree (start level element_level, merged one level up),
  /// voxel octree (or every link active), element matrices, fixed nodes, surface. Throws
  /// InputError when the counts differ or a material is invalid.
  Simulation(Scene scene, std::vector<VoxelGrid> grids, const SimulationParams& params = {});
  Simulation(Simulation&&) noexcept = default;
  Simulation& operator=(Simulation&&) noexcept = default;

  /// Runs one frame from time frame() * dt to (frame() + 1) * dt. Throws InputError
  /// naming the frame when a node position becomes non-finite.
  FrameReport step();

  [[nodiscard]] int frame() const { return frame_; }
  [[nodiscard]] const Scene& scene() const { return scene_; }
  [[nodiscard]] const std::vector<SimBody>& bodies() const { return bodies_; }
  /// The current (deformed) surface of body b, compact, with area-weighted normals.
  [[nodiscard]] SurfaceMesh deformedSurface(std::size_t b) const;
  /// The largest distance of any material point (occupied voxel centre) from its rest
  /// position, over all bodies (metres; docs/algorithms.md, "What max_displacement
  /// measures"). O(voxels), parallel, deterministic.
  [[nodiscard]] double maxDisplacement() const;
  /// Connected voxel pieces of body b (through connected links). O(voxels).
  [[nodiscard]] int pieces(std::size_t b) const;

 private:
  /// Per moving tool: its blade's sampled end pose this frame and the samples' ids (empty
  /// where the tool did not move or the blade is one segment).
  struct BladeEnds {
    std::vector<std::vector<Vec3d>> points;
    std::vector<std::vector<std::uint64_t>> ids;
  };
  /// One body's frame, in the phases below.
  void stepBody(SimBody& body, std::vector<double>& stageMs, FrameReport& report);
  /// The cutting tools' collision and the debris rule; this frame's cut link ids, ascending.
  std::vector<std::uint64_t> cutBody(SimBody& body, BladeEnds& ends, std::vector<double>& stageMs);
  [[nodiscard]] std::optional<std::vector<BladeSweep>> toolSweeps(SimBody& body, std::size_t tool,
                                                                  BladeEnds& ends) const;
  bool updateTopology(SimBody& body, const std::vector<std::uint64_t>& cut, const BladeEnds& ends);
  void updateSurface(SimBody& body, const std::vector<std::uint64_t>& cut, bool topologyChanged);
  void recordSolve(const StepStatus& status, FrameReport& report) const;
  /// A point contact handed to the solver: which obstacle, along which normal.
  struct ObstacleHit {
    std::size_t obstacle = 0;
    Vec3d normal = Vec3d::Zero();
  };
  /// Finds the body's surface vertices in or entering an obstacle and hands them to its
  /// solver as point contacts for the next step; one hit per contact, in the same order.
  std::vector<ObstacleHit> findObstacleContacts(SimBody& body) const;
  [[nodiscard]] double deepestPenetration(const SimBody& body) const;
  void embedVertices(SimBody& body, const std::vector<std::int32_t>* only);
  void updateVertexPositions(SimBody& body) const;
  void applyFixed(SimBody& body);
  /// Per node of the body's octree: 1 where its rest position is in a fixed box.
  [[nodiscard]] static std::vector<std::uint8_t> fixedFlags(const SimBody& body);

  Scene scene_;
  SimulationParams params_;
  std::vector<SimBody> bodies_;
  int frame_ = 0;
};

}  // namespace voxcut
