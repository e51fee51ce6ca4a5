#include "voxcut/fem/ImplicitEuler.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/fem/Corotation.h"
#include "voxcut/linalg/BlockPreconditioner.h"

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

/// Rows per chunk of a dot product: partial sums land in fixed slots and are added in chunk
/// order, so the result does not depend on how the scheduler splits the range.
constexpr std::size_t kChunk = 256;

/// sum_i body(i) over [0, rows), chunked as above. body may also write row i's outputs.
template <class Body>
double chunkedSum(std::size_t rows, std::vector<double>& partial, bool threaded, Body&& body) {
  const std::size_t chunks = (rows + kChunk - 1) / kChunk;
  partial.resize(chunks);
  parallelFor(
      0, chunks, 1,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t c = b; c < e; ++c) {
          double s = 0.0;
          const std::size_t end = std::min(rows, (c + 1) * kChunk);
          for (std::size_t i = c * kChunk; i < end; ++i) s += body(i);
          partial[c] = s;
        }
      },
      threaded);
  double sum = 0.0;
  for (std::size_t c = 0; c < chunks; ++c) sum += partial[c];
  return sum;
}

/// Two sums at once: body(i) returns a pair.
template <class Body>
std::pair<double, double> chunkedSum2(std::size_t rows, std::vector<double>& partial,
                                      std::vector<double>& partial2, bool threaded, Body&& body) {
  const std::size_t chunks = (rows + kChunk - 1) / kChunk;
  partial.resize(chunks);
  partial2.resize(chunks);
  parallelFor(
      0, chunks, 1,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t c = b; c < e; ++c) {
          double s = 0.0, s2 = 0.0;
          const std::size_t end = std::min(rows, (c + 1) * kChunk);
          for (std::size_t i = c * kChunk; i < end; ++i) {
            const auto [x, y] = body(i);
            s += x;
            s2 += y;
          }
          partial[c] = s;
          partial2[c] = s2;
        }
      },
      threaded);
  double sum = 0.0, sum2 = 0.0;
  for (std::size_t c = 0; c < chunks; ++c) {
    sum += partial[c];
    sum2 += partial2[c];
  }
  return {sum, sum2};
}

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

const char* preconditionerName(Preconditioner p) {
  switch (p) {
    case Preconditioner::Jacobi:
      return "jacobi";
    case Preconditioner::BlockJacobi:
      return "block_jacobi";
    case Preconditioner::SymmetricGaussSeidel:
      return "symmetric_gauss_seidel";
    case Preconditioner::IncompleteCholesky:
      return "incomplete_cholesky";
    case Preconditioner::TwoLevel:
      return "two_level";
    case Preconditioner::Cholesky:
      return "cholesky";
    case Preconditioner::Multigrid:
      return "multigrid";
  }
  return "unknown";
}

void ImplicitEuler::setContacts(std::vector<PointContact> contacts) {
  contacts_ = std::move(contacts);
}

void ImplicitEuler::reset() {
  velocity_.clear();
  lastDv_.clear();
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
  bridge_.update(change);
  bridgeRevision_ = 0;
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
  for (auto* v : {&b_, &x_, &r_, &z_, &p_, &q_, &vr_, &shift_}) v->resize(free);
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
  const bool block = params_.preconditioner != Preconditioner::Jacobi;
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
          for (std::uint32_t slot = sp.rowStart[i]; slot < sp.diagonal[i]; ++slot)
            blocks_[slot] = blocks_[mirror[slot]].transpose();
      },
      threaded);
}

StepStatus ImplicitEuler::solve(const ElasticModel& model) {
  const bool threaded = model.threaded();
  const std::size_t rows = model.freeNodeCount();
  const BlockSparsity& sp = model.sparsity();
  const Eigen::Matrix3d* blocks = blocks_.data();
  const std::uint32_t* column = sp.column.data();
  const std::uint32_t* rowStart = sp.rowStart.data();
  const BlockMatrixView view{rows, rowStart, column, sp.diagonal.data(), blocks};
  // Row i of A x: most of the solve.
  auto multiply = [&](const std::vector<Vec3d>& in, std::size_t i) {
    return blockRowProduct(blocks, column, in.data(), rowStart[i], rowStart[i + 1]);
  };
  // Jacobi and block Jacobi act row by row, fused into the vector updates; the coupled
  // preconditioners run as one sequential sweep over all rows after them.
  Preconditioner kind = params_.preconditioner;
  const bool pointwise = kind == Preconditioner::Jacobi || kind == Preconditioner::BlockJacobi;
  bool bridged = false;
  auto precondition = [&] {
    if (bridged)
      bridge_.apply(sp, blocks_, cholesky_, preconditioner_, r_, z_);
    else if (kind == Preconditioner::Cholesky)
      cholesky_.solve(r_, z_);
    else if (kind == Preconditioner::IncompleteCholesky)
      applyIncompleteCholesky(sp, factor_, r_, z_);
    else if (kind == Preconditioner::Multigrid)
      multigrid_.apply(view, r_, z_, threaded);
    else if (kind == Preconditioner::TwoLevel)
      twoLevel_.apply(sp, model.aggregation(), blocks_, preconditioner_, r_, z_, threaded);
    else
      applySymmetricGaussSeidel(sp, blocks_, preconditioner_, r_, z_);
    return chunkedSum(rows, partial_, threaded, [&](std::size_t i) { return r_[i].dot(z_[i]); });
  };

  StepStatus status;
  status.preconditioner = params_.preconditioner;
  const double bb = chunkedSum(rows, partial_, threaded, [&](std::size_t i) {
    x_[i] = params_.warmStart ? lastDv_[model.freeNodes()[i]] : Vec3d::Zero();
    return b_[i].squaredNorm();
  });
  if (!std::isfinite(bb)) {
    status.finite = false;
    return status;
  }
  if (bb == 0.0) {
    std::fill(x_.begin(), x_.end(), Vec3d::Zero());
    status.converged = true;
    return status;
  }
  const double stop = params_.tolerance * params_.tolerance * bb;
  // The rigid-mode correction (RigidModes.h) of the start, and again of the result: A times
  // the modes is made once for both.
  const bool correctRigid = params_.rigidCorrection;
  // The products of A with a translation c of a free piece (no anchored row) are taken as
  // what they are exactly, massRow c: the stiffness blocks' round-off times a large common
  // velocity change (a long step, a fast fall) would otherwise act as a force and turn the
  // piece. The warm start is split the same way, into its free pieces' mass-weighted means
  // (shift_) and what is left.
  std::fill(shift_.begin(), shift_.end(), Vec3d::Zero());
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
    std::vector<Vec3d> mean(rigid_.pieceCount(), Vec3d::Zero());
    std::vector<double> weight(rigid_.pieceCount(), 0.0);
    for (std::size_t i = 0; i < rows; ++i) {
      mean[piece[i]] += massRow_[i] * x_[i];
      weight[piece[i]] += massRow_[i];
    }
    for (std::size_t i = 0; i < rows; ++i)
      if (freePiece_[piece[i]] && weight[piece[i]] > 0.0)
        shift_[i] = mean[piece[i]] / weight[piece[i]];
    for (auto& v : rigidProducts_) v.resize(rows);
    parallelFor(
        0, rows, 256,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t i = b; i < e; ++i) {
            const bool translationExact = freePiece_[piece[i]] != 0;
            for (int k = 0; k < 6; ++k)
              rigidProducts_[static_cast<std::size_t>(k)][i] =
                  translationExact && k < 3 ? Vec3d(massRow_[i] * rigid_.mode(k)[i])
                                            : multiply(rigid_.mode(k), i);
          }
        },
        threaded);
    rigid_.setOperator(rigidProducts_);
  }
  // r = b - A x0 (corrected), z = M^-1 r, p = z; q holds x0 less its shift meanwhile.
  parallelFor(
      0, rows, 256,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) q_[i] = x_[i] - shift_[i];
      },
      threaded);
  parallelFor(
      0, rows, 256,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i)
          r_[i] = b_[i] - multiply(q_, i) - massRow_[i] * shift_[i];
      },
      threaded);
  if (correctRigid) rigid_.correct(x_, r_);
  auto [rz, rr] = chunkedSum2(rows, partial_, partial2_, threaded, [&](std::size_t i) {
    if (!pointwise) return std::pair{0.0, r_[i].squaredNorm()};
    z_[i] = preconditioner_[i] * r_[i];
    return std::pair{r_[i].dot(z_[i]), r_[i].squaredNorm()};
  });
  bool finite = std::isfinite(rr);
  if (finite && rr > stop && status.iterations < params_.maxIterations && !pointwise) {
    if (kind == Preconditioner::IncompleteCholesky) {
      if (icRevision_ != model.sparsityRevision()) {
        icPattern_ = incompleteCholeskyPattern(sp);
        icRevision_ = model.sparsityRevision();
      }
      factorIncompleteCholesky(sp, icPattern_, blocks_, factor_);
    }
    if (kind == Preconditioner::Cholesky) {
      // A new structure is analysed and factorised once it has lasted factorAfterSteps steps;
      // until then, when its factor would cost too much, or when the matrix is not SPD, the
      // two-level V-cycle stands in. A structure at least 90 % the size of one whose factor
      // was too costly is not analysed again (the analysis alone takes tens of ms there).
      const std::uint64_t revision = model.sparsityRevision();
      if (choleskyRevision_ != revision && costlyRevision_ != revision &&
          stepsOnStructure_ >= params_.factorAfterSteps) {
        if (costlyRows_ != 0 && 10 * rows >= 9 * costlyRows_) {
          costlyRevision_ = revision;
        } else {
          cholesky_.analyse(sp);
          bridge_.invalidate();
          choleskyRevision_ = revision;
          const double updates = cholesky_.updateCount();
          costlyRows_ = 0;
          if (updates > params_.maxFactorUpdates ||
              updates > params_.maxFactorUpdatesPerBlock * static_cast<double>(sp.blockCount())) {
            costlyRows_ = rows;
            costlyRevision_ = revision;
            cholesky_ = BlockCholesky{};  // its pattern's memory back
          }
        }
      }
      if (choleskyRevision_ != revision || costlyRevision_ == revision) {
        // The earlier factor through the node map when step() could prepare it.
        bridged = bridgeRevision_ == revision && bridge_.valid() && cholesky_.factorised();
        if (!bridged) kind = Preconditioner::TwoLevel;
      } else if (!cholesky_.factorised() || lastIterations_ > params_.refactorIterations) {
        status.factorised = cholesky_.factorise(sp, blocks_, threaded);
        if (status.factorised)
          bridge_.reset(model);
        else {
          bridge_.invalidate();
          kind = Preconditioner::TwoLevel;
        }
      }
    }
    if (kind == Preconditioner::Multigrid) {
      // The hierarchy follows the sparsity; its coarse levels are remade when the last step
      // showed them stale, else only the fine smoother follows the new matrix.
      if (multigridRefreshed_) multigridBaseIterations_ = lastIterations_;
      multigridRefreshed_ = false;
      bool ok = false;
      if (multigridRevision_ != model.sparsityRevision() || !multigrid_.built()) {
        multigrid_.build(view, freeCoords_, params_.multigrid, threaded);
        multigridRevision_ = model.sparsityRevision();
        ok = multigridRefreshed_ = multigrid_.setup(view, threaded);
      } else if (!multigrid_.valid() ||
                 lastIterations_ > multigridBaseIterations_ + params_.multigridRefreshIterations) {
        ok = multigridRefreshed_ = multigrid_.setup(view, threaded);
      } else {
        ok = multigrid_.updateFine(view, threaded);
        if (!ok) ok = multigridRefreshed_ = multigrid_.setup(view, threaded);
      }
      if (!ok) kind = Preconditioner::TwoLevel;
    }
    if (kind == Preconditioner::TwoLevel)
      (void)twoLevel_.setup(sp, model.aggregation(), blocks_, &freePositions_, threaded);
    rz = precondition();
    status.preconditioner = kind;
    status.bridged = bridged;
  }
  finite = finite && std::isfinite(rz);
  std::copy(z_.begin(), z_.end(), p_.begin());
  while (finite && rr > stop && status.iterations < params_.maxIterations) {
    const double pq = chunkedSum(rows, partial_, threaded, [&](std::size_t i) {
      q_[i] = multiply(p_, i);
      return p_[i].dot(q_[i]);
    });
    const double alpha = rz / pq;
    if (!std::isfinite(alpha)) {
      finite = std::isfinite(pq);
      break;  // pq == 0 (breakdown) or a non-finite value
    }
    auto [rzNew, rrNew] = chunkedSum2(rows, partial_, partial2_, threaded, [&](std::size_t i) {
      x_[i] += alpha * p_[i];
      r_[i] -= alpha * q_[i];
      if (!pointwise) return std::pair{0.0, r_[i].squaredNorm()};
      z_[i] = preconditioner_[i] * r_[i];
      return std::pair{r_[i].dot(z_[i]), r_[i].squaredNorm()};
    });
    ++status.iterations;
    rr = rrNew;
    finite = std::isfinite(rr);
    if (!finite || rr <= stop) break;
    if (!pointwise) rzNew = precondition();
    finite = std::isfinite(rzNew);
    if (!finite) break;
    const double beta = rzNew / rz;
    rz = rzNew;
    parallelFor(
        0, rows, 256,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t i = b; i < e; ++i) p_[i] = z_[i] + beta * p_[i];
        },
        threaded);
  }
  status.finite = finite;
  status.residual = std::sqrt(rr / bb);
  status.converged = finite && rr <= stop;
  if (correctRigid && finite) {
    rigid_.correct(x_, r_);
    for (const Vec3d& v : x_) status.finite = status.finite && v.allFinite();
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
    if (params_.preconditioner == Preconditioner::Multigrid &&
        multigridRevision_ != model.sparsityRevision()) {
      freeCoords_.resize(freeNodes.size());
      for (std::size_t i = 0; i < freeNodes.size(); ++i)
        freeCoords_[i] = octree.nodeCoord(freeNodes[i]);
    }
  }
  // A cut since the factor: map the factor onto the new rows (FactorBridge.h), once per
  // sparsity, unless the last step on the bridge showed it has worn out.
  if (lastBridged_ && lastIterations_ > params_.bridgeIterations) bridge_.invalidate();
  if (params_.preconditioner == Preconditioner::Cholesky && bridge_.valid() &&
      cholesky_.factorised() && model.sparsityRevision() != choleskyRevision_ &&
      bridgeRevision_ != model.sparsityRevision()) {
    if (bridge_.prepare(model, octree, cholesky_.rows()))
      bridgeRevision_ = model.sparsityRevision();
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
  if (!status.finite) {
    std::fill(lastDv_.begin(), lastDv_.end(), Vec3d::Zero());
    contacts_.clear();
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
  contacts_.clear();
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
