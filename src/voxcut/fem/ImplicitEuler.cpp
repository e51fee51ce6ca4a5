#include "voxcut/fem/ImplicitEuler.h"

#include <algorithm>
#include <optional>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/linalg/ChunkedSum.h"

namespace voxcut {

namespace {

/// P applied to reduced values: out[n] = sum over node n's prolongation row.
void prolong(const WeightedRows& p, const std::vector<Vec3d>& reduced, std::vector<Vec3d>& out,
             bool threaded) {
  parallelFor(
      0, p.rows(), 512,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t n = b; n < e; ++n) {
          Vec3d s = Vec3d::Zero();
          for (std::uint32_t k = p.start[n]; k < p.start[n + 1]; ++k)
            s += p.weight[k] * reduced[p.index[k]];
          out[n] = s;
        }
      },
      threaded);
}

}  // namespace

void ImplicitEuler::setContacts(std::vector<PointContact> contacts) {
  contacts_.setPoints(std::move(contacts));
}

void ImplicitEuler::setPairContacts(std::vector<PairContact> pairs) {
  contacts_.setPairs(std::move(pairs));
}

void ImplicitEuler::reset() {
  velocity_.clear();
  warmStart_.reset();
}

void ImplicitEuler::updateTopology(const TopologyChange& change) {
  if (!change.changed) return;
  remapByNode(change, velocity_);
  warmStart_.updateTopology(change);
  preconditioners_.updateTopology(change);
}

double ImplicitEuler::kineticEnergy(const ElasticModel& model) const {
  if (velocity_.empty()) return 0.0;
  VOXCUT_ASSERT(velocity_.size() == model.nodeCount(), "velocities do not match the model");
  double sum = 0.0;
  for (std::size_t n = 0; n < velocity_.size(); ++n)
    sum += 0.5 * model.nodeMass()[n] * velocity_[n].squaredNorm();
  return sum;
}

Eigen::SparseMatrix<double> ImplicitEuler::reducedMatrix(const ElasticModel& model) const {
  return assembly_.reducedMatrix(model);
}

void ImplicitEuler::resize(const ElasticModel& model) {
  const std::size_t nodes = model.nodeCount(), free = model.freeNodeCount();
  if (velocity_.empty()) velocity_.assign(nodes, Vec3d::Zero());
  VOXCUT_ASSERT(velocity_.size() == nodes,
                "velocities do not match the model (missing updateTopology?)");
  warmStart_.resize(model);
  assembly_.resize(model);
  for (auto* v : {&x_, &r_, &q_, &vr_, &shift_}) v->resize(free);
}

bool ImplicitEuler::startSolve(const ElasticModel& model, const BlockMatrixView& view,
                              StepParts& parts) {
  const bool threaded = model.threaded();
  const std::size_t rows = model.freeNodeCount();
  const std::vector<Vec3d>& rhs = assembly_.rhs();
  const std::vector<double>& massRow = assembly_.massRow();
  const RowCoupling& coupling = contacts_.coupling();
  const Eigen::Matrix3d* blocks = view.blocks;
  const std::uint32_t* column = view.column;
  const std::uint32_t* rowStart = view.rowStart;
  // Row i of A x (the arrays held in locals: the products are the hot loop).
  auto multiply = [&](const std::vector<Vec3d>& in, std::size_t i) {
    return blockRowProduct(blocks, column, in.data(), rowStart[i], rowStart[i + 1]);
  };
  // The rigid-mode correction (RigidCorrection.h) of the start, and again of the result: A
  // times the modes is made once for both. The warm start is split into its free pieces'
  // mass-weighted means (shift_) and what is left.
  Timer timer;
  std::fill(shift_.begin(), shift_.end(), Vec3d::Zero());
  if (params_.rigidCorrection) {
    rigid_.setup(model, view, freePositions_, freeMasses_, massRow, contacts_.points(), &coupling);
    rigid_.freePieceMeans(x_, massRow, shift_);
  }
  parts.rigid += timer.ms();
  timer.restart();
  // r = b - A x0 (corrected); q holds x0 less its shift meanwhile.
  parallelFor(
      0, rows, 256,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) q_[i] = x_[i] - shift_[i];
      },
      threaded);
  // The earlier solutions are kept less their free pieces' means, as q is: the start's part
  // other than the shift is their best combination for A q = b - A shift.
  const bool projected = warmStart_.project(model, params_, view, &coupling, rhs, massRow, shift_,
                                            q_, x_, threaded);
  parallelFor(
      0, rows, 256,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i)
          r_[i] = rhs[i] - multiply(q_, i) - massRow[i] * shift_[i];
      },
      threaded);
  if (!coupling.empty()) {  // r -= X q (the shift is a translation of free pieces, which
                            // hold no pair: X shift = 0)
    coupling.multiplySubtract(q_, r_, threaded);
  }
  parts.projection += timer.ms();
  timer.restart();
  if (params_.rigidCorrection) rigid_.correct(x_, r_);
  parts.rigid += timer.ms();
  return projected;
}

void ImplicitEuler::finishSolve(const ConjugateGradientStatus& cg, bool projected,
                                StepStatus& status) {
  status.iterations = cg.iterations;
  status.residual = cg.residual;
  status.converged = cg.converged;
  status.finite = cg.finite;
  const bool correctRigid = params_.rigidCorrection;
  Timer timer;
  if (correctRigid && cg.finite) {
    rigid_.correct(x_, r_);
    for (const Vec3d& v : x_) status.finite = status.finite && v.allFinite();
  }
  status.parts.rigid += timer.ms();
  timer.restart();
  const int history = params_.projectionHistory;
  const std::vector<Vec3d>* kept = nullptr;
  if (status.finite && history > 0) {
    // Kept less its free pieces' means (q_ is free now).
    if (correctRigid && rigid_.anyFreePiece()) {
      rigid_.freePieceMeans(x_, assembly_.massRow(), shift_);
      for (std::size_t i = 0; i < x_.size(); ++i) q_[i] = x_[i] - shift_[i];
      kept = &q_;
    } else {
      kept = &x_;
    }
  }
  warmStart_.finishSolve(history, projected, cg.iterations, kept);
  status.parts.advance += timer.ms();
}

StepStatus ImplicitEuler::solve(const ElasticModel& model) {
  const bool threaded = model.threaded();
  const std::size_t rows = model.freeNodeCount();
  const BlockMatrixView view = model.sparsity().view(assembly_.blocks());
  VOXCUT_ASSERT(view.rows == rows, "the sparsity does not match the free nodes");
  StepStatus status;
  status.preconditioner = params_.preconditioner;
  const std::vector<Vec3d>& rhs = assembly_.rhs();
  const std::vector<Vec3d>& previous = warmStart_.previous();
  const double bb = chunkedSum(rows, partial_, threaded, [&](std::size_t i) {
    x_[i] = params_.warmStart ? previous[model.freeNodes()[i]] : Vec3d::Zero();
    return rhs[i].squaredNorm();
  });
  if (const std::optional<ConjugateGradientStatus> trivial =
          ConjugateGradients::trivialSolve(bb, x_)) {
    status.finite = trivial->finite;
    status.converged = trivial->converged;
    return status;
  }
  const bool projected = startSolve(model, view, status.parts);
  // The conjugate gradients (linalg/ConjugateGradients.h) from this start and its residual,
  // on the preconditioner this step chooses (PreconditionerChoice.h).
  cg_.setOperator(view, threaded);
  cg_.setCoupling(&contacts_.coupling());
  cg_.setParams({params_.tolerance, params_.maxIterations});
  const bool coarse = !contacts_.coupling().empty() && params_.rigidCorrection;
  const PreconditionerChoice::Inputs inputs{model,
                                            params_,
                                            assembly_.blocks(),
                                            assembly_.diagonalInverse(),
                                            freePositions_,
                                            coarse ? &rigid_.modes() : nullptr};
  Timer timer;
  const ConjugateGradientStatus cg = preconditioners_.iterate(cg_, inputs, bb, x_, r_, status);
  // The preconditioner's set-up happens inside the iteration (once one is needed).
  status.parts.iterations += std::max(0.0, timer.ms() - status.parts.setup);
  finishSolve(cg, projected, status);
  return status;
}

void ImplicitEuler::advance(const ElasticModel& model, DeformationOctree& octree) {
  const bool threaded = model.threaded();
  const std::vector<std::uint32_t>& freeNodes = model.freeNodes();
  for (std::size_t i = 0; i < freeNodes.size(); ++i) vr_[i] += x_[i];
  warmStart_.keep(freeNodes, x_);
  prolong(model.prolongation(), vr_, velocity_, threaded);
  const double dt = params_.timeStep;
  contacts_.finish(octree, velocity_, dt, true);
  std::vector<Vec3d>& pos = octree.positions();
  parallelFor(
      0, pos.size(), 512,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t n = b; n < e; ++n)
          if (!octree.isHanging(static_cast<std::uint32_t>(n))) pos[n] += dt * velocity_[n];
      },
      threaded);
  octree.updateHangingNodes();
}

StepStatus ImplicitEuler::step(const ElasticModel& model, DeformationOctree& octree) {
  VOXCUT_ASSERT(
      model.elementCount() == octree.elementCount() && model.nodeCount() == octree.nodeCount(),
      "the model does not match the octree (missing updateTopology?)");
  VOXCUT_ASSERT(params_.timeStep > 0.0 && params_.maxIterations >= 0, "bad step settings");
  Timer timer;
  resize(model);
  const bool threaded = model.threaded();
  const std::vector<std::uint32_t>& freeNodes = model.freeNodes();
  // Project the velocities through P: fixed and unused nodes at rest, hanging nodes at their
  // masters' mean.
  for (std::size_t i = 0; i < freeNodes.size(); ++i) vr_[i] = velocity_[freeNodes[i]];
  prolong(model.prolongation(), vr_, velocity_, threaded);
  // The rigid modes' and the two-level coarse space's rotations.
  freePositions_.resize(freeNodes.size());
  freeMasses_.resize(freeNodes.size());
  for (std::size_t i = 0; i < freeNodes.size(); ++i) {
    freePositions_[i] = octree.positions()[freeNodes[i]];
    freeMasses_[i] = model.nodeMass()[freeNodes[i]];
  }
  preconditioners_.beginStep(model, octree, params_, contacts_.any());
  contacts_.prepare(model, octree, velocity_, params_.timeStep);
  const double prepareMs = timer.ms();
  timer.restart();
  assembly_.assemble(model, octree, velocity_, contacts_, params_);
  const double assemblyMs = timer.ms();
  timer.restart();
  StepStatus status = solve(model);
  status.assemblyMs = assemblyMs;
  status.solveMs = timer.ms();
  status.parts.prepare = prepareMs;
  status.parts.assembly = assemblyMs;
  timer.restart();
  preconditioners_.endStep(status);
  if (!status.finite) {
    warmStart_.forget();
    contacts_.finish(octree, velocity_, params_.timeStep, false);
    status.parts.advance += timer.ms();
    return status;
  }
  advance(model, octree);
  status.parts.advance += timer.ms();
  return status;
}

}  // namespace voxcut
