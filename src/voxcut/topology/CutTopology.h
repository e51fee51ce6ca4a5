#pragma once
/// @file CutTopology.h
/// The deformation octree's topology after a cut (docs/algorithms.md, "Cut topology"): elements
/// holding newly cut links are refined down to a finest level keeping the 2:1 rule, every
/// element whose voxels form several connected parts becomes one copy per part, and nodes are
/// duplicated so that copies share a node exactly where their voxels stay connected around it.
///
/// Node rule (our choice). At each node-grid point P, take the element copies whose closed
/// cube contains P: "corner" copies have P as a corner, "coarse" copies have it at an edge
/// midpoint or face centre (2:1 allows nothing else next to a corner copy). Unite two copies
/// of different cubes when their cubes share a face region (which then holds P) and a
/// connected link joins a voxel of one to a voxel of the other. This contains the dual-cell
/// rule: two voxels around P joined by a link of the dual cell at P sit in copies whose cubes
/// share a face through P, so at level 0 the groups at P are exactly the connected components
/// of the dual cell at P. Each group with a corner copy gets one node copy at P, used by its
/// corner copies. A group that also holds a coarse copy makes that node hanging, with the
/// coarse copy's corner nodes at the edge ends or face corners as masters; a fine copy not
/// connected to the coarse element there keeps a free node.
///
/// Why this has no gap where no link is cut: a connected link v-w between copies A and B puts
/// the face of v's and w's cubes inside the smaller of A's and B's faces; A and B are united at
/// every node on it, so they share those nodes, and a node on the coarser face is hanging on
/// the coarser copy's corners, which makes the two trilinear maps agree on the whole face.
/// Why cut pieces separate: copies are united only through connected links, so two copies
/// that share a node lie in one connected piece.
///
/// Where two coarse copies in one group would give a hanging node different masters (a coarse
/// cube whose parts are joined only through finer neighbours), the coarse cubes are refined
/// (keeping 2:1) and the groups recomputed, until every hanging node is unambiguous.
///
/// Thread-safety: the functions here modify the octree; nothing may read it concurrently.
/// Results do not depend on the thread count.

#include <cstdint>
#include <vector>

#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/topology/TopologyChange.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Settings of the topology update after a cut.
struct CutTopologyParams {
  /// Where a cut link's two voxels stay glued (see updateCutTopology), their elements are
  /// refined down to this level at most.
  int finestLevel = 0;
  bool threaded = true;  ///< run the per-cube and per-point loops in parallel
  /// Only refine where a link is glued, and repartition only what was refined: for links cut
  /// in an earlier update (a blade's front resting in an element), whose other leaves are
  /// partitioned already.
  bool refineOnly = false;
};

/// After a cut (docs/algorithms.md, "Cut topology"): the elements holding a voxel of a newly
/// cut link (link id 3*v + axis, VoxelGrid::linkId) keep their level unless the link's two
/// voxels stay *glued* there: in one connected part of their element's cube, or (two cubes)
/// in parts that another connected link joins across the cubes' shared face, so that the two
/// sides share their nodes and the cut could not open. Those are refined, the coarser cube
/// first, until the voxels come apart or params.finestLevel is reached, restoring 2:1 around
/// them; so refinement follows the cut's front (its boundary inside the material), not its
/// area. Then elements are duplicated per connected voxel part and nodes per connected group
/// in the changed region (the cubes refined or holding a cut voxel, and the nodes on them and
/// on the cubes touching those nodes). The links must already be disconnected in `grid`.
///
/// Elements that did not change keep their index and data; new elements fill the slots of the
/// removed ones (ascending) in order of their lowest voxel index, then are appended. Nodes away
/// from the changed region keep their index; freed node slots are reused and, if fewer nodes
/// are needed, filled from the end. Current node positions are carried over: a copied node
/// keeps its source's position, a node created by refinement gets the trilinear interpolation
/// of its old element's current corners, so no voxel moves (a hanging node so placed equals the
/// mean of its masters up to rounding; updateHangingNodes() makes it exact).
///
/// Cost: proportional to the changed region (its cubes' voxels and points) plus O(#elements +
/// #nodes) for the bookkeeping and the clearing of a one-bit-per-point bitmap over the node
/// grid; no pass over the grid's voxels. Several rounds when hanging nodes are ambiguous
/// (each regroups only the points whose surrounding leaves changed). Throws InputError for
/// finestLevel outside [0, 7]. Returns the map from the old elements and nodes to the new ones.
TopologyChange updateCutTopology(DeformationOctree& octree, const VoxelGrid& grid,
                                 const std::vector<std::uint64_t>& newCutLinks,
                                 const CutTopologyParams& params = {});

/// The octree's unchanged map (every element and node its own source).
[[nodiscard]] TopologyChange identityChange(const DeformationOctree& octree);

/// Settings of coarsening after cuts.
struct CoarsenParams {
  int startLevel = 3;    ///< the body's start level: no merge makes an element coarser
  /// The build's surface level (initialFinestLevel): a parent up to this level may always
  /// form; above it only one at least half full, as the build decides.
  int surfaceLevel = 3;
  /// A merge that would put both voxels of a cut link in one part (closing a cut's front
  /// inside the element) goes no coarser than this level.
  int frontLevel = 1;
  bool threaded = true;
};

/// What coarsening did: the change; the regions where a merge was refused only because a
/// finer neighbour (2:1) forbade it, worth trying again later; and the regions (of the start
/// level) where a merge was undone because it made a hanging node ambiguous (a coarse cube
/// whose parts meet only through finer neighbours), which trying again would only repeat.
struct CoarsenResult {
  TopologyChange change;
  std::vector<std::uint64_t> blocked;
  std::vector<std::uint64_t> unsettled;
};

/// Undoes refinement away from the tools (docs/algorithms.md, "Coarsening after cuts"):
/// inside each region (a cube key, DeformationOctree::cubeKey, normally of the start level),
/// the leaves merge bottom up into their parent where (1) the parent is no coarser than
/// params.startLevel and, above params.surfaceLevel, at least half full; (2) no leaf touching
/// the parent is two levels finer (2:1); (3) above params.frontLevel, no cut link inside the
/// parent has both voxels in one of its connected parts. The merged cubes are duplicated per
/// part and their nodes regrouped by the node rule, as after a cut; a new corner node takes
/// its state from the node at that point of the old element holding the part's voxel nearest
/// that corner. Cost: proportional to the regions' voxels and points. Throws InputError for
/// levels outside [0, 7].
CoarsenResult coarsenCutTopology(DeformationOctree& octree, const VoxelGrid& grid,
                                 const std::vector<std::uint64_t>& regions,
                                 const CoarsenParams& params = {});

/// The load-time rule: every element whose voxels form several connected parts becomes one
/// copy per part, and nodes are regrouped by the rule above at every node-grid point (a few
/// cubes may be refined where a hanging node would be ambiguous). buildDeformationOctree calls
/// it when DeformationOctreeParams::splitParts is set. Cost: one pass over the voxels of every
/// element. Returns the map from the octree before to the octree after.
TopologyChange duplicateByParts(DeformationOctree& octree, const VoxelGrid& grid,
                                bool threaded = true);

}  // namespace voxcut
