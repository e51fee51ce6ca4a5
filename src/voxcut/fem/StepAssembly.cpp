#include "voxcut/fem/StepAssembly.h"

#include <cstdint>

#include "voxcut/core/Parallel.h"
#include "voxcut/fem/Corotation.h"

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

/// The element blocks and the rows' blocks are read in an order the hardware cannot foresee:
/// the gathers ask for the one this many sources ahead.
constexpr std::uint32_t kGatherAhead = 16;

/// Adds a point contact's terms to its element: the forces spread by the point's weights
/// (times dt later, like the elastic force), the matrix times w_a w_c to the 36 upper blocks.
void spreadContact(const PointContact& pc, const ContactStepTerms& t,
                   std::array<Vec3d, 8>& force, Eigen::Matrix3d* blocks) {
  for (std::size_t c = 0; c < 8; ++c) force[c] += (pc.weight[c] * t.normalForce) * pc.normal;
  if (t.hasFriction)
    for (std::size_t c = 0; c < 8; ++c) force[c] += pc.weight[c] * t.frictionForce;
  for (int a = 0; a < 8; ++a)
    for (int c = a; c < 8; ++c)
      blocks[kUpperBlock[a][c]] +=
          (pc.weight[static_cast<std::size_t>(a)] * pc.weight[static_cast<std::size_t>(c)]) *
          t.matrix;
}

}  // namespace

void StepAssembly::resize(const ElasticModel& model) {
  const std::size_t nodes = model.nodeCount(), free = model.freeNodeCount();
  elementBlocks_.resize(36 * model.elementCount());
  elementForce_.resize(model.elementCount());
  nodeDiagonal_.resize(nodes);
  nodeRhs_.resize(nodes);
  blocks_.resize(model.sparsity().blockCount());
  diagonalInverse_.resize(free);
  rhs_.resize(free);
  massRow_.resize(free);
}

void StepAssembly::assemble(const ElasticModel& model, const DeformationOctree& octree,
                            const std::vector<Vec3d>& velocity, const StepContacts& contacts,
                            const ImplicitEulerParams& params) {
  assembleElements(model, octree, velocity, contacts, params.timeStep);
  gatherNodes(model, velocity, params.timeStep, params.gravity);
  gatherRows(model, params.preconditioner != PreconditionerKind::Jacobi);
  mirrorLowerBlocks(model);
}

void StepAssembly::assembleElements(const ElasticModel& model, const DeformationOctree& octree,
                                    const std::vector<Vec3d>& velocity,
                                    const StepContacts& contacts, double dt) {
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
          for (std::size_t c = 0; c < 8; ++c) meanVelocity += velocity[el.nodes[c]];
          meanVelocity *= 0.125;
          for (std::size_t c = 0; c < 8; ++c)
            y.segment<3>(3 * static_cast<Eigen::Index>(c)) +=
                damp * (r.transpose() * (velocity[el.nodes[c]] - meanVelocity));
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
          // The element's point contacts at their start velocities (ContactLaw.h).
          for (const PointContact& pc : contacts.ofElement(e))
            spreadContact(pc,
                          contactStepTerms(pc, contactPointVelocity(pc.weight, el.nodes, velocity),
                                           dt),
                          elementForce_[e], &elementBlocks_[36 * e]);
        }
      },
      model.threaded());
}

void StepAssembly::gatherNodes(const ElasticModel& model, const std::vector<Vec3d>& velocity,
                               double dt, const Vec3d& gravity) {
  // Nodes: dt (M g - alpha M v + f), gathered from incident corners in a fixed order.
  const WeightedRows& inc = model.incidence();
  const Vec3d g = gravity;
  parallelFor(
      0, model.nodeCount(), 256,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t n = b; n < end; ++n) {
          const double m = model.nodeMass()[n], d = model.nodeMassDamping()[n];
          nodeDiagonal_[n] = m + dt * d;
          Vec3d f = m * g - d * velocity[n];
          for (std::uint32_t k = inc.start[n]; k < inc.start[n + 1]; ++k)
            f += elementForce_[inc.index[k] / 8][inc.index[k] % 8];
          nodeRhs_[n] = dt * f;
        }
      },
      model.threaded());
}

void StepAssembly::gatherRows(const ElasticModel& model, bool blockDiagonal) {
  // Reduced rows: P^T b and the blocks of P^T A P on and above the diagonal, each summed over
  // its sources in order.
  const WeightedRows& res = model.restriction();
  const BlockSparsity& sp = model.sparsity();
  const auto massBase = static_cast<std::uint32_t>(64 * model.elementCount());
  const auto sourceEnd = static_cast<std::uint32_t>(sp.source.size());
  parallelFor(
      0, model.freeNodeCount(), 128,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t i = b; i < end; ++i) {
          Vec3d s = Vec3d::Zero();
          for (std::uint32_t k = res.start[i]; k < res.start[i + 1]; ++k)
            s += res.weight[k] * nodeRhs_[res.index[k]];
          rhs_[i] = s;
          double mass = 0.0;
          for (std::uint32_t k = res.start[i]; k < res.start[i + 1]; ++k)
            mass += res.weight[k] * nodeDiagonal_[res.index[k]];
          massRow_[i] = mass;
          for (std::uint32_t slot = sp.diagonal[i]; slot < sp.rowStart[i + 1]; ++slot) {
            Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
            for (std::uint32_t k = sp.sourceStart[slot]; k < sp.sourceStart[slot + 1]; ++k) {
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
          if (blockDiagonal) {
            diagonalInverse_[i] = diag.inverse();
          } else {
            diagonalInverse_[i] = Eigen::Matrix3d::Zero();
            for (int a = 0; a < 3; ++a) diagonalInverse_[i](a, a) = 1.0 / diag(a, a);
          }
        }
      },
      model.threaded());
}

void StepAssembly::mirrorLowerBlocks(const ElasticModel& model) {
  // The blocks below the diagonal are their mirrors' transposes (A is symmetric, and so
  // exactly symmetric in floating point too).
  const BlockSparsity& sp = model.sparsity();
  const std::vector<std::uint32_t>& mirror = sp.mirror;
  const auto slotEnd = static_cast<std::uint32_t>(mirror.size());
  parallelFor(
      0, model.freeNodeCount(), 256,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t i = b; i < end; ++i)
          for (std::uint32_t slot = sp.rowStart[i]; slot < sp.diagonal[i]; ++slot) {
            if (slot + kGatherAhead < slotEnd) {  // mirrors lie anywhere
              const auto* p =
                  reinterpret_cast<const char*>(blocks_[mirror[slot + kGatherAhead]].data());
              __builtin_prefetch(p);
              __builtin_prefetch(p + 64);
            }
            blocks_[slot] = blocks_[mirror[slot]].transpose();
          }
      },
      model.threaded());
}

Eigen::SparseMatrix<double> StepAssembly::reducedMatrix(const ElasticModel& model) const {
  const std::size_t rows = model.freeNodeCount();
  const BlockSparsity& sp = model.sparsity();
  if (blocks_.size() != sp.blockCount() || diagonalInverse_.size() != rows) return {};
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

}  // namespace voxcut
