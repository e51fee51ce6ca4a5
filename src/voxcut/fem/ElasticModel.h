#pragma once
/// @file ElasticModel.h
/// Set-up of the composite hexahedral FEM on a deformation octree (docs/algorithms.md,
/// "Corotational FEM"): the
/// material table, every element's rest stiffness and lumped mass (HexElement.h), the nodes'
/// lumped masses, the hanging-node prolongation, fixed nodes, and the 3x3-block sparsity of the
/// reduced system with the plan that gathers it each step. ImplicitEuler.h solves with it.
///
/// Reduced unknowns ("free nodes", in node-grid order): the nodes that are neither hanging, nor
/// fixed, nor unused (referenced by no element holding voxels, directly or as a master). The
/// prolongation P maps free-node values to all nodes: a free node takes its own value, a fixed or
/// unused node zero, a hanging node the mean of its masters' values (chains resolved, coarse
/// first). The solver works with P^T A P, P^T f; positions and velocities of all nodes stay
/// consistent with P.
///
/// Fixed nodes. setFixed takes one flag per node. A hanging node cannot be fixed on its own
/// (it is the mean of its masters), so fixing it fixes its masters, recursively: the fixed set
/// is closed under "master of a fixed hanging node", and every node flagged keeps its position.
///
/// Thread-safety: const member functions may run concurrently; the set-up functions run their
/// loops in parallel (results do not depend on the thread count) and must not run concurrently
/// with anything else on the same model.

#include <Eigen/Sparse>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/fem/HexElement.h"
#include "voxcut/linalg/BlockSparsity.h"
#include "voxcut/linalg/SparseRows.h"
#include "voxcut/linalg/TwoLevelPreconditioner.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/topology/TopologyChange.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Marks a node that is not a reduced unknown (hanging, fixed or unused).
inline constexpr std::uint32_t kNotFree = 0xffffffffu;

/// The composite FEM set-up of one deformation octree. Copyable.
class ElasticModel {
 public:
  ElasticModel() = default;
  /// Computes every element's matrices from the voxels it holds (the occupied voxels v of its
  /// cube with octree.owner(v) == e, each with materials[grid.material(v)]), the node masses,
  /// and the constraints with no fixed node. `grid` is the grid the octree was built on.
  /// Throws InputError for a material outside the table or with invalid constants (E <= 0,
  /// nu outside (-1, 0.5), density <= 0, negative damping). Parallel over elements.
  ElasticModel(const DeformationOctree& octree, const VoxelGrid& grid,
               std::vector<ElasticMaterial> materials, bool threaded = true);

  /// Sets the fixed flags (one per node, non-zero = fixed; a shorter vector leaves the rest
  /// free), closes them over hanging masters (file comment) and rebuilds the constraints.
  void setFixed(std::vector<std::uint8_t> fixed);

  /// Follows a topology update of the octree (`octree` and `grid` as they are after it):
  /// elements with a source keep their matrices, new elements (kNewElement) get theirs
  /// computed; the requested fixed flag of a node becomes `fixed[n]` when given (as
  /// setFixed would take it, in the same rebuild), else "every source node was fixed"; node
  /// masses and the prolongation are recomputed (linear passes). The sparsity is updated: a
  /// row whose whole neighbourhood is unchanged (its nodes, their elements, those elements'
  /// corners and prolongation rows) is copied from the old sparsity with its columns
  /// renumbered; only the rows around the change are gathered anew. The result is identical
  /// to a full rebuild (setFixed). The solver's node state is remapped separately
  /// (ImplicitEuler::updateTopology). No-op when !change.changed.
  void updateTopology(const DeformationOctree& octree, const VoxelGrid& grid,
                      const TopologyChange& change,
                      const std::vector<std::uint8_t>* fixed = nullptr);

  [[nodiscard]] const std::vector<ElasticMaterial>& materials() const { return materials_; }
  [[nodiscard]] std::size_t elementCount() const { return elements_.size(); }
  [[nodiscard]] std::size_t nodeCount() const { return nodeMass_.size(); }
  [[nodiscard]] const ElementMatrices& element(std::uint32_t e) const { return elements_[e]; }
  /// Corner nodes of each element (a copy of the octree's, to check they stay in step).
  [[nodiscard]] const std::vector<std::array<std::uint32_t, 8>>& elementNodes() const {
    return elementNodes_;
  }
  /// Lumped mass of each node (kg), #nodes; hanging nodes keep their own mass (P^T M P moves
  /// it to their masters).
  [[nodiscard]] const std::vector<double>& nodeMass() const { return nodeMass_; }
  /// Lumped alpha-weighted mass of each node (kg/s), #nodes.
  [[nodiscard]] const std::vector<double>& nodeMassDamping() const { return nodeMassDamping_; }
  /// Total mass (kg).
  [[nodiscard]] double totalMass() const;

  /// Fixed flags as requested (#nodes) and as applied (closed over hanging masters).
  [[nodiscard]] const std::vector<std::uint8_t>& requestedFixed() const { return requested_; }
  [[nodiscard]] const std::vector<std::uint8_t>& fixed() const { return fixed_; }

  /// Number of reduced unknowns (free nodes, 3 DOFs each).
  [[nodiscard]] std::size_t freeNodeCount() const { return freeNodes_.size(); }
  /// Free node ids in node-grid order (ascending z, y, x of their node-grid coordinates, then
  /// id); index i is reduced unknown i.
  [[nodiscard]] const std::vector<std::uint32_t>& freeNodes() const { return freeNodes_; }
  /// Reduced index of node n, or kNotFree.
  [[nodiscard]] std::uint32_t freeIndex(std::uint32_t n) const { return freeIndex_[n]; }
  /// P by rows: node n's value = sum weight * value of free node index.
  [[nodiscard]] const WeightedRows& prolongation() const { return prolongation_; }
  /// P^T by rows: free node i collects weight * value of node index, node ids ascending.
  [[nodiscard]] const WeightedRows& restriction() const { return restriction_; }
  /// Element corners at each node: row n lists 8 e + c for every corner c of element e that
  /// is node n, ascending (weights unused, 1).
  [[nodiscard]] const WeightedRows& incidence() const { return incidence_; }
  /// The reduced system's 3x3-block sparsity, one row per free node, with its assembly plan:
  /// a source id below 64 * #elements is the element block 64 e + 8 a + b (corners a, b of
  /// element e); an id 64 * #elements + n is node n's lumped mass (times the identity); each
  /// with a weight (products of prolongation weights).
  [[nodiscard]] const BlockSparsity& sparsity() const { return sparsity_; }
  /// Changes whenever sparsity() is rebuilt or updated (unique across models; copies share
  /// it), so that a solver can keep structures derived from the sparsity (the IC(0) pattern
  /// of PreconditionerChoice.h).
  [[nodiscard]] std::uint64_t sparsityRevision() const { return sparsityRevision_; }
  /// Rows of the last sparsity build that were copied from the one before (updateTopology)
  /// rather than gathered anew; 0 after a full build.
  [[nodiscard]] std::size_t sparsityRowsReused() const { return sparsityRowsReused_; }
  /// The aggregates of the free nodes for the two-level preconditioner
  /// (linalg/TwoLevelPreconditioner.h), for the current sparsity(): made by the first call after
  /// each rebuild (a cost that a step preconditioned otherwise does not pay). That first call must
  /// not run concurrently with another.
  [[nodiscard]] const NodeAggregation& aggregation() const;
  [[nodiscard]] bool threaded() const { return threaded_; }

 private:
  void computeElements(const DeformationOctree& octree, const VoxelGrid& grid,
                       const std::vector<std::uint32_t>& which);
  void copyNodeCoords(const DeformationOctree& octree);
  void buildNodeData();
  struct SparsityReuse;
  void buildConstraints();
  /// The rows of the last build that updateTopology can copy (see there), from the model as
  /// it was before (its prolongation, incidence and free nodes, moved out of this one).
  [[nodiscard]] SparsityReuse sparsityReuse(const TopologyChange& change,
                                            const WeightedRows& oldProlongation,
                                            const WeightedRows& oldRestriction,
                                            const WeightedRows& oldIncidence,
                                            const std::vector<std::uint32_t>& oldFreeNodes,
                                            std::size_t oldElementCount) const;
  void buildSparsity(const SparsityReuse* reuse);

  std::vector<ElasticMaterial> materials_;
  bool threaded_ = true;
  std::vector<ElementMatrices> elements_;
  /// Matrices of an element full of one material, per level * #materials + material, made
  /// on first need (fullElementMade_).
  std::vector<ElementMatrices> fullElements_;
  std::vector<std::uint8_t> fullElementMade_;
  std::vector<std::array<std::uint32_t, 8>> elementNodes_;
  std::vector<HangingNode> hanging_;
  std::vector<Index3> nodeCoord_;  ///< node-grid coordinates, orders the unknowns
  std::vector<double> nodeMass_;
  std::vector<double> nodeMassDamping_;
  std::vector<std::uint8_t> requested_;
  std::vector<std::uint8_t> fixed_;
  std::vector<std::uint32_t> freeNodes_;
  std::vector<std::uint32_t> freeIndex_;
  WeightedRows prolongation_;
  WeightedRows restriction_;
  WeightedRows incidence_;
  BlockSparsity sparsity_;
  std::uint64_t sparsityRevision_ = 0;
  std::size_t sparsityRowsReused_ = 0;
  mutable NodeAggregation aggregation_;
  mutable std::uint64_t aggregationRevision_ = 0;  ///< sparsity revision aggregation_ is for
};

/// Corotated elastic forces on every node (N), #nodes: f = -sum_e R_e K_e y_e with y_e the
/// corotated displacement (HexElement.h) of the octree's current positions. Not reduced
/// (hanging nodes get their own share). Zero at rest and for rigid motions (to round-off).
/// Parallel over nodes, deterministic.
[[nodiscard]] std::vector<Vec3d> elasticForces(const ElasticModel& model,
                                               const DeformationOctree& octree);

/// Corotated elastic energy (J): sum_e 1/2 y_e^T K_e y_e. Deterministic.
[[nodiscard]] double elasticEnergy(const ElasticModel& model, const DeformationOctree& octree);

/// The rest stiffness over all nodes (N/m), 3 #nodes square, DOF 3 n + axis.
[[nodiscard]] Eigen::SparseMatrix<double> restStiffnessMatrix(const ElasticModel& model);

/// The prolongation P, 3 #nodes x 3 #free.
[[nodiscard]] Eigen::SparseMatrix<double> prolongationMatrix(const ElasticModel& model);

}  // namespace voxcut
