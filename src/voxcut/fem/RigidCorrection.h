#pragma once
/// @file RigidCorrection.h
/// The rigid-mode correction of an implicit Euler step's solve (RigidModes.h;
/// docs/algorithms.md, "Rigid-mode correction") set up for the step's matrix A, and the
/// step's free pieces.
///
/// A piece is free when no element couples it to a node that is not the full prolongation of
/// free nodes (a fixed node, or a hanging node with a fixed master: an "anchored" row) and no
/// point contact presses on it: the reduced stiffness annihilates its translations, so A times
/// a translation c of it is massRow c exactly. The products of A with the modes take those
/// translations as exactly that (the stiffness blocks' round-off times a large common
/// velocity change, a long step or a fast fall, would otherwise act as a force and turn the
/// piece), and the step's start is split the same way, into its free pieces' mass-weighted
/// means and what is left (freePieceMeans).
///
/// Thread-safety: one step at a time per object; results do not depend on the thread count.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/fem/ContactLaw.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/RigidModes.h"
#include "voxcut/linalg/BlockMatrix.h"
#include "voxcut/linalg/RowCoupling.h"

namespace voxcut {

/// The rigid modes of a step's pieces, which pieces are free, and A times the modes.
class RigidCorrection {
 public:
  /// Sets up for the step's matrix `view` of `model` (the free nodes' current positions and
  /// masses, #free each; the mass row of A, StepAssembly::massRow; the step's point
  /// contacts; the pairs' cross terms beside A, borrowed until the next setup).
  void setup(const ElasticModel& model, const BlockMatrixView& view,
             const std::vector<Vec3d>& freePositions, const std::vector<double>& freeMasses,
             const std::vector<double>& massRow, const std::vector<PointContact>& contacts,
             const RowCoupling* coupling);

  /// out_i = the mean of v (#free) over row i's piece, weighted by `massRow`, where that piece
  /// is free; zero elsewhere. After setup.
  void freePieceMeans(const std::vector<Vec3d>& v, const std::vector<double>& massRow,
                      std::vector<Vec3d>& out) const;
  /// Whether the last setup found a free piece.
  [[nodiscard]] bool anyFreePiece() const;

  /// The correction of an iterate x and its residual r (RigidModes::correct). After setup.
  void correct(std::vector<Vec3d>& x, std::vector<Vec3d>& r) const { rigid_.correct(x, r); }
  /// The modes, for a preconditioner's coarse correction (RigidModes::coarseCorrection).
  [[nodiscard]] const RigidModes& modes() const { return rigid_; }

 private:
  /// Per free row: coupled through an element to a node that is not the full prolongation
  /// of free nodes (fixed, or hanging on a fixed master); its piece's translations stiffen.
  std::vector<std::uint8_t> anchoredRow_;
  std::uint64_t anchoredRevision_ = 0;   ///< sparsity revision anchoredRow_ is for
  std::vector<std::uint8_t> freePiece_;  ///< per rigid_ piece: no anchored row, no contact
  RigidModes rigid_;
  std::array<std::vector<Vec3d>, 6> rigidProducts_;  ///< scratch: A times each rigid mode
};

}  // namespace voxcut
