#include "voxcut/fem/RigidCorrection.h"

#include <algorithm>
#include <cmath>

#include "voxcut/core/Parallel.h"

namespace voxcut {

namespace {

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

void RigidCorrection::setup(const ElasticModel& model, const BlockMatrixView& view,
                            const std::vector<Vec3d>& freePositions,
                            const std::vector<double>& freeMasses,
                            const std::vector<double>& massRow,
                            const std::vector<PointContact>& contacts,
                            const RowCoupling* coupling) {
  const std::size_t rows = model.freeNodeCount();
  rigid_.setup(model.sparsity(), model.sparsityRevision(), freePositions, freeMasses);
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
  for (const PointContact& pc : contacts)
    for (std::uint32_t n : model.elementNodes()[pc.element])
      for (std::uint32_t k = pr.start[n]; k < pr.start[n + 1]; ++k)
        freePiece_[piece[pr.index[k]]] = 0;
  // A times the modes, a free piece's translations as massRow c.
  const Eigen::Matrix3d* blocks = view.blocks;
  const std::uint32_t* column = view.column;
  const std::uint32_t* rowStart = view.rowStart;
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
                                       ? Vec3d(massRow[i] * rigid_.mode(static_cast<int>(k))[i])
                                       : az[k];
        }
      },
      model.threaded());
  rigid_.setOperator(rigidProducts_, coupling);
}

void RigidCorrection::freePieceMeans(const std::vector<Vec3d>& v,
                                     const std::vector<double>& massRow,
                                     std::vector<Vec3d>& out) const {
  const std::size_t rows = v.size();
  const std::vector<std::uint32_t>& piece = rigid_.piece();
  std::vector<Vec3d> mean(rigid_.pieceCount(), Vec3d::Zero());
  std::vector<double> weight(rigid_.pieceCount(), 0.0);
  for (std::size_t i = 0; i < rows; ++i) {
    mean[piece[i]] += massRow[i] * v[i];
    weight[piece[i]] += massRow[i];
  }
  for (std::size_t i = 0; i < rows; ++i)
    out[i] = freePiece_[piece[i]] && weight[piece[i]] > 0.0
                 ? Vec3d(mean[piece[i]] / weight[piece[i]])
                 : Vec3d::Zero();
}

bool RigidCorrection::anyFreePiece() const {
  return std::any_of(freePiece_.begin(), freePiece_.end(), [](std::uint8_t f) { return f != 0; });
}

}  // namespace voxcut
