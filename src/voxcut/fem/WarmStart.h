#pragma once
/// @file WarmStart.h
/// Where each implicit Euler step's solve starts (ImplicitEuler.h; docs/algorithms.md,
/// "Implicit Euler" and "Projection onto earlier solutions"): the previous step's velocity
/// change dv, or, while solves take many iterations, the best combination in the energy norm
/// of the last few solutions (linalg/SolutionProjection.h). Both follow topology changes as
/// the velocities do.
///
/// The kept solutions are by free row of the sparsity of the last solve, or by node after a
/// topology change (until the next solve takes them to its rows). They are kept less their
/// free pieces' mass-weighted means (RigidCorrection.h), as the start they are combined for is.
///
/// Thread-safety: one step at a time per object.

#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEulerParams.h"
#include "voxcut/linalg/BlockMatrix.h"
#include "voxcut/linalg/RowCoupling.h"
#include "voxcut/linalg/SolutionProjection.h"
#include "voxcut/topology/TopologyChange.h"

namespace voxcut {

/// Remaps per-node values through a topology change: node n takes the weighted sum of its
/// sources' values (zero without sources). Empty values stay empty.
void remapByNode(const TopologyChange& change, std::vector<Vec3d>& values);

/// The previous step's dv and the kept solutions.
class WarmStart {
 public:
  /// Sizes the previous dv for `model` (zero when there is none yet); it must then match.
  void resize(const ElasticModel& model);
  /// Forgets the previous dv and the kept solutions.
  void reset();
  /// Remaps the previous dv and the kept solutions through a topology change (changed).
  void updateTopology(const TopologyChange& change);

  /// The previous step's dv, per node.
  [[nodiscard]] const std::vector<Vec3d>& previous() const { return lastDv_; }
  /// Keeps a step's solution `x` (per free row of `freeNodes`) as the next step's start.
  void keep(const std::vector<std::uint32_t>& freeNodes, const std::vector<Vec3d>& x);
  /// After a step that moved nothing: the next one starts from zero.
  void forget();

  /// Takes the kept solutions to the free rows of `model` (which become theirs) and, when the
  /// last solve asked for it (and params.warmStart), projects the start onto them: q (#free)
  /// becomes their best combination for A q = b - massRow shift (A `view` plus `coupling`,
  /// which may be null), and x = shift + q. Returns whether it projected.
  bool project(const ElasticModel& model, const ImplicitEulerParams& params,
               const BlockMatrixView& view, const RowCoupling* coupling,
               const std::vector<Vec3d>& b, const std::vector<double>& massRow,
               const std::vector<Vec3d>& shift, std::vector<Vec3d>& q, std::vector<Vec3d>& x,
               bool threaded);

  /// After a solve of `iterations` (projected or not): decides whether the next one starts
  /// projected, and keeps `solution` (#free, less its free pieces' means; null: none to
  /// keep) among the last `history` solutions.
  void finishSolve(int history, bool projected, int iterations,
                   const std::vector<Vec3d>* solution);

 private:
  /// The kept solutions from the free rows of the last solve to nodes.
  void projectionToNodes();

  std::vector<Vec3d> lastDv_;  ///< per node, the warm start
  /// Earlier solutions less their free pieces' means: by free row of the sparsity of the last
  /// solve, or by node after a topology change (until the next solve takes them to its rows).
  SolutionProjection projection_;
  bool projectionByNode_ = false;
  std::uint64_t projectionRevision_ = 0;      ///< sparsity of the kept solutions' rows
  bool projecting_ = false;                   ///< whether the next solve starts projected
  std::vector<std::uint32_t> lastFreeNodes_;  ///< the rows of the kept solutions
  std::size_t lastNodeCount_ = 0;
  std::vector<Vec3d> projectionRhs_;
};

}  // namespace voxcut
