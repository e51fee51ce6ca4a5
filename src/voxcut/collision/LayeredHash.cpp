#include "voxcut/collision/LayeredHash.h"

#include <cmath>
#include <limits>

namespace voxcut {

namespace {

constexpr int kMaxLayers = 24;  // size classes beyond 2^23 times the smallest share the last

bool registrable(const Eigen::AlignedBox3d& b) {
  return !b.isEmpty() && b.min().allFinite() && b.max().allFinite();
}

}  // namespace

void LayeredHash::build(const std::vector<Eigen::AlignedBox3d>& boxes, bool threaded) {
  boxes_ = boxes;
  double smallest = std::numeric_limits<double>::infinity();
  for (const Eigen::AlignedBox3d& b : boxes)
    if (registrable(b)) {
      const double side = b.sizes().maxCoeff();
      if (side > 0.0) smallest = std::min(smallest, side);
    }
  // The size class of a box: floor(log2(side / smallest)); points go with the finest.
  std::vector<std::uint8_t> layerOf(boxes.size(), 0xff);
  std::array<std::size_t, kMaxLayers> members{};
  for (std::size_t e = 0; e < boxes.size(); ++e) {
    if (!registrable(boxes[e])) continue;
    const double side = boxes[e].sizes().maxCoeff();
    int k = 0;
    if (side > 0.0 && std::isfinite(smallest)) {
      const double ratio = side / smallest;
      k = std::isfinite(ratio) ? std::min(kMaxLayers - 1, std::ilogb(ratio)) : kMaxLayers - 1;
    }
    layerOf[e] = static_cast<std::uint8_t>(k);
    ++members[static_cast<std::size_t>(k)];
  }
  layers_.clear();
  std::array<int, kMaxLayers> slot{};
  for (int k = 0; k < kMaxLayers; ++k) {
    slot[static_cast<std::size_t>(k)] = -1;
    if (members[static_cast<std::size_t>(k)] == 0) continue;
    slot[static_cast<std::size_t>(k)] = static_cast<int>(layers_.size());
    layers_.emplace_back();
    layers_.back().ids.reserve(members[static_cast<std::size_t>(k)]);
  }
  std::vector<std::vector<Eigen::AlignedBox3d>> layerBoxes(layers_.size());
  for (std::size_t e = 0; e < boxes.size(); ++e) {
    if (layerOf[e] == 0xff) continue;
    const auto l = static_cast<std::size_t>(slot[layerOf[e]]);
    layers_[l].ids.push_back(static_cast<std::uint32_t>(e));
    layerBoxes[l].push_back(boxes[e]);
  }
  for (std::size_t l = 0; l < layers_.size(); ++l)
    layers_[l].hash.build(layerBoxes[l], 0.0, threaded);
}

std::vector<std::uint32_t> LayeredHash::elementsInBox(const Eigen::AlignedBox3d& box) const {
  std::vector<std::uint32_t> out;
  for (const Layer& layer : layers_) {
    if (layer.hash.cellsTouching(box) > static_cast<double>(layer.ids.size())) {
      // A query far larger than this layer's cells: its boxes one by one.
      for (const std::uint32_t e : layer.ids)
        if (boxes_[e].intersects(box)) out.push_back(e);
      continue;
    }
    for (const std::uint32_t k : layer.hash.elementsInBox(box)) out.push_back(layer.ids[k]);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace voxcut
