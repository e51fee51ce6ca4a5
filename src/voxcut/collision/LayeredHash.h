#pragma once
/// @file LayeredHash.h
/// Spatial hashes of boxes in layers by size (docs/algorithms.md, "Culling"): a box goes to the
/// layer of its size class (its largest side, in powers of two above the smallest box's), and
/// each layer is a SpatialHash whose cells are as large as that layer's largest box. So every
/// box touches at most 8 cells of its layer, and a cell holds boxes of about its own size: a
/// few coarse elements and many fine ones (a body refined along a cut) do not crowd the fine
/// ones into the coarse ones' cells, as one hash sized by the largest box would. Queries visit
/// every layer. Deterministic for any thread count; queries are const and may run
/// concurrently with each other, not with build().

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <vector>

#include "voxcut/collision/SpatialHash.h"
#include "voxcut/core/Types.h"

namespace voxcut {

class LayeredHash {
 public:
  /// Rebuilds the layers over `boxes` (metres; element e is boxes[e]). Empty or non-finite
  /// boxes are not registered. O(#boxes + #entries).
  void build(const std::vector<Eigen::AlignedBox3d>& boxes, bool threaded = true);

  /// Number of boxes given to the last build (registered or not).
  [[nodiscard]] std::size_t elementCount() const { return boxes_.size(); }
  /// The box given for element e to the last build.
  [[nodiscard]] const Eigen::AlignedBox3d& elementBox(std::uint32_t e) const { return boxes_[e]; }
  /// Number of layers holding boxes.
  [[nodiscard]] std::size_t layerCount() const { return layers_.size(); }

  /// Elements registered in any non-empty cell of any layer that touches `bounds` and for
  /// which overlapsCell(that cell's box) is true (e.g. an OBB test), sorted and unique. In a
  /// layer where `bounds` spans more cells than the layer holds boxes, its boxes are taken one
  /// by one instead: those that meet `bounds` and pass overlapsCell(their own box). Either way
  /// every box that meets `bounds` and whose cells, or itself, pass the test is listed; the
  /// boxes are not tested further.
  template <class CellTest>
  [[nodiscard]] std::vector<std::uint32_t> elements(const Eigen::AlignedBox3d& bounds,
                                                    CellTest&& overlapsCell) const {
    std::vector<std::uint32_t> out;
    for (const Layer& layer : layers_) {
      if (layer.hash.cellsTouching(bounds) > static_cast<double>(layer.ids.size())) {
        for (const std::uint32_t e : layer.ids)
          if (boxes_[e].intersects(bounds) && overlapsCell(boxes_[e])) out.push_back(e);
        continue;
      }
      for (const std::uint32_t k : layer.hash.elements(bounds, overlapsCell))
        out.push_back(layer.ids[k]);
    }
    std::sort(out.begin(), out.end());
    return out;
  }

  /// Elements whose box overlaps `box` (closed boxes), sorted and unique.
  [[nodiscard]] std::vector<std::uint32_t> elementsInBox(const Eigen::AlignedBox3d& box) const;

  /// Calls fn(element) for each element registered in a cell that holds point p: layer by
  /// layer, in increasing id within a layer; an element is called at most once.
  template <class Fn>
  void forEachNear(const Vec3d& p, Fn&& fn) const {
    for (const Layer& layer : layers_)
      layer.hash.forEachInCell(layer.hash.cellOf(p), [&](std::uint32_t k) { fn(layer.ids[k]); });
  }

 private:
  struct Layer {
    SpatialHash hash;
    std::vector<std::uint32_t> ids;  ///< the element of each of the layer's boxes
  };
  std::vector<Layer> layers_;  ///< non-empty layers, finest first
  std::vector<Eigen::AlignedBox3d> boxes_;
};

}  // namespace voxcut
