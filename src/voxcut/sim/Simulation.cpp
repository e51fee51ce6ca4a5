#include "voxcut/sim/Simulation.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <string>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/cutting/Fragments.h"
#include "voxcut/surface/VertexNormals.h"
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

bool samePose(const BladePose& p, const BladePose& q) {
  return p.a == q.a && p.b == q.b;
}

/// Material table of a body indexed by grid material (entry 0, empty space, is unused).
std::vector<ElasticMaterial> elasticMaterials(const SceneBody& body, const VoxelGrid& grid) {
  std::vector<ElasticMaterial> out(1);
  for (const std::string& name : grid.materialNames()) {
    const SceneMaterial m = sceneMaterial(body, name);
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

OctreeParams voxelOctreeParams(const SceneBody& body, const VoxelGrid& grid) {
  OctreeParams p;
  for (const std::string& name : grid.materialNames()) {
    const SceneMaterial m = sceneMaterial(body, name);
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

Simulation::Simulation(Scene scene, std::vector<VoxelGrid> grids, const SimulationParams& params)
    : scene_(std::move(scene)), params_(params) {
  if (grids.size() != scene_.bodies.size())
    throw InputError(scene_.source + ": " + std::to_string(scene_.bodies.size()) + " bodies but " +
                     std::to_string(grids.size()) + " voxel grids");
  ImplicitEulerParams solver;
  solver.timeStep = scene_.timeStep;
  solver.gravity = scene_.gravity;
  solver.tolerance = scene_.solver.tolerance;
  solver.maxIterations = scene_.solver.maxIterations;
  solver.preconditioner = scene_.solver.preconditioner;
  bodies_.resize(grids.size());
  for (std::size_t i = 0; i < grids.size(); ++i) {
    const SceneBody& sb = scene_.bodies[i];
    SimBody& b = bodies_[i];
    CutBodyParams cp;
    cp.useOctree = params_.useOctree;
    cp.octree = voxelOctreeParams(sb, grids[i]);
    cp.deformation.startLevel = sb.elementLevel;
    cp.deformation.maxLevel = std::min(sb.elementLevel + 1, 7);
    cp.deformation.surfaceLevel = sb.surfaceLevel;
    const std::vector<ElasticMaterial> materials = elasticMaterials(sb, grids[i]);
    b.cut = makeCutBody(std::move(grids[i]), cp, params_.threaded);
    b.model = ElasticModel(b.cut.deformation, b.cut.grid, materials, params_.threaded);
    b.solver = ImplicitEuler(solver);
    b.fixedBoxes = sb.fixed;
    double stiffest = 0.0;
    for (const ElasticMaterial& m : materials) stiffest = std::max(stiffest, m.youngModulus);
    b.contactStiffness = scene_.contact.stiffness > 0.0 ? scene_.contact.stiffness
                                                        : 10.0 * stiffest * b.cut.grid.voxelSize();
    b.finestLevel = sb.finestLevel;
    b.fronts.resize(scene_.tools.size());
    applyFixed(b);
    DualContourParams dc;
    dc.threaded = params_.threaded;
    b.surface = ContouredSurface::build(b.cut.grid, dc);
    embedVertices(b, nullptr);
    updateVertexPositions(b);
  }
}

std::vector<std::uint8_t> Simulation::fixedFlags(const SimBody& b) {
  const std::vector<Vec3d>& rest = b.cut.deformation.restPositions();
  std::vector<std::uint8_t> fixed(rest.size(), 0);
  for (std::size_t n = 0; n < rest.size(); ++n)
    for (const FixedBox& box : b.fixedBoxes)
      if (inside(box, rest[n])) fixed[n] = 1;
  return fixed;
}

void Simulation::applyFixed(SimBody& b) {
  if (!b.fixedBoxes.empty()) b.model.setFixed(fixedFlags(b));
}

void Simulation::embedVertices(SimBody& b, const std::vector<std::int32_t>* only) {
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
      params_.threaded);
}

void Simulation::updateVertexPositions(SimBody& b) const {
  const DeformationOctree& d = b.cut.deformation;
  parallelFor(
      0, b.embedding.size(), 4096,
      [&](std::size_t lo, std::size_t hi) {
        for (std::size_t v = lo; v < hi; ++v)
          if (b.embedding[v].element != kNoElement)
            b.vertexPositions[v] = d.pointInElement(b.embedding[v].element, b.embedding[v].local);
      },
      params_.threaded);
}

void Simulation::stepBody(SimBody& b, std::vector<double>& ms, FrameReport& report) {
  BladeEnds ends;
  const std::vector<std::uint64_t> cut = cutBody(b, ends, ms);
  report.cutLinks += cut.size();
  b.cutLinks += cut.size();

  Timer timer;
  const bool topologyChanged = updateTopology(b, cut, ends);
  ms[kCutTopology] += timer.ms();

  timer.restart();
  if (!cut.empty()) updateSurface(b, cut, topologyChanged);
  ms[kSurfaceUpdate] += timer.ms();

  timer.restart();
  std::vector<ObstacleHit> hits = findObstacleContacts(b);
  ms[kObjectCollision] += timer.ms();

  timer.restart();
  const StepStatus status = b.solver.step(b.model, b.cut.deformation);
  ms[kDeformation] += timer.ms();
  recordSolve(status, report);
  const std::vector<double>& force = b.solver.contactForces();
  for (std::size_t k = 0; k < hits.size(); ++k)
    report.obstacleForces[hits[k].obstacle] -= force[k] * hits[k].normal;
  report.contacts += hits.size();

  timer.restart();
  updateVertexPositions(b);
  ms[kSurfaceVertices] += timer.ms();

  timer.restart();
  report.maxPenetration = std::max(report.maxPenetration, deepestPenetration(b));
  ms[kObjectCollision] += timer.ms();
}

// Contact with the obstacles: each surface vertex inside an obstacle, or headed inside it
// within this step at its current velocity, becomes a point contact of the implicit step
// (docs/algorithms.md, "Contact"). Vertices in id order, obstacles in scene order.
std::vector<Simulation::ObstacleHit> Simulation::findObstacleContacts(SimBody& b) const {
  std::vector<ObstacleHit> hits;
  if (scene_.obstacles.empty()) {
    b.solver.setContacts({});
    return hits;
  }
  const DeformationOctree& d = b.cut.deformation;
  const std::vector<Vec3d>& velocity = b.solver.velocities();
  const double dt = scene_.timeStep;
  // Chunks of vertices in parallel, each into its own lists, joined in chunk order: the
  // contacts come out in vertex order whatever the thread count.
  constexpr std::size_t kChunk = 2048;
  const std::size_t chunks = (b.embedding.size() + kChunk - 1) / kChunk;
  std::vector<std::vector<PointContact>> chunkContacts(chunks);
  std::vector<std::vector<ObstacleHit>> chunkHits(chunks);
  parallelFor(
      0, chunks, 1,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t ch = c0; ch < c1; ++ch)
          for (std::size_t v = ch * kChunk; v < std::min(b.embedding.size(), (ch + 1) * kChunk);
               ++v) {
            const VertexEmbedding& em = b.embedding[v];
            if (em.element == kNoElement) continue;
            // From the nodes, not vertexPositions: vertices a cut added this frame have none
            // yet.
            const Vec3d x = d.pointInElement(em.element, em.local);
            const std::array<double, 8> w = trilinearWeights(em.local);
            Vec3d vp = Vec3d::Zero();
            if (!velocity.empty())
              for (std::size_t c = 0; c < 8; ++c)
                vp += w[c] * velocity[d.element(em.element).nodes[c]];
            for (std::size_t o = 0; o < scene_.obstacles.size(); ++o) {
              Vec3d n;
              const double gap = signedDistance(scene_.obstacles[o], x, n);
              if (!(gap < 0.0 || gap + dt * n.dot(vp) < 0.0)) continue;
              PointContact pc;
              pc.element = em.element;
              pc.weight = w;
              pc.normal = n;
              pc.gap = gap;
              pc.stiffness = b.contactStiffness;
              chunkContacts[ch].push_back(pc);
              chunkHits[ch].push_back({o, n});
            }
          }
      },
      params_.threaded);
  std::vector<PointContact> contacts;
  for (std::size_t ch = 0; ch < chunks; ++ch) {
    contacts.insert(contacts.end(), chunkContacts[ch].begin(), chunkContacts[ch].end());
    hits.insert(hits.end(), chunkHits[ch].begin(), chunkHits[ch].end());
  }
  b.solver.setContacts(std::move(contacts));
  return hits;
}

// The deepest any surface vertex of the body lies inside an obstacle (m; 0 when none). The
// maximum does not depend on how the vertices are split among threads.
double Simulation::deepestPenetration(const SimBody& b) const {
  if (scene_.obstacles.empty()) return 0.0;
  constexpr std::size_t kChunk = 4096;
  std::vector<double> partial((b.embedding.size() + kChunk - 1) / kChunk, 0.0);
  parallelFor(
      0, partial.size(), 1,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t ch = c0; ch < c1; ++ch) {
          double deepest = 0.0;
          for (std::size_t v = ch * kChunk; v < std::min(b.embedding.size(), (ch + 1) * kChunk);
               ++v) {
            if (b.embedding[v].element == kNoElement) continue;
            for (const Obstacle& o : scene_.obstacles) {
              Vec3d n;
              deepest = std::max(deepest, -signedDistance(o, b.vertexPositions[v], n));
            }
          }
          partial[ch] = deepest;
        }
      },
      params_.threaded);
  double deepest = 0.0;
  for (double p : partial) deepest = std::max(deepest, p);
  return deepest;
}

// Cutting tool collision: per moving blade, the strip of sweeps from its cut front (carried
// with the material since the last frame) to its new pose.
std::vector<std::uint64_t> Simulation::cutBody(SimBody& b, BladeEnds& ends,
                                               std::vector<double>& ms) {
  std::vector<LinkCut> frameCuts;
  ends.points.assign(scene_.tools.size(), {});
  ends.ids.assign(scene_.tools.size(), {});
  for (std::size_t ti = 0; ti < scene_.tools.size(); ++ti) {
    const std::optional<std::vector<BladeSweep>> moving = toolSweeps(b, ti, ends);
    if (!moving || moving->empty()) continue;
    const std::vector<BladeSweep>& sweeps = *moving;
    CutStepResult r = cutStep(b.cut, sweeps, b.subdivision, params_.threaded);
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
  (void)healSmallFragments(b.cut.grid, frameCuts, params_.minFragmentVoxels);
  std::vector<std::uint64_t> cut;
  cut.reserve(frameCuts.size());
  for (const LinkCut& c : frameCuts) cut.push_back(c.link);
  return cut;
}

namespace {

/// Segments of a blade's carried front in a body: at least `minimum`, and no longer than a
/// voxel along the blade's longest key, so that the front follows the material closely: a
/// chord of the carried front strays from the material line it stands for where the body
/// bends across it, and a link under that gap crosses neither frame's sweep. Capped at four
/// times the grid's longest side (a blade much longer than the body gains nothing inside it).
int frontSegments(const SceneTool& tool, const VoxelGrid& grid, int minimum) {
  if (minimum <= 0) return minimum;
  double length = 0.0;
  for (const ToolKey& k : tool.keys) length = std::max(length, (k.pose.b - k.pose.a).norm());
  const double cap = 4.0 * std::max({grid.dims().x, grid.dims().y, grid.dims().z});
  const double perVoxel = std::min(std::ceil(length / grid.voxelSize()), cap);
  return std::max(minimum, static_cast<int>(perVoxel));
}

}  // namespace

// The sweeps of tool ti this frame (nullopt when it does not move); with blade segments, its
// end pose's samples and ids go to `ends`.
std::optional<std::vector<BladeSweep>> Simulation::toolSweeps(SimBody& b, std::size_t ti,
                                                              BladeEnds& ends) const {
  const double t0 = frame_ * scene_.timeStep, t1 = (frame_ + 1) * scene_.timeStep;
  const auto frame = static_cast<std::uint64_t>(frame_);
  const SceneTool& tool = scene_.tools[ti];
  const int segs = frontSegments(tool, b.cut.grid, params_.bladeSegments);
  const std::uint64_t n = static_cast<std::uint64_t>(std::max(segs, 1)) + 1;
  const BladePose from = bladePoseAt(tool, t0), to = bladePoseAt(tool, t1);
  if (samePose(from, to)) return std::nullopt;
  std::vector<BladeSweep> sweeps;
  if (segs <= 0) {
    sweeps.push_back(makeSweep(from, to, frame));
  } else {
    ends.points[ti] = sampleBlade(to, segs);
    ends.ids[ti].resize(n);
    for (std::uint64_t i = 0; i < n; ++i) ends.ids[ti][i] = (2 * frame + 1) * n + i;
    std::vector<Vec3d> start;
    std::vector<std::uint64_t> startIds;
    if (b.fronts[ti].empty()) {
      start = sampleBlade(from, segs);
      for (std::uint64_t i = 0; i < n; ++i) startIds.push_back(2 * frame * n + i);
    } else {
      frontStart(b.fronts[ti], b.cut.deformation, 2 * frame * n, start, startIds, &ends.points[ti]);
    }
    sweeps = sweepStrip(start, startIds, ends.points[ti], ends.ids[ti], frame);
  }
  // Only sweeps that reach the body can cross its links (every voxel lies in the hull of its
  // element's nodes): a blade much longer than the body keeps the few sweeps near it.
  Eigen::AlignedBox3d body;
  for (const Vec3d& x : b.cut.deformation.positions()) body.extend(x);
  body.extend(body.min() - Vec3d::Constant(b.cut.grid.voxelSize()));
  body.extend(body.max() + Vec3d::Constant(b.cut.grid.voxelSize()));
  std::erase_if(sweeps, [&](const BladeSweep& s) {
    return !s.bounds[0].merged(s.bounds[1]).intersects(body);
  });
  return sweeps;
}

// After the cuts: the cut topology, the model's and solver's, and the blades' fronts embedded
// again. Returns whether the topology changed.
bool Simulation::updateTopology(SimBody& b, const std::vector<std::uint64_t>& cut,
                                const BladeEnds& ends) {
  bool topologyChanged = false;
  // Fronts of blades that did not move this frame, where they are now (re-embedded after a
  // topology change, which renumbers elements but moves no material).
  std::vector<std::vector<Vec3d>> still(scene_.tools.size());
  if (!cut.empty()) {
    for (std::size_t ti = 0; ti < scene_.tools.size(); ++ti)
      if (ends.points[ti].empty() && !b.fronts[ti].empty()) {
        std::vector<std::uint64_t> ids;
        frontStart(b.fronts[ti], b.cut.deformation, 0, still[ti], ids);
      }
    const TopologyChange change = updateCutTopology(
        b.cut.deformation, b.cut.grid, cut, CutTopologyParams{b.finestLevel, params_.threaded});
    if (change.changed) {
      topologyChanged = true;
      // The fixed boxes, applied to the new nodes in the same rebuild of the constraints.
      const std::vector<std::uint8_t> fixed =
          b.fixedBoxes.empty() ? std::vector<std::uint8_t>{} : fixedFlags(b);
      b.model.updateTopology(b.cut.deformation, b.cut.grid, change,
                             b.fixedBoxes.empty() ? nullptr : &fixed);
      b.solver.updateTopology(change);
      // The collision's per-entry embeddings, gathered here rather than in next frame's step.
      refreshActiveEmbeddings(b.cut, params_.threaded);
    }
  }
  for (std::size_t ti = 0; ti < scene_.tools.size(); ++ti) {
    if (!ends.points[ti].empty())
      b.fronts[ti] = embedFront(ends.points[ti], ends.ids[ti], b.cut.deformation);
    else if (topologyChanged && !b.fronts[ti].empty())
      b.fronts[ti] = embedFront(still[ti], b.fronts[ti].ids, b.cut.deformation);
  }
  return topologyChanged;
}

// The surface after the cuts, its new vertices embedded (every vertex when elements were
// renumbered).
void Simulation::updateSurface(SimBody& b, const std::vector<std::uint64_t>& cut,
                               bool topologyChanged) {
  const SurfaceDelta delta = b.surface.update(b.cut.grid, cut);
  if (topologyChanged) {
    embedVertices(b, nullptr);  // element ids moved: every vertex looks its element up again
  } else {
    b.embedding.resize(b.surface.vertexSlots());
    b.vertexPositions.resize(b.surface.vertexSlots(), Vec3d::Zero());
    for (std::int32_t v : delta.removedVertices) b.embedding[static_cast<std::size_t>(v)] = {};
    embedVertices(b, &delta.addedVertices);
  }
}

// The solve's counts in the frame's report; a diverged solve is an error.
void Simulation::recordSolve(const StepStatus& status, FrameReport& report) const {
  report.solverIterations += status.iterations;
  report.solverFactorisations += status.factorised ? 1 : 0;
  report.converged = report.converged && status.converged;
  if (!status.finite)
    throw InputError("frame " + std::to_string(frame_) +
                     ": a node position became non-finite (the solve diverged); try a smaller "
                     "time_step or stiffer solver settings");
}

FrameReport Simulation::step() {
  Timer frameTimer;
  FrameReport report;
  report.frame = frame_;
  report.stageMs.assign(kStageCount, 0.0);
  report.obstacleForces.assign(scene_.obstacles.size(), Vec3d::Zero());
  for (SimBody& b : bodies_) stepBody(b, report.stageMs, report);
  ++frame_;
  report.time = frame_ * scene_.timeStep;
  report.totalMs = frameTimer.ms();
  return report;
}

SurfaceMesh Simulation::deformedSurface(std::size_t bi) const {
  const SimBody& b = bodies_[bi];
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

double Simulation::maxDisplacement() const {
  // Over the material (every occupied voxel's centre), not the nodes: a corner of a coarse
  // element that holds a few voxels lies outside the body, and its displacement extrapolates
  // the element's rotation over the empty part.
  double best = 0.0;
  for (const SimBody& b : bodies_) {
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
        params_.threaded);
    for (double m : partial) best = std::max(best, m);
  }
  return best;
}

int Simulation::pieces(std::size_t b) const {
  return findPieces(bodies_[b].cut.grid).count;
}

}  // namespace voxcut
