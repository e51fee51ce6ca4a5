#include "voxcut/fem/WarmStart.h"

#include <algorithm>
#include <utility>

#include "voxcut/core/Error.h"

namespace voxcut {

void remapByNode(const TopologyChange& change, std::vector<Vec3d>& values) {
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
}

void WarmStart::resize(const ElasticModel& model) {
  if (lastDv_.empty()) lastDv_.assign(model.nodeCount(), Vec3d::Zero());
  VOXCUT_ASSERT(lastDv_.size() == model.nodeCount(),
                "the warm start does not match the model (missing updateTopology?)");
}

void WarmStart::reset() {
  lastDv_.clear();
  projection_.clear();
  projectionByNode_ = false;
  projecting_ = false;
}

void WarmStart::updateTopology(const TopologyChange& change) {
  auto remap = [&](std::vector<Vec3d>& values) { remapByNode(change, values); };
  remap(lastDv_);
  // The kept solutions follow as the velocities do, by node (their free rows are known at the
  // next solve).
  if (!projectionByNode_) projectionToNodes();
  projection_.transform(remap);
}

void WarmStart::keep(const std::vector<std::uint32_t>& freeNodes, const std::vector<Vec3d>& x) {
  for (std::size_t i = 0; i < freeNodes.size(); ++i) lastDv_[freeNodes[i]] = x[i];
}

void WarmStart::forget() { std::fill(lastDv_.begin(), lastDv_.end(), Vec3d::Zero()); }

void WarmStart::projectionToNodes() {
  projection_.transform([&](std::vector<Vec3d>& h) {
    std::vector<Vec3d> byNode(lastNodeCount_, Vec3d::Zero());
    for (std::size_t i = 0; i < h.size() && i < lastFreeNodes_.size(); ++i)
      byNode[lastFreeNodes_[i]] = h[i];
    h = std::move(byNode);
  });
  projectionByNode_ = projection_.size() > 0;
}

bool WarmStart::project(const ElasticModel& model, const ImplicitEulerParams& params,
                        const BlockMatrixView& view, const RowCoupling* coupling,
                        const std::vector<Vec3d>& b, const std::vector<double>& massRow,
                        const std::vector<Vec3d>& shift, std::vector<Vec3d>& q,
                        std::vector<Vec3d>& x, bool threaded) {
  const std::size_t rows = model.freeNodeCount();
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
  projection_.setCapacity(static_cast<std::size_t>(std::max(params.projectionHistory, 0)));
  if (!(params.warmStart && projecting_ && projection_.size() > 0)) return false;
  projectionRhs_.resize(rows);
  for (std::size_t i = 0; i < rows; ++i) projectionRhs_[i] = b[i] - massRow[i] * shift[i];
  const bool projected = projection_.project(view, projectionRhs_, q, threaded, coupling);
  if (projected)
    for (std::size_t i = 0; i < rows; ++i) x[i] = shift[i] + q[i];
  return projected;
}

void WarmStart::finishSolve(int history, bool projected, int iterations,
                            const std::vector<Vec3d>* solution) {
  projecting_ = projected ? 2 * iterations >= history : iterations > history;
  if (solution != nullptr && history > 0) projection_.add(*solution);
}

}  // namespace voxcut
