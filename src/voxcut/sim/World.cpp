#include "voxcut/sim/World.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>
#include <mutex>
#include <optional>
#include <string>

#include "voxcut/core/CoordinateRange.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/cutting/Fragments.h"
#include "voxcut/sim/BodyContacts.h"
#include "voxcut/sim/WorldInternals.h"
#include "voxcut/surface/VertexNormals.h"
#include "voxcut/topology/CutTopology.h"
#include "voxcut/voxel/Pieces.h"

namespace voxcut {
namespace {

enum Stage : std::size_t {
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

/// Voxels from the boundary that a body's rest distance field reaches: deeper points of another
/// body (or of itself) are not found as contacts.
constexpr int kRestDistanceBand = 3;

/// Coarsening after cuts (docs/algorithms.md, "Coarsening after cuts"): a start-level region
/// coarsens once no cut has touched it for this many frames, no blade's front lies in it and
/// no neighbouring region is busy (the blade has moved on), at most this many regions a frame
/// outside a quiet pass (so no frame stalls on it).
constexpr int kCoarsenAfterFrames = 2;
constexpr std::size_t kCoarsenRegionsPerFrame = 256;

/// The level a body's resting fronts are refined to: its finest level, by default two below
/// its start level (a quarter of an element's side).
int finestLevelOf(const BodySettings& s) {
  return s.finestLevel >= 0 ? std::min(s.finestLevel, s.elementLevel)
                            : std::max(s.elementLevel - 2, 0);
}

/// The start-level region (a cube of level S, DeformationOctree::cubeKey) holding voxel v,
/// clamped into a grid of `dims` voxels.
std::uint64_t regionKey(int S, const Index3& v, const Index3& dims) {
  return DeformationOctree::cubeKey(S, {std::clamp(v.x, 0, dims.x - 1) >> S,
                                        std::clamp(v.y, 0, dims.y - 1) >> S,
                                        std::clamp(v.z, 0, dims.z - 1) >> S});
}

/// Below this tangential speed (m/s) a contact's friction holds like a viscous stick; above it,
/// it is the Coulomb force mu f_n against the sliding (docs/algorithms.md, "Friction").
constexpr double kStickSpeed = 1e-3;
constexpr double kPairClosing = 0.5;

/// Sets a contact's friction damper for the coefficient mu: the normal force estimated from
/// `overlap`, how far the point is pressed in at the step's start (m; the contact's own share of
/// it between bodies, not the part of its gap that only follows the other body's motion), the
/// tangential speed from the point's and the surface's velocities.
void setFriction(PointContact& pc, double mu, double overlap, const Vec3d& pointVelocity,
                 const Vec3d& surfaceVelocity) {
  pc.surfaceVelocity = surfaceVelocity;
  const double normalForce = pc.stiffness * std::max(0.0, overlap);
  if (!(mu > 0.0) || !(normalForce > 0.0)) return;
  const Vec3d rel = pointVelocity - surfaceVelocity;
  const double slip = (rel - pc.normal.dot(rel) * pc.normal).norm();
  pc.friction = mu * normalForce / std::max(slip, kStickSpeed);
}

bool samePose(const BladePose& p, const BladePose& q) {
  return p.a == q.a && p.b == q.b;
}

/// Material table of a body indexed by grid material (entry 0, empty space, is unused).
std::vector<ElasticMaterial> elasticMaterials(const BodySettings& body, const VoxelGrid& grid) {
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

OctreeParams voxelOctreeParams(const BodySettings& body, const VoxelGrid& grid) {
  OctreeParams p;
  for (const std::string& name : grid.materialNames()) {
    const SceneMaterial m = sceneMaterial(body.materials, name);
    p.maxInternalLevel.push_back(m.maxInternalLevel);
    p.maxBoundaryLevel.push_back(m.maxBoundaryLevel);
  }
  return p;
}

bool inside(const FixedBox& box, const Vec3d& p) {
  return (p.array() >= box.lo.array()).all() && (p.array() <= box.hi.array()).all();
}

}  // namespace

const std::vector<std::string>& frameStageNames() {
  static const std::vector<std::string> names{
      "voxel_position_update", "intersection_test", "octree_subdivision",
      "deferred_updates",      "cut_topology",      "surface_update",
      "object_collision",      "deformation",       "surface_vertices"};
  return names;
}

namespace {

/// Vertices per task of the per-vertex contact loops.
constexpr std::size_t kVertexChunk = 512;

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
std::size_t vertexChunks(const std::vector<std::uint32_t>& vertices) {
  return (vertices.size() + kVertexChunk - 1) / kVertexChunk;
}

/// The span of wall-clock time between two frames that the haptic call blends over is held at
/// most this (seconds; a paused world still blends over a sensible time), and at least the
/// time step: frames that run back to back to catch up do not shorten the blend.
constexpr double kHapticMaxPeriod = 0.05;

/// The fastest the haptic call lets a frame's correction change its force (a fraction of the
/// force per millisecond), where the correction can take longer than a frame period.
constexpr double kHapticStepRate = 0.08;

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

/// A tool of the world: its shape, where it is, where it goes next frame, and what pushes on it.
struct WorldTool {
  ToolKind kind = ToolKind::Blade;
  double radius = 0.0;
  double friction = -1.0;           ///< Coulomb coefficient (negative: the world's default)
  BladePose pose;                   ///< now
  std::optional<BladePose> target;  ///< set by setToolPose for the end of the next frame
  std::vector<ToolKey> keys;        ///< trajectory (empty: none)
  double longest = 0.0;             ///< longest its segment has been (m): the fronts' sampling
  ToolReaction reaction;
  std::vector<ToolKey> recorded;
  HapticModel haptic;                ///< this thread's copy of what `slot` holds
  std::unique_ptr<HapticSlot> slot;  ///< shared with haptic threads (stable address)
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
};

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

}  // namespace

struct World::Impl {
  WorldSettings settings;
  std::string source;  ///< prefix of error messages (the scene file), may be empty
  std::vector<SimBody> bodies;
  std::vector<WorldTool> tools;
  std::vector<Obstacle> obstacles;
  int frame = 0;
  bool recording = false;

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

  [[nodiscard]] std::string prefix() const { return source.empty() ? "" : source + ": "; }
  [[nodiscard]] double time() const { return frame * settings.timeStep; }
  /// After a body's cuts: cut topology, surface, distance field.
  void afterCut(SimBody& body, const std::vector<std::uint64_t>& cut, const BladeEnds& ends,
                std::vector<double>& stageMs);
  /// The contacts between bodies (point contacts of each body's next step) and of bodies with
  /// themselves (pairs within the body's step); those the step's end finds pulling are left
  /// out and the step solved again.
  std::vector<BodyContactSet> findBodyContactsAll(std::vector<double>& stageMs,
                                                  FrameReport& report);
  /// A body's step with its contacts (the shapes', then `bodyContacts`), and its surface.
  void solvePhase(SimBody& body, const Motion& motion, ContactShapes& shapes,
                  BodyContactSet bodyContacts, std::vector<double>& stageMs, FrameReport& report);
  std::vector<std::uint64_t> cutBody(SimBody& body, const Motion& motion, BladeEnds& ends,
                                     std::vector<double>& stageMs);
  [[nodiscard]] std::optional<std::vector<BladeSweep>> toolSweeps(SimBody& body, std::size_t tool,
                                                                  const Motion& motion,
                                                                  BladeEnds& ends) const;
  TopologyChange updateTopology(SimBody& body, const std::vector<std::uint64_t>& cut,
                                const BladeEnds& ends);
  /// At a frame's start: coarsens the body's regions that cuts have left (docs/algorithms.md,
  /// "Coarsening after cuts"), with the model, solver, surface embedding and fronts.
  void coarsenBody(SimBody& body, std::vector<double>& stageMs);
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
  void refineRestingFronts(SimBody& body, std::vector<double>& stageMs);
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
  void recordSolve(const StepStatus& status, FrameReport& report) const;
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
                                       std::vector<PointContact>& contacts) const;
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
  [[nodiscard]] SimBody& body(std::size_t b) {
    VOXCUT_ASSERT(b < bodies.size(), "body index out of range");
    return bodies[b];
  }
  [[nodiscard]] WorldTool& tool(std::size_t t) {
    VOXCUT_ASSERT(t < tools.size(), "tool index out of range");
    return tools[t];
  }
  std::size_t addTool(WorldTool t);
  /// Puts tool `ti` at `pose` now without moving it there (World::placeTool).
  void place(std::size_t ti, const BladePose& pose);
};

const SimBody& WorldInternals::body(const World& world, std::size_t b) {
  VOXCUT_ASSERT(b < world.impl_->bodies.size(), "body index out of range");
  return world.impl_->bodies[b];
}

World::World(const WorldSettings& settings) : impl_(std::make_unique<Impl>()) {
  VOXCUT_ASSERT(settings.timeStep > 0.0, "the time step must be positive");
  impl_->settings = settings;
}
World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

World World::fromScene(const Scene& scene, std::vector<VoxelGrid> grids,
                       const WorldSettings& base) {
  if (grids.size() != scene.bodies.size())
    throw InputError(scene.source + ": " + std::to_string(scene.bodies.size()) + " bodies but " +
                     std::to_string(grids.size()) + " voxel grids");
  WorldSettings s = base;
  s.timeStep = scene.timeStep;
  s.gravity = scene.gravity;
  s.solver = scene.solver;
  s.contact = scene.contact;
  World w(s);
  w.impl_->source = scene.source;
  // Tools first, so that each body sizes its fronts once.
  for (const SceneTool& t : scene.tools) {
    VOXCUT_ASSERT(!t.keys.empty(), "a scene tool has keys");
    const std::size_t id = t.kind == ToolKind::Blade
                               ? w.addBlade(t.keys.front().pose)
                               : w.addProbe(t.radius, t.keys.front().pose, t.friction);
    w.setToolTrajectory(id, t.keys);
  }
  for (const Obstacle& o : scene.obstacles) w.addObstacle(o);
  for (std::size_t i = 0; i < grids.size(); ++i) {
    const SceneBody& sb = scene.bodies[i];
    BodySettings bs;
    bs.elementLevel = sb.elementLevel;
    bs.finestLevel = sb.finestLevel;
    bs.frontLevel = sb.frontLevel;
    bs.surfaceLevel = sb.surfaceLevel;
    bs.materials = sb.materials;
    bs.fixed = sb.fixed;
    w.addBody(std::move(grids[i]), bs);
  }
  return w;
}

const WorldSettings& World::settings() const {
  return impl_->settings;
}
int World::frame() const {
  return impl_->frame;
}
double World::time() const {
  return impl_->time();
}

// ---- bodies ----

std::size_t World::addBody(VoxelGrid grid, const BodySettings& settings) {
  Impl& w = *impl_;
  const WorldSettings& ws = w.settings;
  SimBody& b = w.bodies.emplace_back();
  try {
    CutBodyParams cp;
    cp.useOctree = ws.useOctree;
    cp.octree = voxelOctreeParams(settings, grid);
    cp.deformation.startLevel = settings.elementLevel;
    cp.deformation.maxLevel = std::min(settings.elementLevel + 1, 7);
    cp.deformation.surfaceLevel = settings.surfaceLevel;
    b.settings = settings;
    b.elastic = elasticMaterials(settings, grid);
    b.cut = makeCutBody(std::move(grid), cp, ws.threaded);
    ImplicitEulerParams solver;
    solver.timeStep = ws.timeStep;
    solver.gravity = ws.gravity;
    solver.tolerance = ws.solver.tolerance;
    solver.maxIterations = ws.solver.maxIterations;
    solver.projectionHistory = ws.solver.projectionHistory;
    solver.preconditioner = ws.solver.preconditioner;
    b.solver = ImplicitEuler(solver);
    w.rebuildModel(b);
    double stiffest = 0.0;
    for (const ElasticMaterial& m : b.elastic) stiffest = std::max(stiffest, m.youngModulus);
    b.contactStiffness = ws.contact.stiffness > 0.0 ? ws.contact.stiffness
                                                    : 10.0 * stiffest * b.cut.grid.voxelSize();
    b.fronts.resize(w.tools.size());
    b.frontSegments.assign(w.tools.size(), 0);
    DualContourParams dc;
    dc.threaded = ws.threaded;
    b.surface = ContouredSurface::build(b.cut.grid, dc);
    b.restDistance.build(b.cut.grid, kRestDistanceBand);
    w.embedVertices(b, nullptr);
    w.updateVertexPositions(b);
  } catch (...) {
    w.bodies.pop_back();
    throw;
  }
  return w.bodies.size() - 1;
}

std::size_t World::bodyCount() const {
  return impl_->bodies.size();
}

// The element matrices from the body's materials, with its fixed nodes.
void World::Impl::rebuildModel(SimBody& b) const {
  b.model = ElasticModel(b.cut.deformation, b.cut.grid, b.elastic, settings.threaded);
  if (!b.settings.fixed.empty()) b.model.setFixed(fixedFlags(b));
}

void World::setFixed(std::size_t body, std::vector<FixedBox> fixed) {
  SimBody& b = impl_->body(body);
  const bool had = !b.settings.fixed.empty();
  b.settings.fixed = std::move(fixed);
  if (had || !b.settings.fixed.empty())
    b.model.setFixed(b.settings.fixed.empty() ? std::vector<std::uint8_t>{} : Impl::fixedFlags(b));
}

void World::setMaterial(std::size_t body, const SceneMaterial& material) {
  SimBody& b = impl_->body(body);
  const std::vector<std::string>& names = b.cut.grid.materialNames();
  const auto it = std::find(names.begin(), names.end(), material.name);
  if (it == names.end()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    throw InputError(impl_->prefix() + "body " + std::to_string(body) + " has no material '" +
                     material.name + "' (it has: " + list + ")");
  }
  std::erase_if(b.settings.materials,
                [&](const SceneMaterial& m) { return m.name == material.name; });
  b.settings.materials.push_back(material);
  b.elastic = elasticMaterials(b.settings, b.cut.grid);
  impl_->rebuildModel(b);
}

BodyInfo World::bodyInfo(std::size_t body) const {
  const SimBody& b = impl_->bodies.at(body);
  BodyInfo info;
  info.elements = b.cut.deformation.elementCount();
  info.nodes = b.cut.deformation.nodeCount();
  info.cutLinks = b.cutLinks;
  info.surfaceVertices = b.surface.vertexCount();
  info.surfaceTriangles = b.surface.triangleCount();
  info.voxelSize = b.cut.grid.voxelSize();
  info.materialNames = b.cut.grid.materialNames();
  return info;
}

ActivityView World::activity(std::size_t body, std::size_t maxLinks,
                             const Eigen::AlignedBox3d* within) const {
  const SimBody& b = impl_->bodies.at(body);
  const VoxelGrid& grid = b.cut.grid;
  const VoxelOctree& act = b.cut.activity;
  const DeformationOctree& def = b.cut.deformation;
  const auto in = [&](const Vec3d& x) { return within == nullptr || within->contains(x); };
  // The links that count: active, still connected (a cut link takes no part any more), and
  // within the box.
  const auto counts = [&](std::uint32_t v, int a) {
    return act.linkActive(v, a) && grid.connected(v, a) &&
           (within == nullptr ||
            (in(def.voxelPosition(v)) && in(def.voxelPosition(v + grid.stride(a)))));
  };
  ActivityView view;
  for (const std::uint32_t v : act.activeVoxels)
    for (int a = 0; a < 3; ++a) view.activeLinks += counts(v, a);
  const std::size_t every =
      maxLinks == 0 ? 1 : std::max<std::size_t>(1, (view.activeLinks + maxLinks - 1) / maxLinks);
  std::size_t seen = 0;
  if (maxLinks > 0)
    for (const std::uint32_t v : act.activeVoxels)
      for (int a = 0; a < 3; ++a) {
        if (!counts(v, a) || seen++ % every != 0) continue;
        view.links.push_back({def.voxelPosition(v), def.voxelPosition(v + grid.stride(a))});
      }
  for (const OctreeCube& c : act.cubes) {
    if (c.deleted) continue;
    const int side = 1 << c.level;
    std::array<Vec3d, 8> corners;
    Eigen::AlignedBox3d box;
    for (int k = 0; k < 8; ++k) {
      const Index3 at{c.origin[0] + side * (k & 1), c.origin[1] + side * ((k >> 1) & 1),
                      c.origin[2] + side * (k >> 2)};
      corners[static_cast<std::size_t>(k)] = def.voxelPosition(grid.index(at));
      box.extend(corners[static_cast<std::size_t>(k)]);
    }
    if (within != nullptr && !within->intersects(box)) continue;
    view.cubes.push_back(corners);
    view.cubeLevels.push_back(c.level);
  }
  return view;
}

void World::setUseOctree(bool on) {
  impl_->settings.useOctree = on;
  for (SimBody& b : impl_->bodies)
    setActivity(b.cut, on, voxelOctreeParams(b.settings, b.cut.grid), impl_->settings.threaded);
}

int World::pieces(std::size_t body) const {
  return findPieces(impl_->bodies.at(body).cut.grid).count;
}

SurfaceView World::surface(std::size_t body) {
  SimBody& b = impl_->body(body);
  if (b.normalsFrame != impl_->frame) {
    // Area-weighted: each live triangle adds its unnormalised cross product to its corners.
    b.vertexNormals.assign(b.vertexPositions.size(), Vec3d::Zero());
    for (const std::array<int, 3>& t : b.surface.triangles()) {
      if (t[0] < 0) continue;
      const Vec3d& p0 = b.vertexPositions[static_cast<std::size_t>(t[0])];
      const Vec3d n = (b.vertexPositions[static_cast<std::size_t>(t[1])] - p0)
                          .cross(b.vertexPositions[static_cast<std::size_t>(t[2])] - p0);
      for (int c : t) b.vertexNormals[static_cast<std::size_t>(c)] += n;
    }
    for (Vec3d& n : b.vertexNormals) {
      const double len = n.norm();
      n = len > 0.0 ? Vec3d(n / len) : Vec3d::Zero();
    }
    b.normalsFrame = impl_->frame;
  }
  SurfaceView v;
  v.positions = b.vertexPositions;
  v.normals = b.vertexNormals;
  v.triangles = b.surface.triangles();
  v.triangleTags = b.surface.triangleTags();
  v.revision = b.surfaceRevision;
  return v;
}

SurfaceChanges World::surfaceChanges(std::size_t body, std::uint64_t since) const {
  const SimBody& b = impl_->bodies.at(body);
  SurfaceChanges c;
  c.from = since;
  c.to = b.surfaceRevision;
  if (since == b.surfaceRevision) return c;
  if (since > b.surfaceRevision || b.surfaceLog.empty() ||
      b.surfaceLog.front().revision > since + 1) {
    c.full = true;
    return c;
  }
  auto merge = [](std::vector<std::int32_t>& into, const std::vector<std::int32_t>& from) {
    into.insert(into.end(), from.begin(), from.end());
  };
  for (const SurfaceLogEntry& e : b.surfaceLog) {
    if (e.revision <= since) continue;
    merge(c.addedVertices, e.delta.addedVertices);
    merge(c.removedVertices, e.delta.removedVertices);
    merge(c.addedTriangles, e.delta.addedTriangles);
    merge(c.removedTriangles, e.delta.removedTriangles);
  }
  for (auto* list :
       {&c.addedVertices, &c.removedVertices, &c.addedTriangles, &c.removedTriangles}) {
    std::sort(list->begin(), list->end());
    list->erase(std::unique(list->begin(), list->end()), list->end());
  }
  return c;
}

SurfaceMesh World::surfaceMesh(std::size_t body) const {
  const SimBody& b = impl_->bodies.at(body);
  SurfaceMesh m;
  std::vector<int> index(b.surface.vertexSlots(), -1);
  for (std::size_t v = 0; v < index.size(); ++v) {
    if (!b.surface.alive(static_cast<std::int32_t>(v))) continue;
    index[v] = static_cast<int>(m.positions.size());
    m.positions.push_back(b.vertexPositions[v]);
    m.vertexVoxel.push_back(b.surface.vertexVoxels()[v]);
  }
  for (const auto& t : b.surface.triangles()) {
    if (t[0] < 0) continue;
    m.triangles.push_back({index[static_cast<std::size_t>(t[0])],
                           index[static_cast<std::size_t>(t[1])],
                           index[static_cast<std::size_t>(t[2])]});
  }
  // Normals follow the deformation: area-weighted from the deformed triangles.
  m.normals = vertexNormals(m.positions, m.triangles, Vec3d::UnitZ());
  return m;
}

double World::maxDisplacement() const {
  // Over the material (every occupied voxel's centre), not the nodes: a corner of a coarse
  // element that holds a few voxels lies outside the body, and its displacement extrapolates
  // the element's rotation over the empty part.
  double best = 0.0;
  for (const SimBody& b : impl_->bodies) {
    const VoxelGrid& grid = b.cut.grid;
    const DeformationOctree& octree = b.cut.deformation;
    const std::size_t n = grid.voxelCount();
    constexpr std::size_t kChunk = 4096;
    std::vector<double> partial((n + kChunk - 1) / kChunk, 0.0);
    parallelFor(
        0, partial.size(), 1,
        [&](std::size_t c0, std::size_t c1) {
          for (std::size_t c = c0; c < c1; ++c) {
            double m = 0.0;
            for (std::size_t v = kChunk * c; v < std::min(n, kChunk * (c + 1)); ++v)
              if (grid.occupied(v))
                m = std::max(m, (octree.voxelPosition(v) - grid.position(v)).norm());
            partial[c] = m;
          }
        },
        impl_->settings.threaded);
    for (double m : partial) best = std::max(best, m);
  }
  return best;
}

// ---- energy ----
BodyEnergy World::energy(std::size_t body) const {
  VOXCUT_ASSERT(body < impl_->bodies.size(), "body index out of range");
  const SimBody& b = impl_->bodies[body];
  const DeformationOctree& d = b.cut.deformation;
  BodyEnergy e;
  if (!b.solver.velocities().empty()) e.kinetic = b.solver.kineticEnergy(b.model);
  const std::vector<double>& mass = b.model.nodeMass();
  for (std::size_t n = 0; n < mass.size(); ++n)
    e.gravitational -= mass[n] * impl_->settings.gravity.dot(d.positions()[n]);
  e.elastic = elasticEnergy(b.model, d);
  return e;
}
// ---- end energy ----

std::uint64_t World::cutSetHash() const {
  if (impl_->bodies.size() == 1) return voxcut::cutSetHash(impl_->bodies[0].cuts);
  // Several bodies: each body's hash in body order, mixed (FNV-1a over their bytes).
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const SimBody& b : impl_->bodies) {
    const std::uint64_t bh = voxcut::cutSetHash(b.cuts);
    for (int i = 0; i < 8; ++i) {
      h ^= (bh >> (8 * i)) & 0xffu;
      h *= 0x100000001b3ULL;
    }
  }
  return h;
}

// ---- tools ----

std::size_t World::Impl::addTool(WorldTool t) {
  VOXCUT_ASSERT(isCoordinate(t.pose.a) && isCoordinate(t.pose.b),
                "a tool's pose has coordinates in range");
  t.longest = (t.pose.b - t.pose.a).norm();
  t.slot = std::make_unique<HapticSlot>();
  t.haptic.centre = t.slot->model.centre = 0.5 * (t.pose.a + t.pose.b);
  if (recording) t.recorded.push_back({time(), t.pose});
  tools.push_back(std::move(t));
  for (SimBody& b : bodies) {
    b.fronts.resize(tools.size());
    b.frontSegments.resize(tools.size(), 0);
  }
  return tools.size() - 1;
}

std::size_t World::addBlade(const BladePose& pose) {
  WorldTool t;
  t.kind = ToolKind::Blade;
  t.pose = pose;
  return impl_->addTool(std::move(t));
}

std::size_t World::addProbe(double radius, const BladePose& pose, double friction) {
  VOXCUT_ASSERT(radius > 0.0 && std::isfinite(radius), "a probe's radius is positive");
  WorldTool t;
  t.kind = ToolKind::Probe;
  t.radius = radius;
  t.friction = friction;
  t.pose = pose;
  return impl_->addTool(std::move(t));
}

std::size_t World::toolCount() const {
  return impl_->tools.size();
}
ToolKind World::toolKind(std::size_t tool) const {
  return impl_->tools.at(tool).kind;
}
double World::toolRadius(std::size_t tool) const {
  return impl_->tools.at(tool).radius;
}
BladePose World::toolPose(std::size_t tool) const {
  return impl_->tools.at(tool).pose;
}
ToolReaction World::toolReaction(std::size_t tool) const {
  return impl_->tools.at(tool).reaction;
}

void World::setToolPose(std::size_t tool, const BladePose& pose) {
  VOXCUT_ASSERT(isCoordinate(pose.a) && isCoordinate(pose.b),
                "a tool's pose has coordinates in range");
  WorldTool& t = impl_->tool(tool);
  t.keys.clear();
  t.target = pose;
  t.longest = std::max(t.longest, (pose.b - pose.a).norm());
}

void World::Impl::place(std::size_t ti, const BladePose& pose) {
  VOXCUT_ASSERT(isCoordinate(pose.a) && isCoordinate(pose.b),
                "a tool's pose has coordinates in range");
  WorldTool& t = tools[ti];
  t.pose = pose;
  t.longest = std::max(t.longest, (pose.b - pose.a).norm());
  t.reaction = ToolReaction{};
  // A blade's cut fronts start afresh from here, as for a new blade.
  for (SimBody& b : bodies) b.fronts[ti] = BladeFront{};
  // A probe's force model forgets the contact it had; the haptic call starts from nothing.
  t.haptic = HapticModel{};
  t.haptic.centre = 0.5 * (pose.a + pose.b);
  t.haptic.radius = t.radius;
  {
    const std::lock_guard<std::mutex> lock(t.slot->mutex);
    t.slot->model = t.haptic;
    t.slot->offset = Vec3d::Zero();
    t.slot->fade = 0.0;
    t.slot->wasAsked = false;
  }
  if (recording) {
    ToolKey& last = t.recorded.back();
    if (last.jump && last.t == time())
      last.pose = pose;
    else
      t.recorded.push_back({time(), pose, true});
  }
}

void World::placeTool(std::size_t tool, const BladePose& pose) {
  WorldTool& t = impl_->tool(tool);
  t.keys.clear();
  t.target.reset();
  impl_->place(tool, pose);
}

void World::setToolTrajectory(std::size_t tool, std::vector<ToolKey> keys) {
  VOXCUT_ASSERT(keysInOrder(keys),
                "a trajectory has keys with increasing times (a jump may share the time of "
                "the key before it)");
  WorldTool& t = impl_->tool(tool);
  for (const ToolKey& k : keys) t.longest = std::max(t.longest, (k.pose.b - k.pose.a).norm());
  t.keys = std::move(keys);
  t.target.reset();
  t.pose = bladePoseAt(t.keys, impl_->time());
}

void World::setRecording(bool on) {
  impl_->recording = on;
  if (!on) return;
  for (WorldTool& t : impl_->tools) t.recorded.assign(1, ToolKey{impl_->time(), t.pose});
}

const std::vector<ToolKey>& World::recording(std::size_t tool) const {
  return impl_->tools.at(tool).recorded;
}

// ---- obstacles ----

std::size_t World::addObstacle(const Obstacle& obstacle) {
  impl_->obstacles.push_back(obstacle);
  return impl_->obstacles.size() - 1;
}

std::size_t World::obstacleCount() const {
  return impl_->obstacles.size();
}

// ---- the frame ----

// A node in a fixed box is fixed when an element copy using it holds material within a voxel
// of the box: a copy reaches past its own voxels (a piece cut off next to the box, in a coarse
// element whose corners reach into the box) and must not pin material that lies away from it.
std::vector<std::uint8_t> World::Impl::fixedFlags(const SimBody& b) {
  const DeformationOctree& d = b.cut.deformation;
  const VoxelGrid& g = b.cut.grid;
  const std::vector<Vec3d>& rest = d.restPositions();
  std::vector<std::uint8_t> holds(d.elementCount(), 0);
  const Index3 gd = g.dims();
  for (const FixedBox& box : b.settings.fixed) {
    // The voxels whose centres lie within a voxel of the box (a box that holds only nodes,
    // around a body's end face, holds the voxels next to them).
    FixedBox near = box;
    near.lo -= Vec3d::Constant(g.voxelSize());
    near.hi += Vec3d::Constant(g.voxelSize());
    Index3 lo, hi;
    for (int a = 0; a < 3; ++a) {
      const double l = (box.lo[a] - g.origin()[a]) / g.voxelSize();
      const double h = (box.hi[a] - g.origin()[a]) / g.voxelSize();
      lo[a] = static_cast<int>(std::clamp(std::floor(l) - 1.0, 0.0, static_cast<double>(gd[a])));
      hi[a] = static_cast<int>(std::clamp(std::ceil(h) + 2.0, 0.0, static_cast<double>(gd[a])));
    }
    for (int z = lo.z; z < hi.z; ++z)
      for (int y = lo.y; y < hi.y; ++y)
        for (int x = lo.x; x < hi.x; ++x) {
          const std::size_t v = g.index(x, y, z);
          if (g.occupied(v) && inside(near, g.position(v))) holds[d.owner(v)] = 1;
        }
  }
  std::vector<std::uint8_t> fixed(rest.size(), 0);
  for (std::uint32_t e = 0; e < d.elementCount(); ++e) {
    if (!holds[e]) continue;
    for (std::uint32_t n : d.element(e).nodes)
      for (const FixedBox& box : b.settings.fixed)
        if (inside(box, rest[n])) fixed[n] = 1;
  }
  return fixed;
}

void World::Impl::embedVertices(SimBody& b, const std::vector<std::int32_t>* only) const {
  const DeformationOctree& d = b.cut.deformation;
  const std::vector<Vec3d>& rest = b.surface.positions();
  const std::vector<std::uint64_t>& voxel = b.surface.vertexVoxels();
  b.embedding.resize(b.surface.vertexSlots());
  b.vertexPositions.resize(b.surface.vertexSlots(), Vec3d::Zero());
  auto embed = [&](std::size_t v) {
    if (!b.surface.alive(static_cast<std::int32_t>(v))) {
      b.embedding[v] = VertexEmbedding{};
      return;
    }
    const std::uint32_t e = d.owner(static_cast<std::size_t>(voxel[v]));
    VOXCUT_ASSERT(e != kNoElement, "a surface vertex's voxel is occupied");
    const OctreeElement& el = d.element(e);
    const double size = d.voxelSize() * el.size();
    b.embedding[v] = VertexEmbedding{e, (rest[v] - d.nodeGridPosition(el.firstVoxel())) / size};
  };
  if (only) {
    for (std::int32_t v : *only) embed(static_cast<std::size_t>(v));
    return;
  }
  parallelFor(
      0, b.embedding.size(), 4096,
      [&](std::size_t lo, std::size_t hi) {
        for (std::size_t v = lo; v < hi; ++v) embed(v);
      },
      settings.threaded);
}

void World::Impl::updateVertexPositions(SimBody& b) const {
  const DeformationOctree& d = b.cut.deformation;
  parallelFor(
      0, b.embedding.size(), 4096,
      [&](std::size_t lo, std::size_t hi) {
        for (std::size_t v = lo; v < hi; ++v)
          if (b.embedding[v].element != kNoElement)
            b.vertexPositions[v] = d.pointInElement(b.embedding[v].element, b.embedding[v].local);
      },
      settings.threaded);
}

// What follows a body's cuts: its cut topology (the model's and solver's with it), its surface
// and its rest distance field.
void World::Impl::afterCut(SimBody& b, const std::vector<std::uint64_t>& cut, const BladeEnds& ends,
                           std::vector<double>& ms) {
  // The topology (deformation octree, model, solver, fronts) beside the surface's and the
  // distance field's own updates: all three only read the grid, and write apart.
  TopologyChange change;
  SurfaceDelta delta;
  double topologyMs = 0.0, surfaceMs = 0.0, distanceMs = 0.0;
  parallelInvoke(
      [&] {
        const Timer timer;
        change = updateTopology(b, cut, ends);
        topologyMs = timer.ms();
      },
      [&] {
        if (cut.empty()) return;
        Timer timer;
        delta = b.surface.update(b.cut.grid, cut);
        surfaceMs = timer.ms();
        timer.restart();
        b.restDistance.update(b.cut.grid, cut);
        distanceMs = timer.ms();
      },
      settings.threaded && !cut.empty());
  ms[kCutTopology] += topologyMs;
  ms[kObjectCollision] += distanceMs;
  const Timer timer;
  if (!cut.empty()) embedSurfaceChange(b, std::move(delta), change);
  ms[kSurfaceUpdate] += surfaceMs + timer.ms();
}

std::vector<BodyContactSet> World::Impl::findBodyContactsAll(std::vector<double>& ms,
                                                             FrameReport& report) {
  std::vector<BodyContactSet> out(bodies.size());
  if (bodies.size() < 2 && !settings.contact.selfCollision) return out;
  Timer timer;
  const double dt = settings.timeStep;
  // Which pairs can touch: bounding boxes of the current nodes, grown by a voxel.
  std::vector<Eigen::AlignedBox3d> bounds(bodies.size());
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    for (const Vec3d& x : bodies[i].cut.deformation.positions()) bounds[i].extend(x);
    const double pad = bodies[i].cut.grid.voxelSize();
    bounds[i].extend(bounds[i].min() - Vec3d::Constant(pad));
    bounds[i].extend(bounds[i].max() + Vec3d::Constant(pad));
  }
  std::vector<LayeredHash> hashes(bodies.size());
  std::vector<std::uint8_t> hashed(bodies.size(), 0);
  // Effective inverse mass of a point with trilinear weights w in element e: sum w_c^2 / m_c
  // over its free corners (0 where every corner is fixed).
  auto inverseMass = [](const SimBody& body, std::uint32_t e, const std::array<double, 8>& w) {
    const OctreeElement& el = body.cut.deformation.element(e);
    const std::vector<std::uint8_t>& fixed = body.model.fixed();
    double sum = 0.0;
    for (std::size_t c = 0; c < 8; ++c) {
      const std::uint32_t n = el.nodes[c];
      const double m = body.model.nodeMass()[n];
      if ((n < fixed.size() && fixed[n] != 0) || !(m > 0.0)) continue;
      sum += w[c] * w[c] / m;
    }
    return sum;
  };
  for (SimBody& body : bodies) groupVerticesByElement(body, body.verticesByElement);
  for (std::size_t ib_ = 0; ib_ < bodies.size(); ++ib_)
    for (std::size_t ia_ = 0; ia_ < bodies.size(); ++ia_) {
      const bool self = ia_ == ib_;
      if (self ? !settings.contact.selfCollision : !bounds[ia_].intersects(bounds[ib_])) continue;
      const SimBody& a = bodies[ia_];
      const SimBody& b = bodies[ib_];
      if (!hashed[ib_]) {
        buildElementHash(b, hashes[ib_], settings.threaded);
        hashed[ib_] = 1;
      }
      for (const BodyContactPoint& c : findBodyContacts(
               a, b, hashes[ib_], self, dt, settings.threaded,
               self ? &bodies[ia_].selfCandidates : nullptr, &bodies[ia_].verticesByElement)) {
        // The depth is the vertex's moved on by dt times its velocity relative to B's element,
        // v_p - v_e: the gap now is -depth - dt n.(v_p - v_e).
        // Each body's step sees the other at its frame-start velocity, so each closes only
        // its share of g, by inverse effective mass (all of it against fixed nodes), against
        // a contact plane that moves with the pair's mass-weighted normal velocity
        // (docs/algorithms.md, "Object collision").
        const double ia = inverseMass(a, c.element, c.weight);
        const double ib = inverseMass(b, c.other, c.otherWeight);
        if (!(ia + ib > 0.0)) continue;
        const Vec3d va = pointVelocity(a, c.element, c.weight);
        const Vec3d vb = pointVelocity(b, c.other, c.otherWeight);
        // Both bodies' vertices find the same interface (each inside the other), so each
        // contact closes half of its gap: together they close it once.
        const double gNow = -c.depth - dt * c.normal.dot(va - c.otherVelocity);
        const double g = (gNow < 0.0 ? 0.5 * kPairClosing : 0.5) * gNow;
        report.maxPenetration = std::max(report.maxPenetration, c.currentDepth);
        if (self) {
          // Within one body the pair is one spring of the body's step (docs/algorithms.md,
          // "Self contact in one solve"): equal and opposite forces.
          PairContact pc;
          pc.element = c.element;
          pc.weight = c.weight;
          pc.other = c.other;
          pc.otherWeight = c.otherWeight;
          pc.normal = c.normal;
          pc.gap = g;
          // Per vertex, the stiffness of a voxel's area against the coarser element's edge
          // rather than against a voxel: stiffer than its elements, a pair's cross terms
          // (which the preconditioner does not see) cost iterations in proportion and stop
          // no more penetration than the elements can resolve (docs/algorithms.md, "Self
          // contact in one solve").
          const int coarser = std::max(a.cut.deformation.element(c.element).size(),
                                       a.cut.deformation.element(c.other).size());
          pc.stiffness = a.contactStiffness / coarser;
          const double normalForce = pc.stiffness * std::max(0.0, -g);
          const Vec3d rel = va - vb;
          const double slip = (rel - c.normal.dot(rel) * c.normal).norm();
          if (settings.contact.friction > 0.0 && normalForce > 0.0)
            pc.friction = settings.contact.friction * normalForce / std::max(slip, kStickSpeed);
          out[ia_].pairs.push_back(pc);
          continue;
        }
        const double sa = ia / (ia + ib), sb = ib / (ia + ib);
        const double vpn = c.normal.dot(va);
        const double vqn = c.normal.dot(vb);
        const double plane = sb * vpn + sa * vqn;
        // Friction drags each side toward the pair's mass-weighted common velocity.
        const Vec3d common = sb * va + sa * vb;
        PointContact pa;
        pa.element = c.element;
        pa.weight = c.weight;
        pa.normal = c.normal;
        pa.gap = sa * g - dt * plane;
        pa.stiffness = a.contactStiffness;
        setFriction(pa, settings.contact.friction, -sa * g, va, common);
        out[ia_].points.push_back(pa);
        PointContact pb;
        pb.element = c.other;
        pb.weight = c.otherWeight;
        pb.normal = -c.normal;
        pb.gap = sb * g + dt * plane;
        pb.stiffness = b.contactStiffness;
        setFriction(pb, settings.contact.friction, -sb * g, vb, common);
        out[ib_].points.push_back(pb);
      }
    }
  ms[kObjectCollision] += timer.ms();
  return out;
}

void World::Impl::solvePhase(SimBody& b, const Motion& motion, ContactShapes& shapes,
                             BodyContactSet contactSet, std::vector<double>& ms,
                             FrameReport& report) {
  Timer timer;
  nearShapes(b, shapes);
  ActiveSetEdits edits;
  std::vector<PointContact> shapeContacts;
  std::vector<PointContact>& bodyContacts = contactSet.points;
  std::vector<PairContact>& pairs = contactSet.pairs;
  std::vector<ContactHit> hits = findContacts(b, shapes, edits, shapeContacts);
  auto setContacts = [&] {
    std::vector<PointContact> all = shapeContacts;
    all.insert(all.end(), bodyContacts.begin(), bodyContacts.end());
    b.solver.setContacts(std::move(all));
    b.solver.setPairContacts(pairs);
  };
  setContacts();
  ms[kObjectCollision] += timer.ms();

  // The step, solved again (from the same start) while the contact set it ends with differs
  // from the one it was given, a few times at most.
  constexpr int kContactPasses = 3;
  const bool contacts = shapes.size() > 0 || !bodyContacts.empty() || !pairs.empty();
  const std::vector<Vec3d> startPositions =
      contacts ? b.cut.deformation.positions() : std::vector<Vec3d>{};
  const std::vector<Vec3d> startVelocities =
      contacts ? b.solver.velocities() : std::vector<Vec3d>{};
  // The deepest a vertex ends inside a shape, when the last active-set check measured it on the
  // step's final positions (negative: not measured).
  double deepestAtEnd = -1.0;
  for (int pass = 1;; ++pass) {
    timer.restart();
    const StepStatus status = b.solver.step(b.model, b.cut.deformation);
    ms[kDeformation] += timer.ms();
    recordSolve(status, report);
    if (!contacts || pass == kContactPasses) break;
    timer.restart();
    double deepest = 0.0;
    bool changed = shapes.size() > 0 && correctActiveSet(b, shapes, hits, edits, deepest);
    // Contacts with other bodies (and the body itself) that pulled: left out.
    const std::vector<double>& force = b.solver.contactForces();
    std::vector<PointContact> pushing;
    for (std::size_t k = 0; k < bodyContacts.size(); ++k)
      if (!(force[hits.size() + k] < 0.0)) pushing.push_back(bodyContacts[k]);
    changed = changed || pushing.size() != bodyContacts.size();
    bodyContacts = std::move(pushing);
    std::vector<PairContact> pushingPairs;
    for (std::size_t k = 0; k < pairs.size(); ++k)
      if (!(b.solver.pairForces()[k] < 0.0)) pushingPairs.push_back(pairs[k]);
    changed = changed || pushingPairs.size() != pairs.size();
    pairs = std::move(pushingPairs);
    if (changed) {
      b.cut.deformation.positions() = startPositions;
      b.solver.setVelocities(startVelocities);
      hits = findContacts(b, shapes, edits, shapeContacts);
      setContacts();
    }
    ms[kObjectCollision] += timer.ms();
    if (!changed) {
      if (shapes.size() > 0) deepestAtEnd = deepest;
      break;
    }
  }
  const std::vector<double>& force = b.solver.contactForces();
  const std::vector<Vec3d>& friction = b.solver.contactFrictionForces();
  for (std::size_t k = 0; k < hits.size(); ++k) {
    const ContactHit& h = hits[k];
    // On the obstacle or probe: what the step applied, a spring that still pulls after the
    // last solve included (docs/algorithms.md, "Contact").
    const Vec3d f = -force[k] * h.normal - friction[k];
    if (h.source < obstacles.size()) {
      report.obstacleForces[h.source] += f;
    } else {
      const std::size_t ti = shapes.probeTool[h.source - obstacles.size()];
      const BladePose& p = motion.to[ti];
      report.toolReactions[ti].force += f;
      report.toolReactions[ti].torque += (h.point - 0.5 * (p.a + p.b)).cross(f);
    }
  }
  report.contacts += hits.size() + bodyContacts.size() + pairs.size();

  timer.restart();
  updateVertexPositions(b);
  ms[kSurfaceVertices] += timer.ms();

  timer.restart();
  report.maxPenetration = std::max(
      report.maxPenetration, deepestAtEnd >= 0.0 ? deepestAtEnd : deepestPenetration(b, shapes));
  ms[kObjectCollision] += timer.ms();
}

// Contact: each surface vertex inside an obstacle or probe, or headed inside it within this
// step at its current velocity, becomes a point contact of the implicit step
// (docs/algorithms.md, "Contact"). Vertices in slot order, shapes in order (obstacles, then
// probes).
std::vector<ContactHit> World::Impl::findContacts(const SimBody& b, const ContactShapes& shapes,
                                                  const ActiveSetEdits& edits,
                                                  std::vector<PointContact>& contacts) const {
  std::vector<ContactHit> hits;
  contacts.clear();
  if (shapes.size() == 0) return hits;
  const double dt = settings.timeStep;
  const std::size_t chunks = vertexChunks(shapes.vertices);
  std::vector<std::vector<PointContact>> chunkContacts(chunks);
  std::vector<std::vector<ContactHit>> chunkHits(chunks);
  forEachVertexChunked(
      b, settings.threaded, shapes.vertices,
      [&](std::size_t ch, std::size_t v, const Vec3d& x) {
        const VertexEmbedding& em = b.embedding[v];
        const std::array<double, 8> w = trilinearWeights(em.local);
        const Vec3d vp = pointVelocity(b, em.element, w);
        for (std::size_t s = 0; s < shapes.size(); ++s) {
          if (!shapes.mayTouch(em.element, s)) continue;
          const std::uint64_t key = v * shapes.size() + s;
          const bool forced = std::binary_search(edits.forced.begin(), edits.forced.end(), key);
          // Only a gap below dt |v_p| can be predicted to close; a forced contact needs its gap
          // wherever the vertex is.
          const double bound = forced ? std::numeric_limits<double>::infinity() : dt * vp.norm();
          Vec3d n;
          const double gap = shapes.distance(s, x, n, bound);
          const bool predicted = gap < 0.0 || gap + dt * n.dot(vp) < 0.0;
          if (predicted ? std::binary_search(edits.dropped.begin(), edits.dropped.end(), key)
                        : !forced)
            continue;
          PointContact pc;
          pc.element = em.element;
          pc.weight = w;
          pc.normal = n;
          pc.gap = gap;
          pc.stiffness = b.contactStiffness;
          setFriction(pc, shapes.friction[s], -gap, vp, shapes.velocity[s]);
          chunkContacts[ch].push_back(pc);
          chunkHits[ch].push_back({static_cast<std::uint32_t>(v), s, n, x - gap * n});
        }
      },
      &shapes.startPositions);
  for (std::size_t ch = 0; ch < chunks; ++ch) {
    contacts.insert(contacts.end(), chunkContacts[ch].begin(), chunkContacts[ch].end());
    hits.insert(hits.end(), chunkHits[ch].begin(), chunkHits[ch].end());
  }
  return hits;
}

bool World::Impl::correctActiveSet(const SimBody& b, const ContactShapes& shapes,
                                   const std::vector<ContactHit>& hits, ActiveSetEdits& edits,
                                   double& deepest) const {
  const std::size_t shapeCount = shapes.size();
  const std::vector<double>& force = b.solver.contactForces();
  bool changed = false;
  std::vector<std::uint64_t> inSet;
  inSet.reserve(hits.size());
  for (std::size_t k = 0; k < hits.size(); ++k) {
    const std::uint64_t key = std::uint64_t{hits[k].vertex} * shapeCount + hits[k].source;
    inSet.push_back(key);
    if (force[k] < 0.0) {
      edits.dropped.push_back(key);
      changed = true;
    }
  }
  // Keys come out ascending: hits are in vertex order, shapes in order within a vertex.
  // Vertices that end more than a fiftieth of a voxel inside a shape they had no contact with.
  const double tolerance = 0.02 * b.cut.grid.voxelSize();
  std::vector<std::vector<std::uint64_t>> chunkForced(vertexChunks(shapes.vertices));
  std::vector<double> chunkDeepest(chunkForced.size(), 0.0);
  forEachVertexChunked(b, settings.threaded, shapes.vertices,
                       [&](std::size_t ch, std::size_t v, const Vec3d& x) {
                         for (std::size_t s = 0; s < shapeCount; ++s) {
                           if (!shapes.mayTouch(b.embedding[v].element, s)) continue;
                           Vec3d n;
                           const double gap = shapes.distance(s, x, n, 0.0);
                           chunkDeepest[ch] = std::max(chunkDeepest[ch], -gap);
                           if (!(gap < -tolerance)) continue;
                           const std::uint64_t key = v * shapeCount + s;
                           if (!std::binary_search(inSet.begin(), inSet.end(), key))
                             chunkForced[ch].push_back(key);
                         }
                       });
  deepest = 0.0;
  for (double d : chunkDeepest) deepest = std::max(deepest, d);
  for (const std::vector<std::uint64_t>& f : chunkForced) {
    if (!f.empty()) changed = true;
    edits.forced.insert(edits.forced.end(), f.begin(), f.end());
  }
  std::sort(edits.forced.begin(), edits.forced.end());
  std::sort(edits.dropped.begin(), edits.dropped.end());
  // A key both forced and dropped (it went in, then pulled): left out.
  std::vector<std::uint64_t> forced;
  std::set_difference(edits.forced.begin(), edits.forced.end(), edits.dropped.begin(),
                      edits.dropped.end(), std::back_inserter(forced));
  edits.forced = std::move(forced);
  return changed;
}

void World::Impl::nearShapes(const SimBody& b, ContactShapes& shapes) const {
  const DeformationOctree& d = b.cut.deformation;
  const std::vector<Vec3d>& velocity = b.solver.velocities();
  const double dt = settings.timeStep;
  // A node moves at most dt (|v| + |g| dt) in a step unless forces beyond gravity act; twice
  // that, and a voxel, to spare (the step's re-solves and the contacts' own pushes).
  const double spare = b.cut.grid.voxelSize() + 2.0 * dt * dt * settings.gravity.norm();
  shapes.near.assign(d.elementCount(), 0);
  std::vector<double> motion(d.elementCount(), 0.0);  // how far the element's nodes may move
  parallelFor(
      0, d.elementCount(), 512,
      [&](std::size_t lo, std::size_t hi) {
        for (std::size_t e = lo; e < hi; ++e) {
          const OctreeElement& el = d.element(static_cast<std::uint32_t>(e));
          Eigen::AlignedBox3d box;
          double speed = 0.0;
          for (std::uint32_t n : el.nodes) {
            box.extend(d.positions()[n]);
            if (!velocity.empty()) speed = std::max(speed, velocity[n].norm());
          }
          motion[e] = 2.0 * dt * speed + spare;
          std::uint64_t bits = 0;
          for (std::size_t s = 0; s < std::min<std::size_t>(shapes.size(), 64); ++s)
            if (shapes.lowerBound(s, box, motion[e]) < motion[e]) bits |= std::uint64_t{1} << s;
          shapes.near[e] = bits;
        }
      },
      settings.threaded);
  // Then the vertices of those elements that a shape can reach within their element's motion:
  // an element's vertices lie anywhere in its ball, most of them farther than that.
  std::vector<std::uint32_t> all;
  for (std::size_t v = 0; v < b.embedding.size(); ++v)
    if (b.embedding[v].element != kNoElement && shapes.mayTouchAny(b.embedding[v].element))
      all.push_back(static_cast<std::uint32_t>(v));
  std::vector<std::vector<std::uint32_t>> chunkNear(vertexChunks(all));
  std::vector<std::vector<Vec3d>> chunkAt(chunkNear.size());
  forEachVertexChunked(
      b, settings.threaded, all, [&](std::size_t ch, std::size_t v, const Vec3d& x) {
        const std::uint32_t e = b.embedding[v].element;
        for (std::size_t s = 0; s < shapes.size(); ++s) {
          Vec3d n;
          if (shapes.mayTouch(e, s) && shapes.distance(s, x, n, motion[e]) < motion[e]) {
            chunkNear[ch].push_back(static_cast<std::uint32_t>(v));
            chunkAt[ch].push_back(x);
            return;
          }
        }
      });
  shapes.vertices.clear();
  shapes.startPositions.clear();
  for (std::size_t ch = 0; ch < chunkNear.size(); ++ch) {
    shapes.vertices.insert(shapes.vertices.end(), chunkNear[ch].begin(), chunkNear[ch].end());
    shapes.startPositions.insert(shapes.startPositions.end(), chunkAt[ch].begin(),
                                 chunkAt[ch].end());
  }
}

// The deepest any surface vertex of the body lies inside an obstacle or probe (m; 0 when
// none). The maximum does not depend on how the vertices are split among threads.
double World::Impl::deepestPenetration(const SimBody& b, const ContactShapes& shapes) const {
  if (shapes.size() == 0) return 0.0;
  std::vector<double> partial(vertexChunks(shapes.vertices), 0.0);
  parallelFor(
      0, partial.size(), 1,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t ch = c0; ch < c1; ++ch) {
          double deepest = 0.0;
          for (std::size_t k = ch * kVertexChunk;
               k < std::min(shapes.vertices.size(), (ch + 1) * kVertexChunk); ++k) {
            const std::uint32_t v = shapes.vertices[k];
            for (std::size_t s = 0; s < shapes.size(); ++s) {
              if (!shapes.mayTouch(b.embedding[v].element, s)) continue;
              Vec3d n;
              deepest = std::max(deepest, -shapes.distance(s, b.vertexPositions[v], n, 0.0));
            }
          }
          partial[ch] = deepest;
        }
      },
      settings.threaded);
  double deepest = 0.0;
  for (double p : partial) deepest = std::max(deepest, p);
  return deepest;
}

// Cutting tool collision: per moving blade, the strip of sweeps from its cut front (carried
// with the material since the last frame) to its new pose.
std::vector<std::uint64_t> World::Impl::cutBody(SimBody& b, const Motion& motion, BladeEnds& ends,
                                                std::vector<double>& ms) {
  std::vector<LinkCut> frameCuts;
  b.cutWork = {};
  ends.points.assign(tools.size(), {});
  ends.ids.assign(tools.size(), {});
  for (std::size_t ti = 0; ti < tools.size(); ++ti) {
    if (tools[ti].kind != ToolKind::Blade) continue;
    const std::optional<std::vector<BladeSweep>> moving = toolSweeps(b, ti, motion, ends);
    if (!moving || moving->empty()) continue;
    CutStepResult r = cutStepLeavingUpdates(b.cut, *moving, b.subdivision, settings.threaded);
    b.cutWork.add(r);
    ms[kPositionUpdate] += r.positionUpdateMs;
    ms[kIntersectionTest] += r.intersectionMs;
    ms[kOctreeSubdivision] += r.subdivisionMs;
    ms[kDeferredUpdates] += r.deferredMs;
    frameCuts.insert(frameCuts.end(), std::make_move_iterator(r.cuts.begin()),
                     std::make_move_iterator(r.cuts.end()));
  }
  // Debris: undo the fewest cuts that keep every tiny fragment attached (cutting/Fragments.h).
  std::sort(frameCuts.begin(), frameCuts.end(),
            [](const LinkCut& x, const LinkCut& y) { return x.link < y.link; });
  (void)healSmallFragments(b.cut.grid, frameCuts, settings.minFragmentVoxels);
  std::vector<std::uint64_t> cut;
  cut.reserve(frameCuts.size());
  for (const LinkCut& c : frameCuts) cut.push_back(c.link);
  b.cuts.insert(b.cuts.end(), frameCuts.begin(), frameCuts.end());
  return cut;
}

namespace {

/// Segments of a blade's carried front in a body: at least `minimum`, and no longer than a
/// voxel along the longest the blade has been, so that the front follows the material closely:
/// a chord of the carried front strays from the material line it stands for where the body
/// bends across it, and a link under that gap crosses neither frame's sweep. Capped at four
/// times the grid's longest side (a blade much longer than the body gains nothing inside it).
int frontSegments(double length, const VoxelGrid& grid, int minimum) {
  if (minimum <= 0) return minimum;
  const double cap = 4.0 * std::max({grid.dims().x, grid.dims().y, grid.dims().z});
  const double perVoxel = std::min(std::ceil(length / grid.voxelSize()), cap);
  return std::max(minimum, static_cast<int>(perVoxel));
}

}  // namespace

// The sweeps of tool ti this frame (nullopt when it does not move); with blade segments, its
// end pose's samples and ids go to `ends`.
std::optional<std::vector<BladeSweep>> World::Impl::toolSweeps(SimBody& b, std::size_t ti,
                                                               const Motion& motion,
                                                               BladeEnds& ends) const {
  const auto frameIndex = static_cast<std::uint64_t>(frame);
  const BladePose& from = motion.from[ti];
  const BladePose& to = motion.to[ti];
  if (samePose(from, to)) return std::nullopt;
  // The front's sampling is fixed the first time the blade moves in this body: the carried
  // front and the new pose's samples must pair up.
  if (b.frontSegments[ti] == 0)
    b.frontSegments[ti] = frontSegments(tools[ti].longest, b.cut.grid, settings.bladeSegments);
  const int segs = b.frontSegments[ti];
  const std::uint64_t n = static_cast<std::uint64_t>(std::max(segs, 1)) + 1;
  std::vector<BladeSweep> sweeps;
  if (segs <= 0) {
    sweeps.push_back(makeSweep(from, to, frameIndex));
  } else {
    ends.points[ti] = sampleBlade(to, segs);
    ends.ids[ti].resize(n);
    for (std::uint64_t i = 0; i < n; ++i) ends.ids[ti][i] = (2 * frameIndex + 1) * n + i;
    std::vector<Vec3d> start;
    std::vector<std::uint64_t> startIds;
    if (b.fronts[ti].empty()) {
      start = sampleBlade(from, segs);
      for (std::uint64_t i = 0; i < n; ++i) startIds.push_back(2 * frameIndex * n + i);
    } else {
      frontStart(b.fronts[ti], b.cut.deformation, 2 * frameIndex * n, start, startIds,
                 &ends.points[ti]);
    }
    sweeps = sweepStrip(start, startIds, ends.points[ti], ends.ids[ti], frameIndex);
  }
  // Only sweeps that reach the body can cross its links (every voxel lies in the hull of its
  // element's nodes): a blade much longer than the body keeps the few sweeps near it.
  Eigen::AlignedBox3d box;
  for (const Vec3d& x : b.cut.deformation.positions()) box.extend(x);
  box.extend(box.min() - Vec3d::Constant(b.cut.grid.voxelSize()));
  box.extend(box.max() + Vec3d::Constant(b.cut.grid.voxelSize()));
  std::erase_if(sweeps, [&](const BladeSweep& s) {
    return !s.bounds[0].merged(s.bounds[1]).intersects(box);
  });
  return sweeps;
}

// After the cuts: the cut topology, the model's and solver's, and the blades' fronts embedded
// again. Returns how the topology changed.
TopologyChange World::Impl::updateTopology(SimBody& b, const std::vector<std::uint64_t>& cut,
                                           const BladeEnds& ends) {
  TopologyChange change;
  // Fronts of blades that did not move this frame, where they are now (re-embedded after a
  // topology change, which renumbers elements but moves no material).
  std::vector<std::vector<Vec3d>> still(tools.size());
  if (!cut.empty()) {
    // The start-level regions cut in this frame wait before they coarsen.
    const int S = b.settings.elementLevel;
    for (std::uint64_t id : cut) {
      const std::size_t v = static_cast<std::size_t>(id / 3);
      for (std::size_t u : {v, v + b.cut.grid.stride(static_cast<int>(id % 3))}) {
        b.cutRegions[regionKey(S, b.cut.grid.coord(u), b.cut.grid.dims())] = frame;
      }
    }
    for (std::size_t ti = 0; ti < tools.size(); ++ti)
      if (ends.points[ti].empty() && !b.fronts[ti].empty()) {
        std::vector<std::uint64_t> ids;
        frontStart(b.fronts[ti], b.cut.deformation, 0, still[ti], ids);
      }
    // A cut refines nothing below the start level in its own frame: most fronts move on in
    // the next (refineRestingFronts refines those that stay).
    change = updateCutTopology(b.cut.deformation, b.cut.grid, cut,
                               CutTopologyParams{S, settings.threaded});
    if (change.changed) {
      applyTopologyChange(b, change);
      noteRefinedRegions(b, change, true);
      b.quietPassDone = false;
    }
  }
  for (std::size_t ti = 0; ti < tools.size(); ++ti) {
    if (!ends.points[ti].empty())
      b.fronts[ti] = embedFront(ends.points[ti], ends.ids[ti], b.cut.deformation);
    else if (change.changed && !b.fronts[ti].empty())
      b.fronts[ti] = embedFront(still[ti], b.fronts[ti].ids, b.cut.deformation);
  }
  // The regions the fronts rest in: where they were at the end of the last frame too.
  std::vector<std::uint64_t> now = frontRegions(b);
  b.restingRegions.clear();
  std::set_intersection(now.begin(), now.end(), b.frontRegions.begin(), b.frontRegions.end(),
                        std::back_inserter(b.restingRegions));
  b.frontRegions = std::move(now);
  return change;
}

std::vector<Index3> World::Impl::frontVoxels(const SimBody& b) const {
  const DeformationOctree& d = b.cut.deformation;
  std::vector<Index3> out;
  for (const BladeFront& bf : b.fronts)
    for (std::size_t i = 0; i < bf.element.size(); ++i) {
      if (bf.element[i] == kNoElement) continue;
      const OctreeElement& el = d.element(bf.element[i]);
      const Index3 f = el.firstVoxel();
      const Vec3d p = Vec3d(f.x, f.y, f.z) + el.size() * bf.local[i];
      out.push_back({static_cast<int>(p.x()), static_cast<int>(p.y()), static_cast<int>(p.z())});
    }
  return out;
}

std::vector<std::uint64_t> World::Impl::frontRegions(const SimBody& b) const {
  std::vector<std::uint64_t> out;
  for (const Index3& c : frontVoxels(b))
    out.push_back(regionKey(b.settings.elementLevel, c, b.cut.grid.dims()));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void World::Impl::refineRestingFronts(SimBody& b, std::vector<double>& ms) {
  const int S = b.settings.elementLevel;
  const int finest = finestLevelOf(b.settings);
  if (b.restingRegions.empty() || finest >= S) return;
  const Timer timer;
  // The cut links near the front points in resting regions: within two finest elements of a
  // point (other cuts' fronts in the region stay as they are).
  const VoxelGrid& g = b.cut.grid;
  const Index3 gd = g.dims();
  const int r = 2 << finest;
  std::vector<std::uint64_t> links;
  for (const Index3& c : frontVoxels(b)) {
    if (!std::binary_search(b.restingRegions.begin(), b.restingRegions.end(),
                            regionKey(S, c, gd)))
      continue;
    for (int z = std::max(c.z - r, 0); z < std::min(c.z + r, gd.z); ++z)
      for (int y = std::max(c.y - r, 0); y < std::min(c.y + r, gd.y); ++y)
        for (int x = std::max(c.x - r, 0); x < std::min(c.x + r, gd.x); ++x) {
          const std::size_t v = g.index(x, y, z);
          if (!g.occupied(v)) continue;
          for (int a = 0; a < 3; ++a)
            if (g.hasLink(v, a) && !g.connected(v, a) && g.occupied(v + g.stride(a)))
              links.push_back(VoxelGrid::linkId(v, a));
        }
  }
  if (links.empty()) return;
  const std::vector<std::vector<Vec3d>> front = frontPoints(b);
  CutTopologyParams cp{finest, settings.threaded};
  cp.refineOnly = true;
  const TopologyChange change = updateCutTopology(b.cut.deformation, g, links, cp);
  if (change.changed) {
    applyFrameStartChange(b, change, front);
    noteRefinedRegions(b, change, true);
    b.quietPassDone = false;
  }
  ms[kCutTopology] += timer.ms();
}

// The start-level regions holding new elements finer than the start level (refined around a
// cut by the 2:1 rule or for an unambiguous hanging node, possibly outside the cut's own
// regions) wait with the cut's before they coarsen.
void World::Impl::noteRefinedRegions(SimBody& b, const TopologyChange& change, bool settled) {
  const int S = b.settings.elementLevel;
  const DeformationOctree& d = b.cut.deformation;
  for (std::size_t e = 0; e < change.elementSource.size(); ++e) {
    const OctreeElement& el = d.element(static_cast<std::uint32_t>(e));
    if (change.elementSource[e] != kNewElement || el.level >= S) continue;
    const std::uint64_t key = regionKey(S, el.firstVoxel(), b.cut.grid.dims());
    if (settled)
      b.cutRegions.try_emplace(key, frame);
    else if (b.cutRegions.count(key) == 0)
      b.unsettledRegions.insert(key);
  }
}

std::vector<std::vector<Vec3d>> World::Impl::frontPoints(const SimBody& b) const {
  std::vector<std::vector<Vec3d>> out(tools.size());
  for (std::size_t ti = 0; ti < tools.size(); ++ti)
    if (!b.fronts[ti].empty()) {
      std::vector<std::uint64_t> ids;
      frontStart(b.fronts[ti], b.cut.deformation, 0, out[ti], ids);
    }
  return out;
}

void World::Impl::applyFrameStartChange(SimBody& b, const TopologyChange& change,
                                        const std::vector<std::vector<Vec3d>>& front) {
  applyTopologyChange(b, change);
  renumberVertexElements(b, change);
  // Both caches hold element ids.
  b.selfCandidates.valid = false;
  b.verticesByElement.valid = false;
  for (std::size_t ti = 0; ti < tools.size(); ++ti)
    if (!b.fronts[ti].empty())
      b.fronts[ti] = embedFront(front[ti], b.fronts[ti].ids, b.cut.deformation);
}

void World::Impl::applyTopologyChange(SimBody& b, const TopologyChange& change) {
  // The fixed boxes, applied to the new nodes in the same rebuild of the constraints.
  const std::vector<std::uint8_t> fixed =
      b.settings.fixed.empty() ? std::vector<std::uint8_t>{} : fixedFlags(b);
  b.model.updateTopology(b.cut.deformation, b.cut.grid, change,
                         b.settings.fixed.empty() ? nullptr : &fixed);
  b.solver.updateTopology(change);
}

void World::Impl::coarsenBody(SimBody& b, std::vector<double>& ms) {
  if (b.cutRegions.empty()) return;
  const Timer timer;
  // Regions where a blade's front is stay as they are: the cut goes on there.
  const int S = b.settings.elementLevel;
  for (std::uint64_t key : b.frontRegions) {
    const auto it = b.cutRegions.find(key);
    if (it != b.cutRegions.end()) it->second = frame;
  }
  // Due: left alone long enough, and so are its neighbours among the regions cut. Merging
  // next to a refined region that is still busy could leave a coarse cube whose parts meet
  // only through the finer neighbour, which the node rule would refine again: the two merge
  // together once both are due.
  auto waiting = [&](std::uint64_t key) {
    const auto it = b.cutRegions.find(key);
    return it != b.cutRegions.end() && frame - it->second < kCoarsenAfterFrames;
  };
  std::vector<std::uint64_t> due;
  // Nothing busy: every refined region at once, those the node rule refined again included
  // (merged together, they leave no finer neighbour to refine them again). Once after each
  // cut, so that a configuration the rule keeps refining costs one change.
  bool busy = false;
  for (const auto& [key, last] : b.cutRegions) busy = busy || frame - last < kCoarsenAfterFrames;
  const bool quietPass = !busy && !b.quietPassDone;
  if (quietPass) {
    for (const auto& [key, last] : b.cutRegions) due.push_back(key);
    due.insert(due.end(), b.unsettledRegions.begin(), b.unsettledRegions.end());
    b.unsettledRegions.clear();
    b.quietPassDone = true;
  }
  for (const auto& [key, last] : b.cutRegions) {
    if (quietPass) break;
    if (frame - last < kCoarsenAfterFrames) continue;
    constexpr std::uint64_t m = (std::uint64_t{1} << 20) - 1;
    const Index3 c{static_cast<int>((key >> 40) & m), static_cast<int>((key >> 20) & m),
                   static_cast<int>(key & m)};
    bool ready = true;
    for (int n = 0; n < 27 && ready; ++n) {
      const Index3 q{c.x + n % 3 - 1, c.y + (n / 3) % 3 - 1, c.z + n / 9 - 1};
      if (n != 13 && q.x >= 0 && q.y >= 0 && q.z >= 0)
        ready = !waiting(DeformationOctree::cubeKey(S, q));
    }
    if (ready) due.push_back(key);
  }
  if (due.empty()) {
    ms[kCutTopology] += timer.ms();
    return;
  }
  // The oldest regions first, a bounded number a frame (all of them in a quiet pass).
  auto lastOf = [&](std::uint64_t k) {
    const auto it = b.cutRegions.find(k);
    return it != b.cutRegions.end() ? it->second : -1;
  };
  std::sort(due.begin(), due.end(), [&](std::uint64_t x, std::uint64_t y) {
    const int fx = lastOf(x), fy = lastOf(y);
    return fx != fy ? fx < fy : x < y;
  });
  due.erase(std::unique(due.begin(), due.end()), due.end());
  if (!quietPass && due.size() > kCoarsenRegionsPerFrame) due.resize(kCoarsenRegionsPerFrame);
  std::unordered_map<std::uint64_t, int> lastCut;
  for (std::uint64_t k : due) {
    lastCut.emplace(k, lastOf(k));
    b.cutRegions.erase(k);
  }
  // The blades' fronts where they are now, to embed again in the new elements.
  const std::vector<std::vector<Vec3d>> front = frontPoints(b);
  CoarsenParams cp;
  cp.startLevel = S;
  const Index3 gd = b.cut.grid.dims();
  cp.surfaceLevel = initialFinestLevel(S, b.settings.surfaceLevel, std::max({gd.x, gd.y, gd.z}));
  cp.frontLevel = b.settings.frontLevel < 0 ? S : std::clamp(b.settings.frontLevel, 0, S);
  cp.threaded = settings.threaded;
  CoarsenResult res = coarsenCutTopology(b.cut.deformation, b.cut.grid, due, cp);
  // Refused for a finer neighbour: tried again as it was (the neighbour may coarsen first).
  // Refined again by the node rule: left as it is until a cut comes back, since trying again
  // would refine again, every few frames.
  for (std::uint64_t k : res.blocked)
    if (!std::binary_search(res.unsettled.begin(), res.unsettled.end(), k))
      b.cutRegions.emplace(k, lastCut.at(k));
  b.unsettledRegions.insert(res.unsettled.begin(), res.unsettled.end());
  if (res.change.changed) {
    applyFrameStartChange(b, res.change, front);
    noteRefinedRegions(b, res.change, false);
  }
  ms[kCutTopology] += timer.ms();
}

// After a topology change, each surface vertex's element id: the new id of its element when
// that element was kept (same cube, same voxels: the vertex's trilinear coordinates in it are
// the same), else looked up again from its voxel. One pass over the vertices with a table the
// size of the elements; only the vertices in refined or copied elements read the grid-sized
// embedding.
void World::Impl::renumberVertexElements(SimBody& b, const TopologyChange& change) const {
  std::vector<std::uint32_t> kept;  // old element -> its new id, or kNoElement
  for (std::size_t e = 0; e < change.elementSource.size(); ++e) {
    const std::uint32_t old = change.elementSource[e];
    if (old == kNewElement) continue;
    if (old >= kept.size()) kept.resize(static_cast<std::size_t>(old) + 1, kNoElement);
    kept[old] = static_cast<std::uint32_t>(e);
  }
  std::vector<std::int32_t> again;
  for (std::size_t v = 0; v < b.embedding.size(); ++v) {
    VertexEmbedding& em = b.embedding[v];
    if (em.element == kNoElement) continue;
    const std::uint32_t now = em.element < kept.size() ? kept[em.element] : kNoElement;
    if (now != kNoElement)
      em.element = now;
    else
      again.push_back(static_cast<std::int32_t>(v));
  }
  embedVertices(b, &again);
}

// After the surface's update for the cuts: its new vertices embedded (and, when elements were
// renumbered, the others' element ids renumbered), and the change logged for readers.
void World::Impl::embedSurfaceChange(SimBody& b, SurfaceDelta delta, const TopologyChange& change) {
  b.embedding.resize(b.surface.vertexSlots());
  b.vertexPositions.resize(b.surface.vertexSlots(), Vec3d::Zero());
  for (std::int32_t v : delta.removedVertices) b.embedding[static_cast<std::size_t>(v)] = {};
  if (change.changed) renumberVertexElements(b, change);
  embedVertices(b, &delta.addedVertices);
  if (delta.addedVertices.empty() && delta.removedVertices.empty() &&
      delta.addedTriangles.empty() && delta.removedTriangles.empty())
    return;
  // A bounded log: a reader further behind reads everything again (SurfaceChanges::full).
  constexpr std::size_t kLogLength = 256;
  b.surfaceLog.push_back({++b.surfaceRevision, std::move(delta)});
  if (b.surfaceLog.size() > kLogLength) b.surfaceLog.pop_front();
}

// The solve's counts in the frame's report; a diverged solve is an error.
void World::Impl::recordSolve(const StepStatus& status, FrameReport& report) const {
  report.solverIterations += status.iterations;
  report.solverFactorisations += status.factorised ? 1 : 0;
  report.converged = report.converged && status.converged;
  if (!status.finite)
    throw InputError(prefix() + "frame " + std::to_string(frame) +
                     ": a node position became non-finite (the solve diverged); try a smaller "
                     "time_step or stiffer solver settings");
}

namespace {

/// The force of one model at the probe's midpoint c: the linearisation, used within the last
/// frame's motion of the model's pose (held at that distance beyond: a device running ahead of
/// frames that fall behind feels no extrapolated wall or cliff), zero where it would pull, and
/// fading to zero as the probe is pulled out from one to two radii.
Vec3d hapticModelForce(const HapticModel& m, const Vec3d& c) {
  if (!m.contact) return Vec3d::Zero();
  Vec3d offset = c - m.centre;
  // Pulled out farther than its radius, the probe is leaving whatever the frames say: the
  // force fades to nothing at twice the radius.
  double leaving = 1.0;
  if (offset.dot(m.reaction.force) > 0.0)
    leaving = std::clamp(2.0 - offset.norm() / m.radius, 0.0, 1.0);
  if (offset.norm() > m.reach) offset *= m.reach / offset.norm();
  const Vec3d force = leaving * (m.reaction.force + m.jacobian * offset);
  // Contact pushes and never pulls: past the point where the extrapolation turns round, the
  // probe has left the surface.
  return force.dot(m.reaction.force) > 0.0 ? force : Vec3d::Zero();
}

/// What the haptic call answers at the probe midpoint c: the model's force plus what is left
/// of the step to it, never pulling (along the model's contact force, or along the leftover
/// where the model has none). The publication uses the same answer, so a step that the call
/// clamped to nothing is faded from nothing.
Vec3d hapticAnswer(const HapticModel& m, const Vec3d& leftover, const Vec3d& c) {
  const Vec3d force = hapticModelForce(m, c) + leftover;
  const Vec3d along = m.contact ? m.reaction.force : leftover;
  return force.dot(along) > 0.0 ? force : Vec3d::Zero();
}

/// The probe's force model after a frame: its reaction there, and the Jacobian estimate
/// updated by the secant of the last two frames along the probe's motion (Broyden's rank-one
/// update, which keeps what earlier motions taught in the other directions). A frame without
/// contact forgets it; the first frame of a contact has no slope yet. Published to the slot.
void publishHaptic(WorldTool& t, double timeStep) {
  HapticModel next;
  next.centre = 0.5 * (t.pose.a + t.pose.b);
  next.radius = t.radius;
  next.reaction = t.reaction;
  next.contact = t.reaction.force != Vec3d::Zero();
  next.reach = std::min(0.5 * t.radius, (next.centre - t.haptic.centre).norm());
  if (next.contact && t.haptic.contact) {
    next.jacobian = t.haptic.jacobian;
    const Vec3d dc = next.centre - t.haptic.centre;
    // Below a ten-thousandth of the radius, the force's change is the tissue settling, not
    // the motion: the slope would be noise.
    if (dc.norm() > 1e-4 * t.radius) {
      const Vec3d miss = next.reaction.force - t.haptic.reaction.force - next.jacobian * dc;
      next.jacobian += miss * dc.transpose() / dc.squaredNorm();
    }
  }
  t.haptic = next;
  const auto now = std::chrono::steady_clock::now();
  const std::lock_guard<std::mutex> lock(t.slot->mutex);
  HapticSlot& slot = *t.slot;
  // What the call answered at the new pose until now, less what the new model answers there:
  // faded out over the next period, it makes the force continuous in time.
  const Vec3d at = slot.wasAsked ? slot.asked : next.centre;
  const Vec3d answered = hapticAnswer(slot.model, (1.0 - slot.blend(now)) * slot.offset, at);
  const Vec3d fresh = hapticModelForce(next, at);
  slot.offset = answered - fresh;
  // The frames' wall-clock period (0 at the first publication: nothing to fade from).
  double period = 0.0;
  if (slot.published != std::chrono::steady_clock::time_point{})
    period = std::clamp(std::chrono::duration<double>(now - slot.published).count(),
                        std::min(timeStep, kHapticMaxPeriod), kHapticMaxPeriod);
  // A step larger than the frame period can spread at kHapticStepRate of the force per
  // millisecond is spread over longer (within the longest period): the force lags the frames
  // a little where they disagree much, rather than jumping.
  const double smaller = std::min(answered.norm(), fresh.norm());
  slot.fade = period;
  if (smaller > 0.0)
    slot.fade = std::clamp(1e-3 * slot.offset.norm() / (kHapticStepRate * smaller), period,
                           std::max(period, kHapticMaxPeriod));
  slot.model = next;
  slot.published = now;
}

}  // namespace

ToolReaction World::hapticForce(std::size_t tool, const BladePose& pose) const {
  VOXCUT_ASSERT(tool < impl_->tools.size(), "tool index out of range");
  HapticModel m;
  Vec3d offset;
  {
    const HapticSlot& slot = *impl_->tools[tool].slot;
    const std::lock_guard<std::mutex> lock(slot.mutex);
    m = slot.model;
    offset = (1.0 - slot.blend(std::chrono::steady_clock::now())) * slot.offset;
    slot.asked = 0.5 * (pose.a + pose.b);
    slot.wasAsked = true;
  }
  // The newest frame's model, plus what is left of the step to it (docs/algorithms.md,
  // "Forces at haptic rate"); still never pulling.
  ToolReaction r;
  r.force = hapticAnswer(m, offset, 0.5 * (pose.a + pose.b));
  if (r.force != Vec3d::Zero()) r.torque = m.reaction.torque;
  return r;
}

FrameReport World::step() {
  Impl& w = *impl_;
  Timer frameTimer;
  FrameReport report;
  report.frame = w.frame;
  report.stageMs.assign(kStageCount, 0.0);
  report.obstacleForces.assign(w.obstacles.size(), Vec3d::Zero());
  report.toolReactions.assign(w.tools.size(), ToolReaction{});
  // Where each tool goes this frame: its trajectory's pose at the frame's end, or the pose
  // the application set, or where it is.
  const double t1 = (w.frame + 1) * w.settings.timeStep;
  Impl::Motion motion;
  ContactShapes shapes;
  shapes.obstacles = &w.obstacles;
  const double mu = w.settings.contact.friction;
  for (const Obstacle& o : w.obstacles) {
    shapes.friction.push_back(o.friction >= 0.0 ? o.friction : mu);
    shapes.velocity.push_back(Vec3d::Zero());
  }
  for (std::size_t ti = 0; ti < w.tools.size(); ++ti) {
    // A trajectory's jump in this frame's span places the tool at its start.
    if (const ToolKey* jump =
            w.tools[ti].keys.empty() ? nullptr : jumpIn(w.tools[ti].keys, w.time(), t1))
      w.place(ti, jump->pose);
    const WorldTool& t = w.tools[ti];
    motion.from.push_back(t.pose);
    motion.to.push_back(!t.keys.empty() ? bladePoseBefore(t.keys, t1) : t.target.value_or(t.pose));
    if (t.kind == ToolKind::Probe) {
      shapes.probes.push_back({motion.to.back().a, motion.to.back().b, t.radius});
      shapes.probeTool.push_back(ti);
      shapes.friction.push_back(t.friction >= 0.0 ? t.friction : mu);
      const BladePose& from = motion.from.back();
      const BladePose& to = motion.to.back();
      shapes.velocity.push_back((0.5 * (to.a + to.b) - 0.5 * (from.a + from.b)) /
                                w.settings.timeStep);
    }
  }
  const std::size_t n = w.bodies.size();
  std::vector<std::vector<std::uint64_t>> cuts(n);
  std::vector<Impl::BladeEnds> ends(n);
  for (std::size_t i = 0; i < n; ++i) {
    w.refineRestingFronts(w.bodies[i], report.stageMs);
    w.coarsenBody(w.bodies[i], report.stageMs);
  }
  for (std::size_t i = 0; i < n; ++i) {
    cuts[i] = w.cutBody(w.bodies[i], motion, ends[i], report.stageMs);
    report.cutLinks += cuts[i].size();
    w.bodies[i].cutLinks += cuts[i].size();
    report.positionedVoxels += w.bodies[i].cutWork.positionedVoxels;
    report.testedLinks +=
        w.bodies[i].cutWork.testedLinks + w.bodies[i].cutWork.subdivisionTestedLinks;
  }
  // The octrees' deferred updates run beside the rest of the frame (the paper's figure 3):
  // they touch only each body's voxel octree, which nothing after the cut reads.
  std::vector<double> deferredMs(n, 0.0);
  parallelInvoke(
      [&] {
        for (std::size_t i = 0; i < n; ++i)
          deferredMs[i] = runDeferredUpdates(w.bodies[i].cut, w.settings.threaded);
      },
      [&] {
        for (std::size_t i = 0; i < n; ++i)
          w.afterCut(w.bodies[i], cuts[i], ends[i], report.stageMs);
        std::vector<BodyContactSet> bodyContacts = w.findBodyContactsAll(report.stageMs, report);
        for (std::size_t i = 0; i < n; ++i)
          w.solvePhase(w.bodies[i], motion, shapes, std::move(bodyContacts[i]), report.stageMs,
                       report);
      },
      w.settings.threaded);
  for (const double ms : deferredMs) report.stageMs[kDeferredUpdates] += ms;
  ++w.frame;
  for (std::size_t ti = 0; ti < w.tools.size(); ++ti) {
    WorldTool& t = w.tools[ti];
    t.pose = motion.to[ti];
    t.target.reset();
    t.reaction = report.toolReactions[ti];
    if (t.kind == ToolKind::Probe) publishHaptic(t, w.settings.timeStep);
    if (w.recording) t.recorded.push_back({w.time(), t.pose});
  }
  report.time = w.time();
  report.totalMs = frameTimer.ms();
  return report;
}

}  // namespace voxcut
