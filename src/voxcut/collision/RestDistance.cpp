#include "voxcut/collision/RestDistance.h"

#include <algorithm>
#include <functional>

#include "voxcut/core/Error.h"

namespace voxcut {
namespace {

using HeapEntry = std::pair<float, std::uint64_t>;  // (distance, voxel), smallest first

void push(std::vector<HeapEntry>& heap, float d, std::uint64_t v) {
  heap.emplace_back(d, v);
  std::push_heap(heap.begin(), heap.end(), std::greater<>());
}

}  // namespace

void RestDistanceField::ownFeatures(const VoxelGrid& grid, std::size_t v,
                                    std::vector<Feature>& out) const {
  out.clear();
  const Index3 c = grid.coord(v);
  const Vec3d centre = grid.position(v);
  const double h = grid.voxelSize();
  for (int a = 0; a < 3; ++a)
    for (int sign : {-1, 1}) {
      Vec3d dir = Vec3d::Zero();
      dir[a] = sign;
      const bool onGrid = sign > 0 ? c[a] + 1 < grid.dims()[a] : c[a] > 0;
      Vec3d point = centre + 0.5 * h * dir, normal = dir;
      if (onGrid) {
        const std::size_t lower = sign > 0 ? v : v - grid.stride(a);
        if (grid.connected(lower, a)) continue;  // not a boundary face
        if (const Hermite* he = grid.hermite().find(VoxelGrid::linkId(lower, a))) {
          Vec3d e = Vec3d::Zero();
          e[a] = 1.0;
          point = grid.position(lower) + static_cast<double>(he->t) * h * e;
          const Vec3d n(he->n[0], he->n[1], he->n[2]);
          // The Hermite normal of a cut is the blade's, the same for both sides: outward for
          // this voxel is the way of the face. A normal nearly along the face keeps the face's.
          if (std::abs(n.dot(dir)) > 0.1 * n.norm()) normal = n.dot(dir) > 0 ? n : Vec3d(-n);
          normal.normalize();
        }
      }
      Feature f;
      for (int i = 0; i < 3; ++i) {
        f.point[i] = static_cast<float>(point[i]);
        f.normal[i] = static_cast<float>(normal[i]);
      }
      f.distance = static_cast<float>((point - centre).norm());
      out.push_back(f);
    }
  std::stable_sort(out.begin(), out.end(),
                   [](const Feature& x, const Feature& y) { return x.distance < y.distance; });
}

template <class InRegion>
void RestDistanceField::propagate(const VoxelGrid& grid, std::vector<HeapEntry>& heap,
                                  InRegion&& inRegion) {
  const double limit = band_ * grid.voxelSize();
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end(), std::greater<>());
    const auto [d, v] = heap.back();
    heap.pop_back();
    const Feature* here = field_.find(v);
    if (here == nullptr || here->distance < d) continue;  // a stale entry
    const Feature f = *here;
    const Vec3d point(f.point[0], f.point[1], f.point[2]);
    const Index3 c = grid.coord(v);
    for (int a = 0; a < 3; ++a)
      for (int sign : {-1, 1}) {
        if (sign > 0 ? c[a] + 1 >= grid.dims()[a] : c[a] == 0) continue;
        const std::size_t w = sign > 0 ? v + grid.stride(a) : v - grid.stride(a);
        if (!grid.connected(sign > 0 ? v : w, a) || !inRegion(w)) continue;
        const double exact = (point - grid.position(w)).norm();
        if (exact > limit) continue;
        // Compared as stored (float): a rounded-up distance would otherwise never settle.
        const auto dw = static_cast<float>(exact);
        const Feature* there = field_.find(w);
        if (there != nullptr && there->distance <= dw) continue;
        Feature g = f;
        g.distance = dw;
        field_.set(w, g);
        push(heap, g.distance, w);
      }
  }
}

void RestDistanceField::build(const VoxelGrid& grid, int band) {
  VOXCUT_ASSERT(band >= 1, "the band is at least one voxel");
  band_ = band;
  field_ = FlatHashMap<Feature>();
  std::vector<HeapEntry> heap;
  std::vector<Feature> own;
  for (std::size_t v = 0; v < grid.voxelCount(); ++v) {
    if (!grid.occupied(v)) continue;
    ownFeatures(grid, v, own);
    if (own.empty()) continue;
    field_.set(v, own.front());
    heap.emplace_back(own.front().distance, v);
  }
  std::make_heap(heap.begin(), heap.end(), std::greater<>());
  propagate(grid, heap, [](std::size_t) { return true; });
}

void RestDistanceField::update(const VoxelGrid& grid, const std::vector<std::uint64_t>& changed) {
  if (changed.empty()) return;
  // The region: every voxel within band + 1 (Chebyshev) of a changed link's ends, found by
  // dilating the ends one axis at a time (so each voxel of the region is listed once). The
  // voxels just outside it keep their features, which flow back in: propagation passes a
  // feature only from neighbour to neighbour.
  const int r = band_ + 1;
  std::vector<std::uint64_t> region;
  for (std::uint64_t link : changed) {
    const std::size_t v = static_cast<std::size_t>(link / 3);
    const int a = static_cast<int>(link % 3);
    region.push_back(v);
    if (grid.hasLink(v, a)) region.push_back(v + grid.stride(a));
  }
  std::sort(region.begin(), region.end());
  region.erase(std::unique(region.begin(), region.end()), region.end());
  for (int a = 0; a < 3; ++a) {
    FlatHashMap<std::uint8_t> seen;
    std::vector<std::uint64_t> next;
    for (std::uint64_t v : region) {
      const int c = grid.coord(v)[a];
      for (int d = std::max(-r, -c); d <= std::min(r, grid.dims()[a] - 1 - c); ++d) {
        const std::uint64_t w = d >= 0 ? v + static_cast<std::uint64_t>(d) * grid.stride(a)
                                       : v - static_cast<std::uint64_t>(-d) * grid.stride(a);
        if (seen.insert(w, 1)) next.push_back(w);
      }
    }
    region = std::move(next);
  }
  std::sort(region.begin(), region.end());  // a fixed order, whatever the tables'
  FlatHashMap<std::uint8_t> inRegion;
  inRegion.reserve(region.size());
  for (std::uint64_t v : region) inRegion.insert(v, 1);
  for (std::uint64_t v : region) (void)field_.erase(v);
  std::vector<HeapEntry> heap;
  std::vector<Feature> own;
  std::vector<std::uint64_t> ring;
  for (std::uint64_t v : region) {
    const Index3 c = grid.coord(v);
    for (int a = 0; a < 3; ++a) {
      if (c[a] + 1 < grid.dims()[a] && !inRegion.contains(v + grid.stride(a)))
        ring.push_back(v + grid.stride(a));
      if (c[a] > 0 && !inRegion.contains(v - grid.stride(a))) ring.push_back(v - grid.stride(a));
    }
    if (!grid.occupied(v)) continue;
    ownFeatures(grid, v, own);
    if (own.empty()) continue;
    field_.set(v, own.front());
    heap.emplace_back(own.front().distance, v);
  }
  std::sort(ring.begin(), ring.end());
  ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
  for (std::uint64_t v : ring)
    if (const Feature* f = field_.find(v)) heap.emplace_back(f->distance, v);
  std::make_heap(heap.begin(), heap.end(), std::greater<>());
  propagate(grid, heap, [&](std::size_t v) { return inRegion.contains(v); });
}

bool RestDistanceField::depth(const VoxelGrid& grid, std::size_t v, const Vec3d& x, double& depth,
                              Vec3d& normal) const {
  if (!grid.occupied(v)) return false;
  bool found = false;
  auto consider = [&](const Feature& f) {
    const Vec3d n(f.normal[0], f.normal[1], f.normal[2]);
    const double d = n.dot(Vec3d(f.point[0], f.point[1], f.point[2]) - x);
    if (!found || d < depth) {
      depth = d;
      normal = n;
      found = true;
    }
  };
  std::vector<Feature> own;
  ownFeatures(grid, v, own);
  for (const Feature& f : own) consider(f);
  if (const Feature* f = field_.find(v)) consider(*f);
  const Index3 c = grid.coord(v);
  for (int a = 0; a < 3; ++a)
    for (int sign : {-1, 1}) {
      if (sign > 0 ? c[a] + 1 >= grid.dims()[a] : c[a] == 0) continue;
      const std::size_t w = sign > 0 ? v + grid.stride(a) : v - grid.stride(a);
      if (!grid.connected(sign > 0 ? v : w, a)) continue;
      if (const Feature* f = field_.find(w)) consider(*f);
    }
  return found;
}

}  // namespace voxcut
