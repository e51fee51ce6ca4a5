#pragma once
/// @file WorldInternals.h
/// A world's per-body state, for the library's own tests and benchmarks (which check
/// invariants on the deformation octree and the grid). Applications use World.h only: nothing
/// here is a stable interface.

#include <array>
#include <cstdint>
#include <deque>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "voxcut/collision/RestDistance.h"
#include "voxcut/cutting/CutStep.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEuler.h"
#include "voxcut/octree/OctreeSubdivision.h"
#include "voxcut/sim/BladeFront.h"
#include "voxcut/sim/World.h"
#include "voxcut/surface/ContouredSurface.h"

namespace voxcut {

/// Where a surface vertex lives: its element copy and trilinear coordinates there.
struct VertexEmbedding {
  std::uint32_t element = kNoElement;
  Vec3d local = Vec3d::Zero();
};

/// One update of a body's surface topology, kept for World::surfaceChanges.
struct SurfaceLogEntry {
  std::uint64_t revision = 0;  ///< the revision this update made
  SurfaceDelta delta;
};

/// A body's self-collision candidates kept between frames (a Verlet list; docs/algorithms.md,
/// "Object collision"): per element, the other elements, less its own neighbourhood, whose
/// boxes met its query box grown by a skin. They stay a superset of what a fresh query would
/// find while every query box, grown by the farthest any node has moved since, still fits in
/// the grown box it was built with, and no cut has changed the elements.
struct SelfCandidateCache {
  std::vector<Vec3d> nodes;                            ///< node positions when built
  std::vector<Eigen::AlignedBox3d> query;              ///< per element, its grown query box
  std::vector<std::vector<std::uint32_t>> candidates;  ///< per element, ascending
  std::size_t cutLinks = 0;                            ///< the body's cut links when built
  bool valid = false;
};

/// A body's surface vertex slots grouped by the element holding them (a counting sort): the
/// slots in element e are order[start[e]] .. order[start[e + 1] - 1], ascending. Kept between
/// frames; it changes only with the surface's embedding, after cuts.
struct VerticesByElement {
  std::vector<std::uint32_t> start;
  std::vector<std::uint32_t> order;
  std::size_t cutLinks = 0;    ///< the body's cut links when grouped
  std::uint64_t revision = 0;  ///< its surface revision then
  std::size_t slots = 0;       ///< its vertex slots then
  bool valid = false;
};

/// One deformable body of a world.
struct SimBody {
  CutBody cut;                     ///< grid, deformation octree, voxel octree, collision structures
  ElasticModel model;              ///< element matrices, constraints
  ImplicitEuler solver;            ///< velocities
  ContouredSurface surface;        ///< rest frame, updated locally after cuts
  RestDistanceField restDistance;  ///< rest frame, near the boundary, updated after cuts
  std::vector<VertexEmbedding> embedding;  ///< per surface vertex slot
  std::vector<Vec3d> vertexPositions;      ///< per surface vertex slot, current (metres)
  std::vector<Vec3d> vertexNormals;        ///< per surface vertex slot, of normalsFrame
  int normalsFrame = -1;                   ///< frame whose positions vertexNormals are of
  std::uint64_t surfaceRevision = 0;
  std::deque<SurfaceLogEntry> surfaceLog;  ///< the latest topology updates, oldest first
  BodySettings settings;                   ///< materials and fixed boxes as set
  std::vector<ElasticMaterial> elastic;    ///< per grid material (entry 0 unused)
  std::vector<BladeFront> fronts;          ///< per tool: its cut front in this body
  std::vector<int> frontSegments;          ///< per tool: its front's segments (0: not yet)
  double contactStiffness = 0.0;           ///< penalty stiffness per surface vertex (N/m)
  SolverChoice solverChoice = SolverChoice::Cholesky;  ///< its step's (never Automatic)
  std::size_t cutLinks = 0;                ///< links cut so far
  std::vector<LinkCut> cuts;               ///< every cut so far (for the cut set hash)
  SubdivisionWorkspace subdivision;        ///< the cutting step's buffers, kept between frames
  CutWork cutWork;                         ///< the last frame's cutting tool collision work
  SelfCandidateCache selfCandidates;       ///< self collision's broad phase, kept between frames
  VerticesByElement verticesByElement;     ///< for object collision, kept between frames
  /// Start-level cubes (DeformationOctree::cubeKey) cut since they last coarsened, with the
  /// frame of their latest cut (the cut topology stage writes and coarsens them).
  std::unordered_map<std::uint64_t, int> cutRegions;
  /// Regions the node rule refined again while coarsening (written by the same stage); they
  /// coarsen with all others once no region is busy.
  std::unordered_set<std::uint64_t> unsettledRegions;
  bool quietPassDone = true;  ///< no cut since the last pass over every refined region
  /// Start-level regions holding a blade front at the end of the last frame, ascending, and
  /// those of them that held one at the end of the frame before too (the cut stage writes
  /// both; the next frame refines the resting ones).
  std::vector<std::uint64_t> frontRegions, restingRegions;
};

/// The velocity (m/s) of the point with trilinear weights `weight` in element copy `element`
/// of the body: its corners' node velocities interpolated; zero before the first step.
[[nodiscard]] inline Vec3d pointVelocity(const SimBody& body, std::uint32_t element,
                                         const std::array<double, 8>& weight) {
  const std::vector<Vec3d>& velocity = body.solver.velocities();
  Vec3d v = Vec3d::Zero();
  if (velocity.empty()) return v;
  const OctreeElement& el = body.cut.deformation.element(element);
  for (std::size_t c = 0; c < 8; ++c) v += weight[c] * velocity[el.nodes[c]];
  return v;
}

/// Read access to a world's bodies.
struct WorldInternals {
  [[nodiscard]] static const SimBody& body(const World& world, BodyId b);
};

}  // namespace voxcut
