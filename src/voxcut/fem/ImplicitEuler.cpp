#include "voxcut/fem/ImplicitEuler.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/fem/Corotation.h"
#include "voxcut/linalg/BlockPreconditioner.h"
#include "voxcut/linalg/ChunkedSum.h"

namespace voxcut {

namespace {

/// Corner pair (a, b), a <= b, of an element -> its block among the element's 36 upper ones,
/// row by row: (0,0) .. (0,7), (1,1) .. (1,7), ..., (7,7).
constexpr std::array<std::array<std::uint8_t, 8>, 8> kUpperBlock = [] {
  std::array<std::array<std::uint8_t, 8>, 8> t{};
  std::uint8_t next = 0;
  for (int a = 0; a < 8; ++a)
    for (int b = a; b < 8; ++b) t[a][b] = t[b][a] = next++;
  return t;
}();

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

/// Per free row of `model`: 1 when an element holding voxels couples it to a node whose
/// prolongation row does not sum to one (a fixed node, or a hanging node with a fixed
/// master). The reduced stiffness annihilates the translations of a piece without such rows
/// (docs/algorithms.md, "Rigid-mode correction").
std::vector<std::uint8_t> anchoredRows(const ElasticModel& model) {
  const WeightedRows& p = model.prolongation();
  std::vector<std::uint8_t> deficient(model.nodeCount(), 0);
  for (std::size_t n = 0; n < model.nodeCount(); ++n) {
    double sum = 0.0;
    for (std::uint32_t k = p.start[n]; k < p.start[n + 1]; ++k) sum += p.weight[k];
    deficient[n] = std::abs(sum - 1.0) > 1e-9 ? 1 : 0;
  }
  std::vector<std::uint8_t> anchored(model.freeNodeCount(), 0);
  for (std::size_t e = 0; e < model.elementCount(); ++e) {
    if (!(model.element(static_cast<std::uint32_t>(e)).volume > 0.0)) continue;
    const auto& corners = model.elementNodes()[e];
    if (std::none_of(corners.begin(), corners.end(), [&](std::uint32_t n) { return deficient[n]; }))
      continue;
    for (std::uint32_t n : corners)
      for (std::uint32_t k = p.start[n]; k < p.start[n + 1]; ++k) anchored[p.index[k]] = 1;
  }
  return anchored;
}

}  // namespace

const char* preconditionerName(PreconditionerKind p) {
  switch (p) {
    case PreconditionerKind::Jacobi:
      return "jacobi";
    case PreconditionerKind::BlockJacobi:
      return "block_jacobi";
    case PreconditionerKind::SymmetricGaussSeidel:
      return "symmetric_gauss_seidel";
    case PreconditionerKind::IncompleteCholesky:
      return "incomplete_cholesky";
    case PreconditionerKind::TwoLevel:
      return "two_level";
    case PreconditionerKind::Cholesky:
      return "cholesky";
    case PreconditionerKind::Multigrid:
      return "multigrid";
  }
  return "unknown";
}

void ImplicitEuler::setContacts(std::vector<PointContact> contacts) {
  contacts_ = std::move(contacts);
}

void ImplicitEuler::setPairContacts(std::vector<PairContact> pairs) { pairs_ = std::move(pairs); }

void ImplicitEuler::reset() {
  velocity_.clear();
  lastDv_.clear();
  projection_.clear();
  projectionByNode_ = false;
  projecting_ = false;
}

void ImplicitEuler::updateTopology(const TopologyChange& change) {
  if (!change.changed) return;
  auto remap = [&](std::vector<Vec3d>& values) {
    if (values.empty()) return;
    std::vector<Vec3d> next(change.nodeSource.size(), Vec3d::Zero());
    for (std::size_t n = 0; n < next.size(); ++n) {
      const NodeSource& src = change.nodeSource[n];
      for (int k = 0; k < src.count; ++k) {
        VOXCUT_ASSERT(src.nodes[k] < values.size(), "node source out of range");
        next[n] += src.weights[k] * values[src.nodes[k]];
      }
    }
    values = std::move(next);
  };
  remap(velocity_);
  remap(lastDv_);
  // The kept solutions follow as the velocities do, by node (their free rows are known at the
  // next solve).
  if (!projectionByNode_) projectionToNodes();
  projection_.transform(remap);
  bridge_.update(change);
  bridgeRevision_ = 0;
}

void ImplicitEuler::projectionToNodes() {
  projection_.transform([&](std::vector<Vec3d>& h) {
    std::vector<Vec3d> byNode(lastNodeCount_, Vec3d::Zero());
    for (std::size_t i = 0; i < h.size() && i < lastFreeNodes_.size(); ++i)
      byNode[lastFreeNodes_[i]] = h[i];
    h = std::move(byNode);
  });
  projectionByNode_ = projection_.size() > 0;
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
  const std::size_t rows = model.freeNodeCount();
  const BlockSparsity& sp = model.sparsity();
  if (blocks_.size() != sp.blockCount() || preconditioner_.size() != rows) return {};
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(9 * sp.blockCount());
  for (std::size_t i = 0; i < rows; ++i)
    for (std::uint32_t slot = sp.rowStart[i]; slot < sp.rowStart[i + 1]; ++slot)
      for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c)
          entries.emplace_back(static_cast<int>(3 * i) + a,
                               static_cast<int>(3 * sp.column[slot]) + c, blocks_[slot](a, c));
  Eigen::SparseMatrix<double> m(static_cast<Eigen::Index>(3 * rows),
                                static_cast<Eigen::Index>(3 * rows));
  m.setFromTriplets(entries.begin(), entries.end());
  return m;
}

void ImplicitEuler::resize(const ElasticModel& model) {
  const std::size_t nodes = model.nodeCount(), free = model.freeNodeCount();
  if (velocity_.empty()) velocity_.assign(nodes, Vec3d::Zero());
  if (lastDv_.empty()) lastDv_.assign(nodes, Vec3d::Zero());
  VOXCUT_ASSERT(velocity_.size() == nodes && lastDv_.size() == nodes,
                "velocities do not match the model (missing updateTopology?)");
  elementBlocks_.resize(36 * model.elementCount());
  elementForce_.resize(model.elementCount());
  nodeDiagonal_.resize(nodes);
  nodeRhs_.resize(nodes);
  blocks_.resize(model.sparsity().blockCount());
  preconditioner_.resize(free);
  for (auto* v : {&b_, &x_, &r_, &q_, &vr_, &shift_}) v->resize(free);
  massRow_.resize(free);
}

void ImplicitEuler::assemble(const ElasticModel& model, const DeformationOctree& octree) {
  const bool threaded = model.threaded();
  const double dt = params_.timeStep;
  // Elements: rotation, right-hand side force R K (y + (beta + dt) R^T v) and the rotated,
  // scaled stiffness blocks (dt beta + dt^2) R K_ab R^T.
  parallelFor(
      0, model.elementCount(), 32,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t e = b; e < end; ++e) {
          const ElementMatrices& em = model.element(static_cast<std::uint32_t>(e));
          const OctreeElement& el = octree.element(static_cast<std::uint32_t>(e));
          const Corotation co = corotation(octree, static_cast<std::uint32_t>(e), em.gradientMean);
          const Eigen::Matrix3d& r = co.rotation;
          Eigen::Matrix<double, 24, 1> y = co.displacement;
          // K annihilates translations, so the element's mean velocity is taken out first:
          // the round-off of K times a large common velocity (a long fall) would otherwise
          // act as a force that grows with the speed, and turn the body.
          const double damp = em.stiffnessDamping + dt;
          Vec3d meanVelocity = Vec3d::Zero();
          for (std::size_t c = 0; c < 8; ++c) meanVelocity += velocity_[el.nodes[c]];
          meanVelocity *= 0.125;
          for (std::size_t c = 0; c < 8; ++c)
            y.segment<3>(3 * static_cast<Eigen::Index>(c)) +=
                damp * (r.transpose() * (velocity_[el.nodes[c]] - meanVelocity));
          const Eigen::Matrix<double, 24, 1> ky = em.stiffness * y;
          for (std::size_t c = 0; c < 8; ++c)
            elementForce_[e][c] = -(r * ky.segment<3>(3 * static_cast<Eigen::Index>(c)));
          const Eigen::Matrix3d cr = (dt * em.stiffnessDamping + dt * dt) * r;
          const Eigen::Matrix3d rt = r.transpose();
          // The 36 blocks on and above the diagonal, in kUpperBlock order; the gather below
          // reads a block below the diagonal as its mirror's transpose.
          Eigen::Matrix3d* out = &elementBlocks_[36 * e];
          for (int a = 0; a < 8; ++a)
            for (int c = a; c < 8; ++c) {
              // Fixed-size products into named 3x3s: no temporaries of dynamic size.
              Eigen::Matrix3d krt;
              krt.noalias() = em.stiffness.block<3, 3>(3 * a, 3 * c) * rt;
              (out++)->noalias() = cr * krt;
            }
          // The element's point contacts: force -k (gap + dt n . v_p) n spread by the weights
          // (times dt below, like the elastic force), stiffness dt^2 k (w_a w_c) n n^T.
          const std::uint32_t firstContact = contacts_.empty() ? 0 : contactStart_[e];
          const std::uint32_t endContact = contacts_.empty() ? 0 : contactStart_[e + 1];
          for (std::uint32_t k = firstContact; k < endContact; ++k) {
            const PointContact& pc = contacts_[k];
            Vec3d vp = Vec3d::Zero();
            for (std::size_t c = 0; c < 8; ++c) vp += pc.weight[c] * velocity_[el.nodes[c]];
            const double f = -pc.stiffness * (pc.gap + dt * pc.normal.dot(vp));
            for (std::size_t c = 0; c < 8; ++c)
              elementForce_[e][c] += (pc.weight[c] * f) * pc.normal;
            Eigen::Matrix3d nn = (dt * dt * pc.stiffness) * pc.normal * pc.normal.transpose();
            if (pc.friction > 0.0) {
              // The tangential damper: force -c P (v_p - u), P = I - n n^T, matrix dt c P.
              const Eigen::Matrix3d tangent =
                  Eigen::Matrix3d::Identity() - pc.normal * pc.normal.transpose();
              const Vec3d ft = -pc.friction * (tangent * (vp - pc.surfaceVelocity));
              for (std::size_t c = 0; c < 8; ++c) elementForce_[e][c] += pc.weight[c] * ft;
              nn += (dt * pc.friction) * tangent;
            }
            for (int a = 0; a < 8; ++a)
              for (int c = a; c < 8; ++c)
                elementBlocks_[36 * e + kUpperBlock[a][c]] +=
                    (pc.weight[static_cast<std::size_t>(a)] *
                     pc.weight[static_cast<std::size_t>(c)]) *
                    nn;
          }
        }
      },
      threaded);

  // Nodes: dt (M g - alpha M v + f), gathered from incident corners in a fixed order.
  const WeightedRows& inc = model.incidence();
  const Vec3d g = params_.gravity;
  parallelFor(
      0, model.nodeCount(), 256,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t n = b; n < end; ++n) {
          const double m = model.nodeMass()[n], d = model.nodeMassDamping()[n];
          nodeDiagonal_[n] = m + dt * d;
          Vec3d f = m * g - d * velocity_[n];
          for (std::uint32_t k = inc.start[n]; k < inc.start[n + 1]; ++k)
            f += elementForce_[inc.index[k] / 8][inc.index[k] % 8];
          nodeRhs_[n] = dt * f;
        }
      },
      threaded);

  // Reduced rows: P^T b and the blocks of P^T A P on and above the diagonal, each summed over
  // its sources in order; the blocks below are their mirrors' transposes (A is symmetric, and
  // so exactly symmetric in floating point too).
  const WeightedRows& res = model.restriction();
  const BlockSparsity& sp = model.sparsity();
  const std::vector<std::uint32_t>& mirror = sp.mirror;
  const auto massBase = static_cast<std::uint32_t>(64 * model.elementCount());
  const bool block = params_.preconditioner != PreconditionerKind::Jacobi;
  const auto sourceEnd = static_cast<std::uint32_t>(sp.source.size());
  const auto slotEnd = static_cast<std::uint32_t>(mirror.size());
  constexpr std::uint32_t kGatherAhead = 16;
  parallelFor(
      0, model.freeNodeCount(), 128,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t i = b; i < end; ++i) {
          Vec3d s = Vec3d::Zero();
          for (std::uint32_t k = res.start[i]; k < res.start[i + 1]; ++k)
            s += res.weight[k] * nodeRhs_[res.index[k]];
          b_[i] = s;
          double mass = 0.0;
          for (std::uint32_t k = res.start[i]; k < res.start[i + 1]; ++k)
            mass += res.weight[k] * nodeDiagonal_[res.index[k]];
          massRow_[i] = mass;
          for (std::uint32_t slot = sp.diagonal[i]; slot < sp.rowStart[i + 1]; ++slot) {
            Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
            for (std::uint32_t k = sp.sourceStart[slot]; k < sp.sourceStart[slot + 1]; ++k) {
              // The element blocks are read in an order the hardware cannot foresee: ask for
              // the one a few sources ahead now.
              if (k + kGatherAhead < sourceEnd) {
                const std::uint32_t ahead = sp.source[k + kGatherAhead];
                if (ahead < massBase) {
                  const auto* p = reinterpret_cast<const char*>(
                      elementBlocks_[36 * (ahead >> 6) + kUpperBlock[(ahead >> 3) & 7u][ahead & 7u]]
                          .data());
                  __builtin_prefetch(p);
                  __builtin_prefetch(p + 64);
                }
              }
              const std::uint32_t src = sp.source[k];
              if (src < massBase) {  // element src / 64, corners (src / 8) % 8 and src % 8
                const std::uint32_t a = (src >> 3) & 7u, c = src & 7u;
                const Eigen::Matrix3d& blk = elementBlocks_[36 * (src >> 6) + kUpperBlock[a][c]];
                if (a <= c)
                  sum.noalias() += sp.sourceWeight[k] * blk;
                else
                  sum.noalias() += sp.sourceWeight[k] * blk.transpose();
              } else
                sum.diagonal().array() += sp.sourceWeight[k] * nodeDiagonal_[src - massBase];
            }
            blocks_[slot] = sum;
          }
          const Eigen::Matrix3d& diag = blocks_[sp.diagonal[i]];
          if (block) {
            preconditioner_[i] = diag.inverse();
          } else {
            preconditioner_[i] = Eigen::Matrix3d::Zero();
            for (int a = 0; a < 3; ++a) preconditioner_[i](a, a) = 1.0 / diag(a, a);
          }
        }
      },
      threaded);
  parallelFor(
      0, model.freeNodeCount(), 256,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t i = b; i < end; ++i)
          for (std::uint32_t slot = sp.rowStart[i]; slot < sp.diagonal[i]; ++slot) {
            if (slot + kGatherAhead < slotEnd) {  // as above: mirrors lie anywhere
              const auto* p =
                  reinterpret_cast<const char*>(blocks_[mirror[slot + kGatherAhead]].data());
              __builtin_prefetch(p);
              __builtin_prefetch(p + 64);
            }
            blocks_[slot] = blocks_[mirror[slot]].transpose();
          }
      },
      threaded);
}

/// The preconditioner of one solve, through linalg's interface. setOperator, which the
/// conjugate gradients call once an iteration is needed, decides what preconditions this step
/// (Cholesky's factor, made anew or kept; the earlier factor through the bridge; the two-level
/// V-cycle where neither is to be had; the multigrid's levels, remade or kept: see
/// ImplicitEulerParams), sets it up and writes the choice into the step's status; apply runs
/// it. Jacobi and block Jacobi act row by row with the assembly's inverse diagonal blocks.
class ImplicitEuler::StepPreconditioner final : public LinearPreconditioner {
 public:
  /// `refresh`: set up from this step's matrix whatever the last steps did (a new Cholesky
  /// factor, analysed now for a new sparsity unless too costly; the multigrid's coarse levels
  /// remade): the second try of a solve the first preconditioner did not bring to converge.
  StepPreconditioner(ImplicitEuler& solver, const ElasticModel& model, StepStatus& status,
                     bool refresh = false)
      : solver_(solver),
        model_(model),
        status_(status),
        kind_(solver.params_.preconditioner),
        refresh_(refresh) {}

  [[nodiscard]] bool setOperator(const BlockMatrixView& a, bool threaded) override;
  void apply(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) override;
  [[nodiscard]] const Eigen::Matrix3d* rowBlocks() const override {
    const bool pointwise =
        kind_ == PreconditionerKind::Jacobi || kind_ == PreconditionerKind::BlockJacobi;
    return pointwise ? solver_.preconditioner_.data() : nullptr;
  }

 private:
  ImplicitEuler& solver_;
  const ElasticModel& model_;
  StepStatus& status_;
  PreconditionerKind kind_;  ///< what apply runs (Cholesky may hand a step to TwoLevel)
  bool bridged_ = false;     ///< apply runs the earlier factor through the bridge
  bool threaded_ = true;
  bool refresh_ = false;
};

bool ImplicitEuler::StepPreconditioner::setOperator(const BlockMatrixView& view, bool threaded) {
  ImplicitEuler& s = solver_;
  const ElasticModel& model = model_;
  const ImplicitEulerParams& params = s.params_;
  const BlockSparsity& sp = model.sparsity();
  const std::size_t rows = view.rows;
  threaded_ = threaded;
  if (kind_ == PreconditionerKind::IncompleteCholesky) {
    if (s.icRevision_ != model.sparsityRevision()) {
      s.icPattern_ = incompleteCholeskyPattern(sp);
      s.icRevision_ = model.sparsityRevision();
    }
    factorIncompleteCholesky(sp, s.icPattern_, s.blocks_, s.factor_);
  }
  if (kind_ == PreconditionerKind::Cholesky) {
    // A new structure is analysed and factorised once it has lasted factorAfterSteps steps;
    // until then, when its factor would cost too much, or when the matrix is not SPD, the
    // two-level V-cycle stands in. A structure at least 90 % the size of one whose factor
    // was too costly is not analysed again (the analysis alone takes tens of ms there).
    const std::uint64_t revision = model.sparsityRevision();
    if (s.choleskyRevision_ != revision && s.costlyRevision_ != revision &&
        (s.stepsOnStructure_ >= params.factorAfterSteps || refresh_)) {
      if (s.costlyRows_ != 0 && 10 * rows >= 9 * s.costlyRows_) {
        s.costlyRevision_ = revision;
      } else {
        s.cholesky_.analyse(sp);
        s.bridge_.invalidate();
        s.choleskyRevision_ = revision;
        const double updates = s.cholesky_.updateCount();
        s.costlyRows_ = 0;
        if (updates > params.maxFactorUpdates ||
            updates > params.maxFactorUpdatesPerBlock * static_cast<double>(sp.blockCount())) {
          s.costlyRows_ = rows;
          s.costlyRevision_ = revision;
          s.cholesky_ = BlockCholesky{};  // its pattern's memory back
        }
      }
    }
    if (s.choleskyRevision_ != revision || s.costlyRevision_ == revision) {
      // The earlier factor through the node map when step() could prepare it.
      bridged_ = s.bridgeRevision_ == revision && s.bridge_.valid() && s.cholesky_.factorised();
      if (!bridged_) kind_ = PreconditionerKind::TwoLevel;
    } else if (!s.cholesky_.factorised() || s.lastIterations_ > params.refactorIterations ||
               refresh_) {
      status_.factorised = s.cholesky_.factorise(sp, s.blocks_, threaded);
      if (status_.factorised)
        s.bridge_.reset(model);
      else {
        s.bridge_.invalidate();
        kind_ = PreconditionerKind::TwoLevel;
      }
    }
  }
  if (kind_ == PreconditionerKind::Multigrid) {
    // The hierarchy follows the sparsity; its coarse levels are remade when the last step
    // showed them stale, else only the fine smoother follows the new matrix.
    if (s.multigridRefreshed_) s.multigridBaseIterations_ = s.lastIterations_;
    s.multigridRefreshed_ = false;
    bool ok = false;
    if (s.multigridRevision_ != model.sparsityRevision() || !s.multigrid_.built()) {
      s.multigrid_.build(view, s.freeCoords_, params.multigrid, threaded);
      s.multigridRevision_ = model.sparsityRevision();
      ok = s.multigridRefreshed_ = s.multigrid_.setOperator(view, threaded);
    } else if (!s.multigrid_.valid() || refresh_ ||
               s.lastIterations_ > s.multigridBaseIterations_ + params.multigridRefreshIterations) {
      ok = s.multigridRefreshed_ = s.multigrid_.setOperator(view, threaded);
    } else {
      ok = s.multigrid_.updateFine(view, threaded);
      if (!ok) ok = s.multigridRefreshed_ = s.multigrid_.setOperator(view, threaded);
    }
    if (!ok) kind_ = PreconditionerKind::TwoLevel;
  }
  if (kind_ == PreconditionerKind::TwoLevel)
    (void)s.twoLevel_.setup(sp, model.aggregation(), s.blocks_, &s.freePositions_, threaded);
  status_.preconditioner = kind_;
  status_.bridged = bridged_;
  return true;  // every kind above applies, the two-level V-cycle as smoothing alone at worst
}

void ImplicitEuler::StepPreconditioner::apply(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) {
  ImplicitEuler& s = solver_;
  const BlockSparsity& sp = model_.sparsity();
  if (bridged_)
    s.bridge_.apply(sp, s.blocks_, s.cholesky_, s.preconditioner_, r, z);
  else if (kind_ == PreconditionerKind::Cholesky)
    s.cholesky_.solve(r, z);
  else if (kind_ == PreconditionerKind::IncompleteCholesky)
    applyIncompleteCholesky(sp, s.factor_, r, z);
  else if (kind_ == PreconditionerKind::Multigrid)
    s.multigrid_.apply(r, z);
  else if (kind_ == PreconditionerKind::TwoLevel)
    s.twoLevel_.apply(sp, model_.aggregation(), s.blocks_, s.preconditioner_, r, z, threaded_);
  else
    applySymmetricGaussSeidel(sp, s.blocks_, s.preconditioner_, r, z);
  // Pair contacts couple rows the preconditioner does not see: it takes two sides pressed
  // together for stiff where they move together. The pieces' rigid motions, coupled through
  // the pairs (RigidModes), give that motion back as a coarse correction.
  if (!s.coupling_.empty() && s.params_.rigidCorrection) s.rigid_.coarseCorrection(r, z);
}

StepStatus ImplicitEuler::solve(const ElasticModel& model) {
  const bool threaded = model.threaded();
  const std::size_t rows = model.freeNodeCount();
  const BlockSparsity& sp = model.sparsity();
  const BlockMatrixView view = sp.view(blocks_);
  VOXCUT_ASSERT(view.rows == rows, "the sparsity does not match the free nodes");
  const Eigen::Matrix3d* blocks = view.blocks;
  const std::uint32_t* column = view.column;
  const std::uint32_t* rowStart = view.rowStart;
  // Row i of A x (the arrays held in locals: the products are the hot loop).
  auto multiply = [&](const std::vector<Vec3d>& in, std::size_t i) {
    return blockRowProduct(blocks, column, in.data(), rowStart[i], rowStart[i + 1]);
  };

  StepStatus status;
  status.preconditioner = params_.preconditioner;
  const double bb = chunkedSum(rows, partial_, threaded, [&](std::size_t i) {
    x_[i] = params_.warmStart ? lastDv_[model.freeNodes()[i]] : Vec3d::Zero();
    return b_[i].squaredNorm();
  });
  if (const std::optional<ConjugateGradientStatus> trivial =
          ConjugateGradients::trivialSolve(bb, x_)) {
    status.finite = trivial->finite;
    status.converged = trivial->converged;
    return status;
  }
  // The rigid-mode correction (RigidModes.h) of the start, and again of the result: A times
  // the modes is made once for both.
  const bool correctRigid = params_.rigidCorrection;
  // The products of A with a translation c of a free piece (no anchored row) are taken as
  // what they are exactly, massRow c: the stiffness blocks' round-off times a large common
  // velocity change (a long step, a fast fall) would otherwise act as a force and turn the
  // piece. The warm start is split the same way, into its free pieces' mass-weighted means
  // (shift_) and what is left.
  std::fill(shift_.begin(), shift_.end(), Vec3d::Zero());
  // out_i: the mass-weighted mean of v over row i's piece where that piece is free (no
  // anchored row, no contact), else zero.
  auto freePieceMeans = [&](const std::vector<Vec3d>& v, std::vector<Vec3d>& out) {
    const std::vector<std::uint32_t>& piece = rigid_.piece();
    std::vector<Vec3d> mean(rigid_.pieceCount(), Vec3d::Zero());
    std::vector<double> weight(rigid_.pieceCount(), 0.0);
    for (std::size_t i = 0; i < rows; ++i) {
      mean[piece[i]] += massRow_[i] * v[i];
      weight[piece[i]] += massRow_[i];
    }
    for (std::size_t i = 0; i < rows; ++i)
      out[i] = freePiece_[piece[i]] && weight[piece[i]] > 0.0
                   ? Vec3d(mean[piece[i]] / weight[piece[i]])
                   : Vec3d::Zero();
  };
  if (correctRigid) {
    rigid_.setup(sp, model.sparsityRevision(), freePositions_, freeMasses_);
    if (anchoredRevision_ != model.sparsityRevision() || anchoredRow_.size() != rows) {
      anchoredRow_ = anchoredRows(model);
      anchoredRevision_ = model.sparsityRevision();
    }
    const std::vector<std::uint32_t>& piece = rigid_.piece();
    freePiece_.assign(rigid_.pieceCount(), 1);
    for (std::size_t i = 0; i < rows; ++i)
      if (anchoredRow_[i]) freePiece_[piece[i]] = 0;
    // A contact's spring resists its piece's translations too.
    const WeightedRows& pr = model.prolongation();
    for (const PointContact& pc : contacts_)
      for (std::uint32_t n : model.elementNodes()[pc.element])
        for (std::uint32_t k = pr.start[n]; k < pr.start[n + 1]; ++k)
          freePiece_[piece[pr.index[k]]] = 0;
    freePieceMeans(x_, shift_);
    for (auto& v : rigidProducts_) v.resize(rows);
    parallelFor(
        0, rows, 256,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t i = b; i < e; ++i) {
            const bool translationExact = freePiece_[piece[i]] != 0;
            const std::array<Vec3d, 6> az =
                rigid_.rowProducts(blocks, column, rowStart[i], rowStart[i + 1]);
            for (std::size_t k = 0; k < 6; ++k)
              rigidProducts_[k][i] = translationExact && k < 3
                                         ? Vec3d(massRow_[i] * rigid_.mode(static_cast<int>(k))[i])
                                         : az[k];
          }
        },
        threaded);
    rigid_.setOperator(rigidProducts_, &coupling_);
  }
  // r = b - A x0 (corrected); q holds x0 less its shift meanwhile.
  parallelFor(
      0, rows, 256,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) q_[i] = x_[i] - shift_[i];
      },
      threaded);
  // The earlier solutions are kept less their free pieces' means, as q is: the start's part
  // other than the shift is their best combination for A q = b - A shift.
  const std::vector<std::uint32_t>& freeNodes = model.freeNodes();
  // Kept on other rows (other fixed nodes, or a topology change): by node, then these rows,
  // which are from now on those of the kept solutions.
  if (projectionRevision_ != model.sparsityRevision()) {
    if (!projectionByNode_) {
      if (lastNodeCount_ == model.nodeCount())
        projectionToNodes();
      else
        projection_.clear();
    }
    projectionRevision_ = model.sparsityRevision();
    lastFreeNodes_ = freeNodes;
    lastNodeCount_ = model.nodeCount();
  }
  if (projectionByNode_) {
    projection_.transform([&](std::vector<Vec3d>& h) {
      std::vector<Vec3d> byRow(rows);
      for (std::size_t i = 0; i < rows; ++i)
        byRow[i] = freeNodes[i] < h.size() ? h[freeNodes[i]] : Vec3d::Zero();
      h = std::move(byRow);
    });
    projectionByNode_ = false;
  }
  projection_.setCapacity(static_cast<std::size_t>(std::max(params_.projectionHistory, 0)));
  bool projected = false;
  if (params_.warmStart && projecting_ && projection_.size() > 0) {
    projectionRhs_.resize(rows);
    for (std::size_t i = 0; i < rows; ++i) projectionRhs_[i] = b_[i] - massRow_[i] * shift_[i];
    projected = projection_.project(view, projectionRhs_, q_, threaded, &coupling_);
    if (projected)
      for (std::size_t i = 0; i < rows; ++i) x_[i] = shift_[i] + q_[i];
  }
  parallelFor(
      0, rows, 256,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i)
          r_[i] = b_[i] - multiply(q_, i) - massRow_[i] * shift_[i];
      },
      threaded);
  if (!coupling_.empty()) {  // r -= X q (the shift is a translation of free pieces, which
                             // hold no pair: X shift = 0)
    coupling_.multiplySubtract(q_, r_, threaded);
  }
  if (correctRigid) rigid_.correct(x_, r_);
  // The conjugate gradients (linalg/ConjugateGradients.h) from this start and its residual.
  StepPreconditioner preconditioner(*this, model, status);
  cg_.setOperator(view, threaded);
  cg_.setCoupling(&coupling_);
  cg_.setPreconditioner(preconditioner);
  cg_.setParams({params_.tolerance, params_.maxIterations});
  ConjugateGradientStatus cg = cg_.iterate(bb, x_, r_);
  // Not converged on a preconditioner made for earlier steps (the earlier factor through the
  // bridge after a cut, a factor or coarse levels of a matrix the contacts have changed since):
  // once more from where it stopped, on one made for this step's matrix.
  const bool betterFactor = params_.preconditioner == PreconditionerKind::Cholesky &&
                            !status.factorised && costlyRevision_ != model.sparsityRevision();
  const bool betterLevels = params_.preconditioner == PreconditionerKind::Multigrid &&
                            !multigridRefreshed_;
  if (!cg.converged && cg.finite && cg.preconditioned && (betterFactor || betterLevels)) {
    StepStatus again;
    StepPreconditioner fresh(*this, model, again, true);
    cg_.setPreconditioner(fresh);
    const ConjugateGradientStatus more = cg_.iterate(bb, x_, r_);
    status.factorised = status.factorised || again.factorised;
    status.preconditioner = again.preconditioner;
    status.bridged = again.bridged;
    status.retried = true;
    cg = ConjugateGradientStatus{cg.iterations + more.iterations, more.residual, more.converged,
                                 more.finite, more.preconditioned};
  }
  status.iterations = cg.iterations;
  status.residual = cg.residual;
  status.converged = cg.converged;
  status.finite = cg.finite;
  if (correctRigid && cg.finite) {
    rigid_.correct(x_, r_);
    for (const Vec3d& v : x_) status.finite = status.finite && v.allFinite();
  }
  const int history = params_.projectionHistory;
  projecting_ = projected ? 2 * cg.iterations >= history : cg.iterations > history;
  if (status.finite && history > 0) {
    // Kept less its free pieces' means (q_ is free now).
    const bool anyFree = correctRigid && std::any_of(freePiece_.begin(), freePiece_.end(),
                                                     [](std::uint8_t f) { return f != 0; });
    if (anyFree) {
      freePieceMeans(x_, shift_);
      for (std::size_t i = 0; i < rows; ++i) q_[i] = x_[i] - shift_[i];
      projection_.add(q_);
    } else {
      projection_.add(x_);
    }
  }
  return status;
}

StepStatus ImplicitEuler::step(const ElasticModel& model, DeformationOctree& octree) {
  VOXCUT_ASSERT(
      model.elementCount() == octree.elementCount() && model.nodeCount() == octree.nodeCount(),
      "the model does not match the octree (missing updateTopology?)");
  VOXCUT_ASSERT(params_.timeStep > 0.0 && params_.maxIterations >= 0, "bad step settings");
  resize(model);
  if (model.sparsityRevision() != stepRevision_) {
    stepRevision_ = model.sparsityRevision();
    stepsOnStructure_ = 0;
  } else if (stepsOnStructure_ < std::numeric_limits<int>::max()) {
    ++stepsOnStructure_;
  }
  const bool threaded = model.threaded();
  const std::vector<std::uint32_t>& freeNodes = model.freeNodes();
  // Project the velocities through P: fixed and unused nodes at rest, hanging nodes at their
  // masters' mean.
  for (std::size_t i = 0; i < freeNodes.size(); ++i) vr_[i] = velocity_[freeNodes[i]];
  prolong(model.prolongation(), vr_, velocity_, threaded);

  {  // the rigid modes' and the two-level coarse space's rotations
    freePositions_.resize(freeNodes.size());
    freeMasses_.resize(freeNodes.size());
    for (std::size_t i = 0; i < freeNodes.size(); ++i) {
      freePositions_[i] = octree.positions()[freeNodes[i]];
      freeMasses_[i] = model.nodeMass()[freeNodes[i]];
    }
    if (params_.preconditioner == PreconditionerKind::Multigrid &&
        multigridRevision_ != model.sparsityRevision()) {
      freeCoords_.resize(freeNodes.size());
      for (std::size_t i = 0; i < freeNodes.size(); ++i)
        freeCoords_[i] = octree.nodeCoord(freeNodes[i]);
    }
  }
  // A cut since the factor: map the factor onto the new rows (FactorBridge.h), once per
  // sparsity, unless the last step on the bridge showed it has worn out.
  if (lastBridged_ && lastIterations_ > params_.bridgeIterations) bridge_.invalidate();
  if (params_.preconditioner == PreconditionerKind::Cholesky && bridge_.valid() &&
      cholesky_.factorised() && model.sparsityRevision() != choleskyRevision_ &&
      bridgeRevision_ != model.sparsityRevision()) {
    if (bridge_.prepare(model, octree, cholesky_.rows()))
      bridgeRevision_ = model.sparsityRevision();
  }
  // Pair contacts: each side a point contact against the other side at its start velocity
  // (the pair matrix's diagonal parts, assembled with the elements), the cross terms
  // dt^2 k n n^T + dt c (I - n n^T) between the two sides' free rows in coupling_.
  const std::size_t givenContacts = contacts_.size();
  coupling_.clear();
  if (!pairs_.empty()) {
    const double dt = params_.timeStep;
    const WeightedRows& pr = model.prolongation();
    auto pointVelocity = [&](std::uint32_t e, const std::array<double, 8>& w) {
      Vec3d v = Vec3d::Zero();
      for (std::size_t c = 0; c < 8; ++c) v += w[c] * velocity_[octree.element(e).nodes[c]];
      return v;
    };
    auto rowsOf = [&](std::uint32_t e, const std::array<double, 8>& w) {
      RowWeights out;
      for (std::size_t c = 0; c < 8; ++c) {
        const std::uint32_t n = octree.element(e).nodes[c];
        for (std::uint32_t k = pr.start[n]; k < pr.start[n + 1]; ++k)
          out.emplace_back(pr.index[k], w[c] * pr.weight[k]);
      }
      return out;
    };
    for (const PairContact& p : pairs_) {
      VOXCUT_ASSERT(p.element < model.elementCount() && p.other < model.elementCount(),
                    "a pair contact's element is not in the model");
      const Vec3d va = pointVelocity(p.element, p.weight);
      const Vec3d vb = pointVelocity(p.other, p.otherWeight);
      PointContact a;
      a.element = p.element;
      a.weight = p.weight;
      a.normal = p.normal;
      a.gap = p.gap - dt * p.normal.dot(vb);
      a.stiffness = p.stiffness;
      a.friction = p.friction;
      a.surfaceVelocity = vb;
      PointContact b = a;
      b.element = p.other;
      b.weight = p.otherWeight;
      b.normal = -p.normal;
      b.gap = p.gap + dt * p.normal.dot(va);
      b.surfaceVelocity = va;
      contacts_.push_back(a);
      contacts_.push_back(b);
      const Eigen::Matrix3d nn = p.normal * p.normal.transpose();
      const Eigen::Matrix3d c = (dt * dt * p.stiffness) * nn +
                                (dt * p.friction) * (Eigen::Matrix3d::Identity() - nn);
      coupling_.add(rowsOf(p.element, p.weight), rowsOf(p.other, p.otherWeight), c);
    }
  }
  if (!contacts_.empty()) {  // the contacts by element (counting sort, stable)
    const std::size_t elements = model.elementCount();
    contactStart_.assign(elements + 1, 0);
    for (const PointContact& pc : contacts_) {
      VOXCUT_ASSERT(pc.element < elements, "a contact's element is not in the model");
      ++contactStart_[pc.element + 1];
    }
    for (std::size_t e = 0; e < elements; ++e) contactStart_[e + 1] += contactStart_[e];
    std::vector<std::uint32_t> next(contactStart_.begin(), contactStart_.end() - 1);
    std::vector<PointContact> sorted(contacts_.size());
    contactOrder_.resize(contacts_.size());
    for (std::size_t k = 0; k < contacts_.size(); ++k) {
      const std::uint32_t slot = next[contacts_[k].element]++;
      sorted[slot] = contacts_[k];
      contactOrder_[slot] = k;
    }
    contacts_.swap(sorted);
  }
  Timer timer;
  assemble(model, octree);
  const double assemblyMs = timer.ms();
  timer.restart();
  StepStatus status = solve(model);
  status.assemblyMs = assemblyMs;
  status.solveMs = timer.ms();
  lastIterations_ = status.iterations;
  lastBridged_ = status.bridged;
  contactForce_.assign(contacts_.size(), 0.0);
  contactFriction_.assign(contacts_.size(), Vec3d::Zero());
  pairForce_.assign(pairs_.size(), 0.0);
  pairFriction_.assign(pairs_.size(), Vec3d::Zero());
  if (!status.finite) {
    std::fill(lastDv_.begin(), lastDv_.end(), Vec3d::Zero());
    contacts_.clear();
    pairs_.clear();
    coupling_.clear();
    contactForce_.resize(givenContacts);
    contactFriction_.resize(givenContacts);
    return status;
  }
  for (std::size_t i = 0; i < freeNodes.size(); ++i) {
    vr_[i] += x_[i];
    lastDv_[freeNodes[i]] = x_[i];
  }
  prolong(model.prolongation(), vr_, velocity_, threaded);
  const double dt = params_.timeStep;
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    const PointContact& pc = contacts_[k];
    const OctreeElement& el = octree.element(pc.element);
    Vec3d vp = Vec3d::Zero();
    for (std::size_t c = 0; c < 8; ++c) vp += pc.weight[c] * velocity_[el.nodes[c]];
    contactForce_[contactOrder_[k]] = -pc.stiffness * (pc.gap + dt * pc.normal.dot(vp));
    if (pc.friction > 0.0) {
      const Vec3d rel = vp - pc.surfaceVelocity;
      contactFriction_[contactOrder_[k]] = -pc.friction * (rel - pc.normal.dot(rel) * pc.normal);
    }
  }
  contactForce_.resize(givenContacts);  // the pairs' halves came after the given contacts
  contactFriction_.resize(givenContacts);
  for (std::size_t k = 0; k < pairs_.size(); ++k) {
    const PairContact& p = pairs_[k];
    Vec3d rel = Vec3d::Zero();
    for (std::size_t c = 0; c < 8; ++c)
      rel += p.weight[c] * velocity_[octree.element(p.element).nodes[c]] -
             p.otherWeight[c] * velocity_[octree.element(p.other).nodes[c]];
    pairForce_[k] = -p.stiffness * (p.gap + dt * p.normal.dot(rel));
    if (p.friction > 0.0) pairFriction_[k] = -p.friction * (rel - p.normal.dot(rel) * p.normal);
  }
  contacts_.clear();
  pairs_.clear();
  coupling_.clear();
  std::vector<Vec3d>& pos = octree.positions();
  parallelFor(
      0, pos.size(), 512,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t n = b; n < e; ++n)
          if (!octree.isHanging(static_cast<std::uint32_t>(n))) pos[n] += dt * velocity_[n];
      },
      threaded);
  octree.updateHangingNodes();
  return status;
}

}  // namespace voxcut
