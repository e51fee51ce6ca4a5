#pragma once
/// @file WorldImpl.h
/// The world's insides, shared by the files of sim/ that implement World (docs/architecture.md,
/// "One frame"): the frame's stages, the tool and contact records, the contact shapes of a
/// frame, and World::Impl. Not part of the API: applications include World.h only.

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/CoordinateRange.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/sim/Scene.h"
#include "voxcut/sim/SlotTable.h"
#include "voxcut/sim/World.h"
#include "voxcut/sim/SimBody.h"

namespace voxcut {

enum FrameStage : std::size_t {
  kPositionUpdate,
  kIntersectionTest,
  kOctreeSubdivision,
  kDeferredUpdates,
  kCutTopology,
  kSurfaceUpdate,
  kObjectCollision,
  kDeformation,
  kSurfaceVertices,
  kStageCount
};

/// Adds the wall-clock time from its making to its end to one stage's time (a frame's report's
/// FrameReport::stageMs entry, or a stage's own figure where branches run side by side);
/// next() charges the time so far and times another stage from then on.
class StageTimer {
 public:
  explicit StageTimer(double& ms) : ms_(&ms) {}
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;
  ~StageTimer() { *ms_ += timer_.ms(); }
  void next(double& ms) {
    *ms_ += timer_.ms();
    ms_ = &ms;
    timer_.restart();
  }

 private:
  double* ms_;
  Timer timer_;
};

/// Voxels from the boundary that a body's rest distance field reaches: deeper points of another
/// body (or of itself) are not found as contacts.
inline constexpr int kRestDistanceBand = 3;

/// Coarsening after cuts (docs/algorithms.md, "Coarsening after cuts"): a start-level region
/// coarsens once no cut has touched it for this many frames, no blade's front lies in it and
/// no neighbouring region is busy (the blade has moved on), at most this many regions a frame
/// outside a quiet pass (so no frame stalls on it).
inline constexpr int kCoarsenAfterFrames = 2;

inline constexpr std::size_t kCoarsenRegionsPerFrame = 256;

/// The level a body's resting fronts are refined to: its finest level, by default two below
/// its start level (a quarter of an element's side).
inline int finestLevelOf(const BodySettings& s) {
  return s.finestLevel >= 0 ? std::min(s.finestLevel, s.elementLevel)
                            : std::max(s.elementLevel - 2, 0);
}

/// The start-level region (a cube of level S, DeformationOctree::cubeKey) holding voxel v,
/// clamped into a grid of `dims` voxels.
inline std::uint64_t regionKey(int S, const Index3& v, const Index3& dims) {
  return DeformationOctree::cubeKey(S, {std::clamp(v.x, 0, dims.x - 1) >> S,
                                        std::clamp(v.y, 0, dims.y - 1) >> S,
                                        std::clamp(v.z, 0, dims.z - 1) >> S});
}

/// Below this tangential speed (m/s) a contact's friction holds like a viscous stick; above it,
/// it is the Coulomb force mu f_n against the sliding (docs/algorithms.md, "Friction").
inline constexpr double kStickSpeed = 1e-3;

inline constexpr double kPairClosing = 0.5;

/// Sets a contact's friction damper for the coefficient mu: the normal force estimated from
/// `overlap`, how far the point is pressed in at the step's start (m; the contact's own share of
/// it between bodies, not the part of its gap that only follows the other body's motion), the
/// tangential speed from the point's and the surface's velocities.
inline void setFriction(PointContact& pc, double mu, double overlap, const Vec3d& pointVelocity,
                        const Vec3d& surfaceVelocity) {
  pc.surfaceVelocity = surfaceVelocity;
  const double normalForce = pc.stiffness * std::max(0.0, overlap);
  if (!(mu > 0.0) || !(normalForce > 0.0)) return;
  const Vec3d rel = pointVelocity - surfaceVelocity;
  const double slip = (rel - pc.normal.dot(rel) * pc.normal).norm();
  pc.friction = mu * normalForce / std::max(slip, kStickSpeed);
}

/// fem's preconditioner for a choice.
inline PreconditionerKind preconditionerOf(SolverChoice c) {
  switch (c) {
    case SolverChoice::Automatic: return PreconditionerKind::Automatic;
    case SolverChoice::Cholesky: return PreconditionerKind::Cholesky;
    case SolverChoice::Multigrid: return PreconditionerKind::Multigrid;
    case SolverChoice::Jacobi: return PreconditionerKind::Jacobi;
    case SolverChoice::BlockJacobi: return PreconditionerKind::BlockJacobi;
    case SolverChoice::SymmetricGaussSeidel: return PreconditionerKind::SymmetricGaussSeidel;
    case SolverChoice::IncompleteCholesky: return PreconditionerKind::IncompleteCholesky;
    case SolverChoice::TwoLevel: return PreconditionerKind::TwoLevel;
  }
  return PreconditionerKind::Automatic;
}

/// The choice that names fem's preconditioner `k`.
inline SolverChoice solverChoiceOf(PreconditionerKind k) {
  for (SolverChoice c : kSolverChoices)
    if (preconditionerOf(c) == k) return c;
  return SolverChoice::Automatic;
}

inline bool samePose(const BladePose& p, const BladePose& q) {
  return p.a == q.a && p.b == q.b;
}

/// Material table of a body indexed by grid material (entry 0, empty space, is unused).
inline std::vector<ElasticMaterial> elasticMaterials(const BodySettings& body,
                                                     const VoxelGrid& grid) {
  std::vector<ElasticMaterial> out(1);
  for (const std::string& name : grid.materialNames()) {
    const SceneMaterial m = sceneMaterial(body.materials, name);
    ElasticMaterial e;
    e.youngModulus = m.youngModulus;
    e.poissonRatio = m.poissonRatio;
    e.density = m.density;
    e.dampingMass = m.massDamping;
    e.dampingStiffness = m.stiffnessDamping;
    out.push_back(e);
  }
  return out;
}

inline OctreeParams voxelOctreeParams(const BodySettings& body, const VoxelGrid& grid) {
  OctreeParams p;
  for (const std::string& name : grid.materialNames()) {
    const SceneMaterial m = sceneMaterial(body.materials, name);
    p.maxInternalLevel.push_back(m.maxInternalLevel);
    p.maxBoundaryLevel.push_back(m.maxBoundaryLevel);
  }
  return p;
}

inline bool inside(const FixedBox& box, const Vec3d& p) {
  return (p.array() >= box.lo.array()).all() && (p.array() <= box.hi.array()).all();
}

/// Vertices per task of the per-vertex contact loops.
inline constexpr std::size_t kVertexChunk = 512;

/// Calls fn(chunk, vertex, x) for every surface vertex slot in `vertices` (embedded, ascending),
/// x its current position from the nodes (not vertexPositions: vertices a cut added this frame
/// have none yet), over chunks of kVertexChunk list entries in parallel. Per-chunk outputs
/// joined in chunk order come out in vertex order whatever the thread count.
/// With `at` (one position per entry of `vertices`), x is taken from it instead.
template <class Fn>
void forEachVertexChunked(const SimBody& b, bool threaded,
                          const std::vector<std::uint32_t>& vertices, Fn&& fn,
                          const std::vector<Vec3d>* at = nullptr) {
  const DeformationOctree& d = b.cut.deformation;
  const std::size_t chunks = (vertices.size() + kVertexChunk - 1) / kVertexChunk;
  parallelFor(
      0, chunks, 1,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t ch = c0; ch < c1; ++ch)
          for (std::size_t k = ch * kVertexChunk;
               k < std::min(vertices.size(), (ch + 1) * kVertexChunk); ++k) {
            const VertexEmbedding& em = b.embedding[vertices[k]];
            fn(ch, vertices[k], at != nullptr ? (*at)[k] : d.pointInElement(em.element, em.local));
          }
      },
      threaded);
}

/// Chunks forEachVertexChunked splits `vertices` into.
inline std::size_t vertexChunks(const std::vector<std::uint32_t>& vertices) {
  return (vertices.size() + kVertexChunk - 1) / kVertexChunk;
}

/// The span of wall-clock time between two frames that the haptic call blends over is held at
/// most this (seconds; a paused world still blends over a sensible time), and at least the
/// time step: frames that run back to back to catch up do not shorten the blend.
inline constexpr double kHapticMaxPeriod = 0.05;

/// The fastest the haptic call lets a frame's correction change its force (a fraction of the
/// force per millisecond), where the correction can take longer than a frame period.
inline constexpr double kHapticStepRate = 0.08;

/// A probe's force model between frames (World::hapticForce; docs/algorithms.md, "Forces at
/// haptic rate"): F(c) = reaction.force + jacobian (c - centre), c the probe's segment midpoint.
struct HapticModel {
  Vec3d centre = Vec3d::Zero();  ///< the probe's segment midpoint at the last frame's end (m)
  ToolReaction reaction;         ///< at the last frame's end
  Eigen::Matrix3d jacobian = Eigen::Matrix3d::Zero();  ///< estimate of dF/dc (N/m)
  bool contact = false;                                ///< the last frame pushed on the probe
  double radius = 0.0;                                 ///< the probe's (m)
  /// How far from `centre` the linearisation is used (m; held there beyond): the last frame's
  /// motion of the probe, at most half its radius.
  double reach = 0.0;
};

/// What a haptic thread reads, published at each frame's end: the newest model; the force the
/// call answered just before it came minus the newest model's there (at the pose of the latest
/// call), which the call fades out over a frame period or more; when it came; and how long the
/// fade lasts.
struct HapticSlot {
  mutable std::mutex mutex;
  HapticModel model;
  Vec3d offset = Vec3d::Zero();
  /// The probe midpoint of the latest call (the device's pose), and whether there was one.
  mutable Vec3d asked = Vec3d::Zero();
  mutable bool wasAsked = false;
  std::chrono::steady_clock::time_point published{};
  double fade = 0.0;  ///< seconds the offset takes to fade out: a frame period or more; 0 at first

  /// The weight of the newest model at `now`: from 0 when it came to 1 a fade later.
  [[nodiscard]] double blend(std::chrono::steady_clock::time_point now) const {
    if (!(fade > 0.0)) return 1.0;
    return std::min(1.0, std::chrono::duration<double>(now - published).count() / fade);
  }
};

/// What a tool's frames and the application's poses change; the rest of a WorldTool is fixed
/// when it is made. A rollback (sim/Snapshots.cpp) assigns only this part, while haptic
/// threads may be reading the rest.
struct ToolState {
  BladePose pose;                   ///< now
  std::optional<BladePose> target;  ///< set by setToolPose for the end of the next frame
  std::vector<ToolKey> keys;        ///< trajectory (empty: none)
  double longest = 0.0;             ///< longest its segment has been (m): the fronts' sampling
  ToolReaction reaction;
  std::vector<ToolKey> recorded;
  HapticModel haptic;  ///< this thread's copy of what `slot` holds
};

/// A tool of the world: its shape, where it is, where it goes next frame, and what pushes on it.
struct WorldTool : ToolState {
  ToolKind kind = ToolKind::Blade;
  double radius = 0.0;
  double friction = -1.0;  ///< Coulomb coefficient (negative: the world's default)
  /// Shared with haptic threads (a stable address). Copies of the tool (a snapshot) share it;
  /// World::restore gives each restored tool its own again (sim/Snapshots.cpp).
  std::shared_ptr<HapticSlot> slot;
};

/// A point contact handed to a body's solver: what it presses on and where.
struct ContactHit {
  std::uint32_t vertex = 0;  ///< surface vertex slot
  std::size_t source = 0;    ///< obstacle index, or obstacles + tool index for a probe
  Vec3d normal = Vec3d::Zero();
  Vec3d point = Vec3d::Zero();  ///< on the obstacle's or probe's surface (m)
};

/// A body's contacts with other bodies (point contacts against them at their start velocity)
/// and with itself (pairs within its own step).
struct BodyContactSet {
  std::vector<PointContact> points;
  std::vector<PairContact> pairs;
  std::vector<std::size_t> pointOther;  ///< per point contact, the other body's position
  /// How far each point and pair lies inside at the frame's start (m), for World::contacts.
  std::vector<double> pointDepth, pairDepth;
};

/// Keeps the entries of `v` whose flag in `keep` is set, in order.
template <class T>
void keepFlagged(std::vector<T>& v, const std::vector<std::uint8_t>& keep) {
  std::size_t n = 0;
  for (std::size_t k = 0; k < v.size(); ++k)
    if (keep[k] != 0) v[n++] = std::move(v[k]);
  v.resize(n);
}

/// The point with trilinear weights `w` in element `e` of the body, where its nodes are now.
inline Vec3d pointAt(const SimBody& b, std::uint32_t e, const std::array<double, 8>& w) {
  const OctreeElement& el = b.cut.deformation.element(e);
  Vec3d x = Vec3d::Zero();
  for (std::size_t c = 0; c < 8; ++c) x += w[c] * b.cut.deformation.positions()[el.nodes[c]];
  return x;
}

/// What the bodies are pressed against in a frame: the obstacles, then the probes at their
/// pose at the frame's end.
struct ContactShapes {
  const std::vector<Obstacle>* obstacles = nullptr;
  std::vector<Capsule> probes;
  std::vector<std::size_t> probeTool;  ///< per probe, its tool index
  std::vector<double> friction;        ///< per shape, its Coulomb coefficient
  std::vector<Vec3d> velocity;         ///< per shape, the velocity of its surface (m/s)
  /// Per element of the body being stepped: bit s set where shape s may come near its
  /// vertices during the step (nearShapes); all bits past the 64th shape are always set.
  std::vector<std::uint64_t> near;
  /// The body's surface vertex slots that some shape may reach during the step (nearShapes),
  /// ascending: the only ones the contact loops look at.
  std::vector<std::uint32_t> vertices;
  /// Their positions at the step's start (each solve of the step starts there again).
  std::vector<Vec3d> startPositions;

  [[nodiscard]] bool mayTouch(std::uint32_t element, std::size_t s) const {
    return s >= 64 || ((near[element] >> s) & 1u) != 0;
  }
  [[nodiscard]] bool mayTouchAny(std::uint32_t element) const {
    return size() > 64 || near[element] != 0;
  }

  [[nodiscard]] std::size_t size() const { return obstacles->size() + probes.size(); }
  /// Shape s's signed distance at x; where it is at least `maxDistance`, only some value
  /// >= maxDistance (a mesh obstacle stops its search early; Obstacle.h).
  /// A lower bound of shape s's signed distance over the points of `box` (m): exact for a
  /// plane or a box obstacle, from the box's bounding ball otherwise (where no more than
  /// `enough` matters: a bound at least that far may be any such value).
  [[nodiscard]] double lowerBound(std::size_t s, const Eigen::AlignedBox3d& box,
                                  double enough) const {
    if (s < obstacles->size()) {
      const Obstacle& o = (*obstacles)[s];
      if (o.type == ObstacleType::Plane) {
        double lowest = std::numeric_limits<double>::infinity();
        for (int c = 0; c < 8; ++c)
          lowest = std::min(
              lowest,
              o.normal.dot(box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)) - o.point));
        return lowest;
      }
      if (o.type == ObstacleType::Box)
        return (o.lo - box.max()).cwiseMax(box.min() - o.hi).cwiseMax(0.0).norm();
    }
    const double radius = 0.5 * box.diagonal().norm();
    Vec3d n;
    return distance(s, box.center(), n, enough + radius) - radius;
  }
  double distance(std::size_t s, const Vec3d& x, Vec3d& n,
                  double maxDistance = std::numeric_limits<double>::infinity()) const {
    return s < obstacles->size() ? signedDistance((*obstacles)[s], x, n, maxDistance)
                                 : signedDistance(probes[s - obstacles->size()], x, n);
  }
};

/// Everything a world is at one moment: what a snapshot holds and a restore brings back
/// (docs/architecture.md, "Snapshots"). Copyable; a copy shares nothing that a step changes
/// (mesh obstacles share their immutable hierarchies, tools their haptic slot).
struct WorldState {
  WorldSettings settings;
  std::string source;  ///< prefix of error messages (the scene file), may be empty
  std::vector<SimBody> bodies;
  std::vector<WorldTool> tools;
  std::vector<Obstacle> obstacles;
  /// The handles of bodies, tools and obstacles, in the order of the arrays above.
  SlotTable<BodyTag> bodySlots;
  SlotTable<ToolTag> toolSlots;
  SlotTable<ObstacleTag> obstacleSlots;
  std::vector<Contact> contacts;  ///< at the end of the last frame
  int frame = 0;
  bool recording = false;
};

/// What an application sets on a tool between frames without invalidating the rollback
/// checkpoint (setToolPose on a tool without a trajectory): logged at each frame's start so
/// that the frames since the checkpoint can be run again (sim/Snapshots.cpp).
struct ToolControl {
  BladePose pose;
  std::optional<BladePose> target;
  double longest = 0.0;
};

/// The state a failed step goes back to (docs/architecture.md, "Errors"): a copy of the world
/// taken at some earlier frame's start and, per frame since, the tools' controls at its
/// start. Running those frames again from the copy gives, bit for bit, the world before the
/// failed step (results do not depend on timing or threads), so the copy is taken only every
/// so many frames, as many as keep its cost a small share of the frames' (kCheckpointShare).
struct Checkpoint {
  std::shared_ptr<const WorldState> state;  ///< null: none yet
  /// False when an edit since made it useless (its memory is kept to copy the next one into).
  bool valid = false;
  std::vector<std::vector<ToolControl>> controls;  ///< per frame since, per tool
  /// A copy of the world's own that no snapshot shares, kept while `state` is a snapshot's:
  /// the next copy goes into its memory (fresh memory costs page faults, several times the copy).
  std::shared_ptr<WorldState> spare;
  double copyMs = 0.0;   ///< what taking the last copy cost (wall clock)
  double frameMs = 0.0;  ///< the frames' mean cost since it (wall clock)
};

/// The most of the frames' time that taking rollback copies may cost, on average.
inline constexpr double kCheckpointShare = 0.02;
/// The most frames a failed step may have to run again to go back (the longest a checkpoint
/// is kept).
inline constexpr std::size_t kCheckpointMaxFrames = 200;

struct World::Impl : WorldState {
  Checkpoint checkpoint;
  /// A step of this frame fails in this body's solve, as a diverged one would (the error
  /// policy's tests: sim/WorldTesting.h); -1: none.
  int failFrame = -1;
  BodyId failBody;
  /// The highest surface revision any body of this world has had (World::restore starts the
  /// restored bodies above it, so a reader's revision never names two surfaces).
  std::uint64_t surfaceRevisionHigh = 0;

  /// Per moving blade: its sampled end pose this frame and the samples' ids (empty where the
  /// tool did not move, is a probe, or the blade is one segment).
  struct BladeEnds {
    std::vector<std::vector<Vec3d>> points;
    std::vector<std::vector<std::uint64_t>> ids;
  };
  /// Per tool: its pose at this frame's start and end.
  struct Motion {
    std::vector<BladePose> from, to;
  };
  /// One frame's working state, made at its start and dropped at its end (runFrame): the
  /// report it fills (stage times through StageTimer), where the tools go, what the bodies are
  /// pressed against, and per body the links cut and the blades' sampled ends.
  struct Frame {
    FrameReport report;
    Motion motion;
    ContactShapes shapes;
    std::vector<std::vector<std::uint64_t>> cuts;  ///< per body
    std::vector<BladeEnds> ends;                   ///< per body
    /// The stage's time in the report, for a StageTimer.
    double& ms(FrameStage stage) { return report.stageMs[stage]; }
  };

  /// One frame: the body of World::step (World.cpp).
  FrameReport runFrame();
  /// An edit other than setToolPose: the frames since the checkpoint can no longer be run
  /// again from it.
  void edited() {
    checkpoint.valid = false;
    checkpoint.controls.clear();
  }
  /// A copy of the world's state, into the memory of the spare or of a rollback point that no
  /// snapshot shares when there is one.
  [[nodiscard]] std::shared_ptr<WorldState> copyState();
  /// Makes a snapshot's state the rollback point (keeping the old one's memory as the spare
  /// when no snapshot shares it).
  void useAsCheckpoint(std::shared_ptr<const WorldState> state);
  /// Before a step: takes a new checkpoint when due, logs the tools' controls.
  void beforeStep();
  /// After a step failed: the world as it was before it (the checkpoint, and the frames since
  /// run again).
  void rollBack();
  /// Copies `from` into this world's state; with `keepSlots`, each tool keeps its own haptic
  /// slot (haptic threads may be reading it).
  void assignState(const WorldState& from, bool keepSlots);

  /// Where each tool goes this frame (placing those whose trajectory jumps), and the frame's
  /// contact shapes: the obstacles, then the probes at their end pose.
  [[nodiscard]] Motion frameMotion(ContactShapes& shapes);
  /// After the frame: the tools at their end pose, with their reactions, haptic models and
  /// recordings.
  void finishTools(const Motion& motion, const FrameReport& report);
  /// Runs an argument check (sim/WorldChecks.h); its InputError comes back with prefix().
  template <class Check>
  void check(Check&& run) const {
    try {
      run();
    } catch (const InputError& e) {
      if (source.empty()) throw;
      throw InputError(prefix() + e.what());
    }
  }
  [[nodiscard]] std::string prefix() const { return source.empty() ? "" : source + ": "; }
  [[nodiscard]] double time() const { return frame * settings.timeStep; }
  /// After a body's cuts: cut topology, surface, distance field.
  void afterCut(SimBody& body, const std::vector<std::uint64_t>& cut, const BladeEnds& ends,
                Frame& f);
  /// The contacts between bodies (point contacts of each body's next step) and of bodies with
  /// themselves (pairs within the body's step); those the step's end finds pulling are left
  /// out and the step solved again.
  std::vector<BodyContactSet> findBodyContactsAll(Frame& f);
  /// A body's step with its contacts (the shapes', then `bodyContacts`), and its surface.
  /// Appends the body's contacts at the end of its step to `contacts` (World::contacts).
  void recordContacts(const SimBody& body, const ContactShapes& shapes,
                      const std::vector<ContactHit>& hits, const BodyContactSet& set);
  void solvePhase(SimBody& body, BodyContactSet bodyContacts, Frame& f);
  std::vector<std::uint64_t> cutBody(SimBody& body, BladeEnds& ends, Frame& f);
  [[nodiscard]] std::optional<std::vector<BladeSweep>> toolSweeps(SimBody& body, std::size_t tool,
                                                                  const Motion& motion,
                                                                  BladeEnds& ends) const;
  TopologyChange updateTopology(SimBody& body, const std::vector<std::uint64_t>& cut,
                                const BladeEnds& ends);
  /// At a frame's start: coarsens the body's regions that cuts have left (docs/algorithms.md,
  /// "Coarsening after cuts"), with the model, solver, surface embedding and fronts.
  void coarsenBody(SimBody& body, Frame& f);
  /// Notes the start-level regions holding new elements finer than the start level: as cut
  /// now (`settled`), or, for refinement the node rule made while coarsening, as unsettled.
  void noteRefinedRegions(SimBody& body, const TopologyChange& change, bool settled);
  /// The voxel coordinates of the body's embedded blade front points (rest frame, possibly
  /// just outside the grid).
  [[nodiscard]] std::vector<Index3> frontVoxels(const SimBody& body) const;
  /// The start-level regions holding the body's blade fronts, ascending.
  [[nodiscard]] std::vector<std::uint64_t> frontRegions(const SimBody& body) const;
  /// At a frame's start: refines, down to the body's finest level, the elements where a
  /// blade's front has rested since the last frame and a cut's two sides are still glued.
  void refineRestingFronts(SimBody& body, Frame& f);
  /// Where the body's blade fronts are now, per tool (empty for a tool without one).
  [[nodiscard]] std::vector<std::vector<Vec3d>> frontPoints(const SimBody& body) const;
  /// A topology change made at a frame's start: model, solver, the surface's embedding, the
  /// caches that hold element ids, and the fronts embedded again where they were (`front`).
  void applyFrameStartChange(SimBody& body, const TopologyChange& change,
                             const std::vector<std::vector<Vec3d>>& front);
  /// Applies a topology change to the body's model and solver (fixed boxes re-applied).
  void applyTopologyChange(SimBody& body, const TopologyChange& change);
  void embedSurfaceChange(SimBody& body, SurfaceDelta delta, const TopologyChange& change);
  void renumberVertexElements(SimBody& body, const TopologyChange& change) const;
  void recordSolve(const SimBody& body, StepStatus& status, FrameReport& report) const;
  /// Changes to the contact set of a step found after solving it (docs/algorithms.md,
  /// "Contact", the active set): keys vertex * shapes + shape, ascending.
  struct ActiveSetEdits {
    std::vector<std::uint64_t> forced;   ///< end inside although not predicted to: added
    std::vector<std::uint64_t> dropped;  ///< pulled instead of pushing: left out
  };
  /// Which shapes may come near each element's vertices in this step (ContactShapes::near):
  /// a lower bound of the shape's distance over the element's bounding box (exact for planes
  /// and boxes, from its bounding ball otherwise), against how far its nodes can move in the
  /// step with a voxel to spare; then which of those elements' vertices a shape can reach
  /// within that motion (ContactShapes::vertices). The per-vertex tests visit only those.
  void nearShapes(const SimBody& body, ContactShapes& shapes) const;
  std::vector<ContactHit> findContacts(const SimBody& body, const ContactShapes& shapes,
                                       const ActiveSetEdits& edits,
                                       std::vector<PointContact>& found) const;
  /// After a step with `hits`: the contacts that pulled and the vertices that ended inside a
  /// shape they had no contact with; false when there are none (the set was right). `deepest`:
  /// the deepest any of the vertices ends inside a shape (m; 0 when none).
  bool correctActiveSet(const SimBody& body, const ContactShapes& shapes,
                        const std::vector<ContactHit>& hits, ActiveSetEdits& edits,
                        double& deepest) const;
  [[nodiscard]] double deepestPenetration(const SimBody& body, const ContactShapes& shapes) const;
  void embedVertices(SimBody& body, const std::vector<std::int32_t>* only) const;
  void updateVertexPositions(SimBody& body) const;
  void rebuildModel(SimBody& body) const;
  [[nodiscard]] static std::vector<std::uint8_t> fixedFlags(const SimBody& body);
  /// The dense position of a handle's object; throws InputError naming `argument` for an
  /// unknown or stale handle.
  template <class Tag>
  [[nodiscard]] std::size_t position(const SlotTable<Tag>& slots, Handle<Tag> id,
                                     const char* argument, const char* what) const {
    const std::optional<std::size_t> p = slots.find(id);
    if (!p)
      throw InputError(prefix() + argument + ": " + (id.valid() ? "stale" : "invalid") + " " +
                       what + " handle (its " + what + " was removed, or it was never made)");
    return *p;
  }
  [[nodiscard]] std::size_t bodyAt(BodyId id, const char* argument = "body") const {
    return position(bodySlots, id, argument, "body");
  }
  [[nodiscard]] std::size_t toolAt(ToolId id, const char* argument = "tool") const {
    return position(toolSlots, id, argument, "tool");
  }
  [[nodiscard]] std::size_t obstacleAt(ObstacleId id, const char* argument = "obstacle") const {
    return position(obstacleSlots, id, argument, "obstacle");
  }
  [[nodiscard]] SimBody& body(BodyId id) { return bodies[bodyAt(id)]; }
  [[nodiscard]] const SimBody& body(BodyId id) const { return bodies[bodyAt(id)]; }
  [[nodiscard]] WorldTool& tool(ToolId id) { return tools[toolAt(id)]; }
  [[nodiscard]] const WorldTool& tool(ToolId id) const { return tools[toolAt(id)]; }
  ToolId addTool(WorldTool t);
  /// Puts tool `ti` at `pose` now without moving it there (World::placeTool).
  void place(std::size_t ti, const BladePose& pose);
};

/// Publishes the probe's force model of the frame just run for the haptic call (Haptics.cpp).
void publishHaptic(WorldTool& t, double timeStep);

}  // namespace voxcut
