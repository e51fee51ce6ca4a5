#pragma once
/// @file SimBody.h
/// One deformable body of a world and the records it keeps between frames. Each field of
/// SimBody says which stage of the frame (docs/architecture.md, "One frame") or which call
/// writes it; every other stage only reads it. Internal to the world: applications include
/// World.h only.

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
#include "voxcut/sim/WorldTypes.h"
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
  std::size_t queries = 0;  ///< times built (BodyInfo::selfCandidateQueries)
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

/// One deformable body of a world. "Writes:" names the stages of a frame (World::Impl::runFrame;
/// docs/architecture.md, "One frame") and the calls that change a field; everything else only
/// reads it. "Build" is World::addBody; a snapshot copies every field, and the scratch
/// (`subdivision`) as a fresh one.
struct SimBody {
  /// Grid, deformation octree, voxel octree, collision structures. Writes: build; the cutting
  /// stage (links, Hermite data, the voxel octree and its deferred updates); refinement,
  /// coarsening and the cut topology stage (the deformation octree's elements); the
  /// deformation stage (node positions); World::setUseOctree (the voxel octree).
  CutBody cut;
  /// Element matrices, constraints. Writes: build, the cut topology stage, refinement and
  /// coarsening; World::setMaterial, World::setFixed.
  ElasticModel model;
  /// Velocities, contact forces, preconditioner, warm start. Writes: the deformation stage;
  /// the cut topology stage, refinement and coarsening (its sparsity and node map).
  ImplicitEuler solver;
  /// Rest frame. Writes: build; the surface update stage after cuts.
  ContouredSurface surface;
  /// Rest frame, near the boundary. Writes: build; the surface update stage after cuts.
  RestDistanceField restDistance;
  /// Per surface vertex slot: its element copy and place there. Writes: build; the surface
  /// update stage; every topology change (element ids renumbered).
  std::vector<VertexEmbedding> embedding;
  /// Per surface vertex slot, current (metres). Writes: the surface vertex stage.
  std::vector<Vec3d> vertexPositions;
  /// Per surface vertex slot, of normalsFrame's positions, and that frame. Writes:
  /// World::surface (computed there once a frame, on demand).
  std::vector<Vec3d> vertexNormals;
  int normalsFrame = -1;
  /// The surface's topology revision and its latest updates, oldest first. Writes: the
  /// surface update stage; World::restore (a fresh revision, an empty log).
  std::uint64_t surfaceRevision = 0;
  std::deque<SurfaceLogEntry> surfaceLog;
  /// Materials and fixed boxes as set, and the materials' elastic constants (per grid
  /// material, entry 0 unused). Writes: build; World::setMaterial, World::setFixed.
  BodySettings settings;
  std::vector<ElasticMaterial> elastic;
  /// Per tool: its cut front in this body and the front's segments (0: not yet). Writes: the
  /// cutting stage; refinement and coarsening (fronts embedded again); World::placeTool,
  /// World::addBlade, World::addProbe, World::removeTool.
  std::vector<BladeFront> fronts;
  std::vector<int> frontSegments;
  double contactStiffness = 0.0;  ///< per surface vertex (N/m). Writes: build.
  /// Links cut so far, and every cut (for the cut set hash). Writes: the cutting stage.
  std::size_t cutLinks = 0;
  std::vector<LinkCut> cuts;
  /// The cutting step's buffers, kept between frames (scratch). Writes: the cutting stage.
  SubdivisionWorkspace subdivision;
  CutWork cutWork;  ///< the last frame's cutting work. Writes: the cutting stage.
  /// Self collision's broad phase, kept between frames. Writes: the body contact stage; any
  /// topology change (made invalid).
  SelfCandidateCache selfCandidates;
  /// Surface vertices by element, kept between frames. Writes: the body contact stage; any
  /// topology change (made invalid).
  VerticesByElement verticesByElement;
  /// Start-level cubes (DeformationOctree::cubeKey) cut since they last coarsened, with the
  /// frame of their latest cut. Writes: the cut topology stage (new cuts) and coarsening.
  std::unordered_map<std::uint64_t, int> cutRegions;
  /// Regions the node rule refined again while coarsening; they coarsen with all others once
  /// no region is busy. Writes: coarsening.
  std::unordered_set<std::uint64_t> unsettledRegions;
  /// No cut since the last pass over every refined region. Writes: the cut topology stage,
  /// refinement and coarsening.
  bool quietPassDone = true;
  /// Start-level regions holding a blade front at the end of the last frame, ascending, and
  /// those of them that held one at the end of the frame before too. Writes: the cut
  /// topology stage (the next frame's refinement reads the resting ones).
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

}  // namespace voxcut
