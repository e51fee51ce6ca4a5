#include "voxcut/sim/BladeFront.h"

#include <algorithm>
#include <cmath>

#include "voxcut/core/Error.h"

namespace voxcut {

std::vector<Vec3d> sampleBlade(const BladePose& pose, int segments) {
  VOXCUT_ASSERT(segments >= 1, "sampleBlade: at least one segment");
  std::vector<Vec3d> out(static_cast<std::size_t>(segments) + 1);
  for (int i = 0; i <= segments; ++i) {
    const double s = static_cast<double>(i) / segments;
    out[static_cast<std::size_t>(i)] =
        i == segments ? pose.b : Vec3d(pose.a + s * (pose.b - pose.a));
  }
  return out;
}

BladeFront embedFront(const std::vector<Vec3d>& points, const std::vector<std::uint64_t>& ids,
                      const DeformationOctree& d) {
  VOXCUT_ASSERT(ids.size() == points.size(), "embedFront: one id per point");
  BladeFront f;
  f.world = points;
  f.ids = ids;
  f.element.assign(points.size(), kNoElement);
  f.local.assign(points.size(), Vec3d::Zero());
  std::vector<Eigen::AlignedBox3d> boxes;
  d.updateElementBounds(boxes, false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3d& p = points[i];
    for (std::uint32_t e = 0; e < boxes.size(); ++e) {
      Eigen::AlignedBox3d box = boxes[e];
      box.extend(box.min() - Vec3d::Constant(1e-9 * d.voxelSize()));
      box.extend(box.max() + Vec3d::Constant(1e-9 * d.voxelSize()));
      if (!box.contains(p)) continue;
      Vec3d xi;
      if (!d.trilinearCoordinates(e, p, xi)) continue;
      const OctreeElement& el = d.element(e);
      // The voxel of the cube at xi: a copy that owns it is the one holding this point.
      Index3 vox = el.firstVoxel();
      for (int k = 0; k < 3; ++k)
        vox[k] += std::clamp(static_cast<int>(std::floor(xi[k] * el.size())), 0, el.size() - 1);
      const Index3& dims = d.gridDims();
      const bool inGrid = vox.x < dims.x && vox.y < dims.y && vox.z < dims.z;
      const bool owns =
          inGrid &&
          d.owner(static_cast<std::size_t>(vox.x) +
                  static_cast<std::size_t>(dims.x) *
                      (static_cast<std::size_t>(vox.y) +
                       static_cast<std::size_t>(dims.y) * static_cast<std::size_t>(vox.z))) == e;
      if (f.element[i] == kNoElement || owns) {
        f.element[i] = e;
        f.local[i] = xi;
      }
      if (owns) break;
    }
  }
  return f;
}

void frontStart(const BladeFront& f, const DeformationOctree& d, std::uint64_t newIdBase,
                std::vector<Vec3d>& points, std::vector<std::uint64_t>& ids,
                const std::vector<Vec3d>* end) {
  VOXCUT_ASSERT(end == nullptr || end->size() == f.world.size(), "one blade sample per point");
  points = f.world;
  ids = f.ids;
  const double still = 1e-9 * d.voxelSize();
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (f.element[i] == kNoElement) continue;
    const Vec3d now = d.pointInElement(f.element[i], f.local[i]);
    const double moved = (now - f.world[i]).norm();
    double away = kFrontFollow * d.voxelSize();
    if (end != nullptr) away = std::max(away, kFrontFollowBlade * ((*end)[i] - f.world[i]).norm());
    if (moved <= still || moved > away) continue;
    points[i] = now;
    ids[i] = newIdBase + i;
  }
}

std::vector<BladeSweep> sweepStrip(const std::vector<Vec3d>& start,
                                   const std::vector<std::uint64_t>& startIds,
                                   const std::vector<Vec3d>& end,
                                   const std::vector<std::uint64_t>& endIds, std::uint64_t frame) {
  VOXCUT_ASSERT(start.size() == end.size() && start.size() >= 2 &&
                    startIds.size() == start.size() && endIds.size() == end.size(),
                "sweepStrip: two polylines of equal length with ids");
  std::vector<BladeSweep> out;
  out.reserve(start.size() - 1);
  for (std::size_t i = 0; i + 1 < start.size(); ++i) {
    const BladePose from{start[i], start[i + 1]}, to{end[i], end[i + 1]};
    out.push_back(
        makeSweep(from, to, {startIds[i], startIds[i + 1], endIds[i + 1], endIds[i]}, frame));
  }
  return out;
}

}  // namespace voxcut
