#include "voxcut/fem/FactorBridge.h"

#include <algorithm>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/linalg/BlockCholesky.h"
#include "voxcut/linalg/BlockPreconditioner.h"
#include "voxcut/topology/DeformationOctree.h"

namespace voxcut {

void FactorBridge::reset(const ElasticModel& model) {
  const WeightedRows& p = model.prolongation();
  VOXCUT_ASSERT(p.rows() == model.nodeCount(), "one prolongation row per node");
  start_ = p.start;
  row_ = p.index;
  weight_ = p.weight;
  dirty_.assign(model.nodeCount(), 0);
  newElement_.assign(model.elementCount(), 0);
  valid_ = true;
}

void FactorBridge::update(const TopologyChange& change) {
  if (!valid_ || !change.changed) return;
  const std::size_t oldNodes = start_.size() - 1;
  std::vector<std::uint32_t> start{0}, row;
  std::vector<double> weight;
  std::vector<std::uint8_t> dirty(change.nodeSource.size(), 0);
  std::vector<std::pair<std::uint32_t, double>> terms;
  row.reserve(row_.size() +
              8 * (change.nodeSource.size() - std::min(change.nodeSource.size(), oldNodes)));
  for (std::size_t n = 0; n < change.nodeSource.size(); ++n) {
    const NodeSource& src = change.nodeSource[n];
    terms.clear();
    bool d = src.count != 1 || src.weights[0] != 1.0;
    for (int k = 0; k < src.count; ++k) {
      const std::uint32_t old = src.nodes[static_cast<std::size_t>(k)];
      if (old >= oldNodes) {  // not the model the bridge follows: give up on it
        valid_ = false;
        return;
      }
      d = d || dirty_[old] != 0;
      for (std::uint32_t q = start_[old]; q < start_[old + 1]; ++q)
        terms.emplace_back(row_[q], src.weights[static_cast<std::size_t>(k)] * weight_[q]);
    }
    std::sort(terms.begin(), terms.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    const std::size_t first = row.size();
    for (const auto& [r, w] : terms) {
      if (row.size() > first && row.back() == r)
        weight.back() += w;
      else {
        row.push_back(r);
        weight.push_back(w);
      }
    }
    start.push_back(static_cast<std::uint32_t>(row.size()));
    dirty[n] = d ? 1 : 0;
  }
  std::vector<std::uint8_t> created(change.elementSource.size(), 0);
  for (std::size_t e = 0; e < created.size(); ++e) {
    const std::uint32_t s = change.elementSource[e];
    created[e] = s == kNewElement || (s < newElement_.size() && newElement_[s] != 0) ? 1 : 0;
  }
  start_ = std::move(start);
  row_ = std::move(row);
  weight_ = std::move(weight);
  dirty_ = std::move(dirty);
  newElement_ = std::move(created);
}

bool FactorBridge::prepare(const ElasticModel& model, const DeformationOctree& octree,
                           std::size_t factorRows) {
  if (!valid_) return false;
  if (start_.size() != model.nodeCount() + 1 || newElement_.size() != octree.elementCount() ||
      octree.nodeCount() != model.nodeCount()) {
    valid_ = false;
    return false;
  }
  // Nodes of elements created since the factor: their rows changed shape.
  std::vector<std::uint8_t> touched = dirty_;
  for (std::size_t e = 0; e < newElement_.size(); ++e)
    if (newElement_[e])
      for (std::uint32_t n : octree.element(static_cast<std::uint32_t>(e)).nodes) touched[n] = 1;
  const std::vector<std::uint32_t>& freeNodes = model.freeNodes();
  const std::size_t rows = freeNodes.size();
  freeStart_.assign(1, 0);
  freeRow_.clear();
  freeWeight_.clear();
  local_.assign(rows, 0);
  std::vector<std::uint32_t> claims(factorRows, 0);
  for (std::size_t i = 0; i < rows; ++i) {
    const std::uint32_t n = freeNodes[i];
    for (std::uint32_t q = start_[n]; q < start_[n + 1]; ++q) {
      if (row_[q] >= factorRows) {
        valid_ = false;
        return false;
      }
      freeRow_.push_back(row_[q]);
      freeWeight_.push_back(weight_[q]);
    }
    freeStart_.push_back(static_cast<std::uint32_t>(freeRow_.size()));
    const bool single = start_[n + 1] == start_[n] + 1 && weight_[start_[n]] == 1.0;
    if (touched[n] || !single)
      local_[i] = 1;
    else
      ++claims[row_[start_[n]]];
  }
  localList_.clear();
  for (std::size_t i = 0; i < rows; ++i)
    if (!local_[i] && claims[freeRow_[freeStart_[i]]] > 1) local_[i] = 1;
  // Grown by one ring of neighbours: rows next to a change see a changed row of A too (fewer
  // iterations per cut step; more rings gain nothing: docs/performance.md, "Deformation solver").
  const BlockSparsity& sp = model.sparsity();
  const auto withNeighbours = [&](const std::vector<std::uint8_t>& flags) {
    std::vector<std::uint8_t> out = flags;
    for (std::size_t i = 0; i < rows; ++i)
      if (flags[i])
        for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s) out[sp.column[s]] = 1;
    return out;
  };
  local_ = withNeighbours(local_);
  // The rows a change of u on the local rows reaches (their neighbours).
  const std::vector<std::uint8_t> halo = withNeighbours(local_);
  haloList_.clear();
  for (std::size_t i = 0; i < rows; ++i) {
    if (local_[i]) localList_.push_back(static_cast<std::uint32_t>(i));
    if (halo[i]) haloList_.push_back(static_cast<std::uint32_t>(i));
  }
  coarse_.assign(factorRows, Vec3d::Zero());
  return true;
}

void FactorBridge::apply(const BlockSparsity& sp, const std::vector<Eigen::Matrix3d>& blocks,
                         BlockCholesky& factor, const std::vector<Eigen::Matrix3d>& diagonalInverse,
                         const std::vector<Vec3d>& r, std::vector<Vec3d>& z) {
  const std::size_t rows = local_.size();
  VOXCUT_ASSERT(
      valid_ && r.size() == rows && diagonalInverse.size() == rows && sp.diagonal.size() == rows,
      "FactorBridge::apply: prepare() first, for this system");
  const Eigen::Matrix3d* a = blocks.data();
  const std::uint32_t* column = sp.column.data();
  const auto rowProduct = [&](const std::vector<Vec3d>& x, std::uint32_t i) {
    return blockRowProduct(a, column, x.data(), sp.rowStart[i], sp.rowStart[i + 1]);
  };
  // Forward Gauss-Seidel over the local rows (u is zero elsewhere and on the rows not reached
  // yet, so the whole row's product is the sum over the rows already updated).
  u_.assign(rows, Vec3d::Zero());
  for (const std::uint32_t i : localList_) u_[i] = diagonalInverse[i] * (r[i] - rowProduct(u_, i));
  // t = r - A u: u is zero off the local rows, so only their neighbours differ from r.
  t_ = r;
  for (const std::uint32_t i : haloList_) t_[i] = r[i] - rowProduct(u_, i);
  // Coarse correction through the earlier factor: u += B C^-1 B^T t.
  std::fill(coarse_.begin(), coarse_.end(), Vec3d::Zero());
  for (std::size_t i = 0; i < rows; ++i)
    for (std::uint32_t q = freeStart_[i]; q < freeStart_[i + 1]; ++q)
      coarse_[freeRow_[q]] += freeWeight_[q] * t_[i];
  factor.solve(coarse_, coarse_);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::uint32_t q = freeStart_[i]; q < freeStart_[i + 1]; ++q)
      u_[i] += freeWeight_[q] * coarse_[freeRow_[q]];
  // Backward Gauss-Seidel over the local rows on the correction d (in z, zero elsewhere),
  // which needs r - A u on those rows only.
  for (const std::uint32_t i : localList_) t_[i] = r[i] - rowProduct(u_, i);
  z.assign(rows, Vec3d::Zero());
  for (auto it = localList_.rbegin(); it != localList_.rend(); ++it) {
    const std::uint32_t i = *it;
    z[i] = diagonalInverse[i] * (t_[i] - rowProduct(z, i));
  }
  for (std::size_t i = 0; i < rows; ++i) z[i] += u_[i];
}

}  // namespace voxcut
