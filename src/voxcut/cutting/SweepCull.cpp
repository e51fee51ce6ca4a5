#include "voxcut/cutting/SweepCull.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "voxcut/core/Parallel.h"

namespace voxcut {
namespace {

// The longest voxel step in element e: along axis a, a voxel step moves by at most the longest
// of the element's 4 edges along a over its size (the derivative of the trilinear map along a
// blends those edges); the largest over the three axes.
double longestStep(const DeformationOctree& d, std::uint32_t e) {
  const Vec3d* x = d.positions().data();
  const OctreeElement& el = d.element(e);
  double edge = 0.0;
  for (int k = 0; k < 8; ++k)
    for (int a = 0; a < 3; ++a)
      if (((k >> a) & 1) == 0)
        edge = std::max(edge, (x[el.nodes[k | (1 << a)]] - x[el.nodes[k]]).squaredNorm());
  return std::sqrt(edge) * el.inverseSize();
}

// An allowance for the rounding of positions near an element's box: the block tests grow
// their boxes by it beyond the voxel tests, so that a block holding a voxel that a box holds
// is never dropped.
double roundingSlack(const Eigen::AlignedBox3d& box, double voxelSize) {
  const double scale = std::max(box.min().cwiseAbs().maxCoeff(), box.max().cwiseAbs().maxCoeff());
  return 1e-9 * (voxelSize + (std::isfinite(scale) ? scale : 0.0));
}

// Whether the convex hull of points p[0..n) (whose axis-aligned box is `hull`) meets `box`
// grown by `grow` along each of its axes (tested along the box's axes only: it may keep a hull
// that misses, never drop one that meets).
bool hullMeets(const CullBox& box, const Eigen::AlignedBox3d& hull, const Vec3d* p, int n,
               double grow) {
  const Vec3d g = grow * box.spread;
  if (!hull.intersects(Eigen::AlignedBox3d(box.bounds.min() - g, box.bounds.max() + g)))
    return false;
  for (int i = 0; i < 3; ++i) {
    const Vec3d axis = box.axes.col(i);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (int k = 0; k < n; ++k) {
      const double s = axis.dot(p[k] - box.centre);
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    const double half = box.halfExtents[i] + grow;
    if (lo > half || hi < -half) return false;
  }
  return true;
}

// Whether point p lies in `box` grown by `grow` along each of its axes.
bool holds(const CullBox& box, const Vec3d& p, double grow) {
  const Vec3d q = p - box.centre;
  for (int i = 0; i < 3; ++i)
    if (std::abs(box.axes.col(i).dot(q)) > box.halfExtents[i] + grow) return false;
  return true;
}

}  // namespace

SweepCull cullSweeps(CutBody& b, const std::vector<BladeSweep>& sweeps, bool threaded) {
  if (threaded) wakeWorkers();  // the element queries are serial, the candidates' search is not
  const DeformationOctree& d = b.deformation;
  d.updateElementBounds(b.elementBoxes, threaded);
  const double h = b.grid.voxelSize();
  const std::size_t n = b.elementBoxes.size();
  SweepCull out;
  out.reach.resize(n);
  // Each element's box grown by its reach (and by the rounding allowance of the block tests
  // twice over) goes into the hash: an element lies under a sweep's box when its grown box
  // meets it, and only then can a voxel it owns lie within its reach of the box.
  std::vector<Eigen::AlignedBox3d> grown(n);
  parallelFor(
      0, n, 2048,
      [&](std::size_t e0, std::size_t e1) {
        for (std::size_t e = e0; e < e1; ++e) {
          const Eigen::AlignedBox3d& box = b.elementBoxes[e];
          out.reach[e] = longestStep(d, static_cast<std::uint32_t>(e)) * (1.0 + 1e-9) + 1e-9 * h;
          const Vec3d g = Vec3d::Constant(out.reach[e] + 2.0 * roundingSlack(box, h));
          grown[e] = Eigen::AlignedBox3d(box.min() - g, box.max() + g);
        }
      },
      threaded);
  b.hash.build(grown, threaded);

  std::vector<std::pair<std::uint32_t, std::uint32_t>> under;  // (element, box)
  for (const BladeSweep& sweep : sweeps) {
    const Obb obb = sweepObb(sweep, b.obbMargin);
    if (!obb.halfExtents.allFinite() || !obb.centre.allFinite()) continue;
    Eigen::AlignedBox3d obbBounds;
    for (int k = 0; k < 8; ++k) {
      Vec3d corner = obb.centre;
      for (int i = 0; i < 3; ++i)
        corner += ((k >> i) & 1 ? 1.0 : -1.0) * obb.halfExtents[i] * obb.axes.col(i);
      obbBounds.extend(corner);
    }
    // Padded by the rounding of the corners, so that the first test never drops what the
    // box itself holds.
    const double pad = 1e-9 * (obbBounds.diagonal().norm() + obb.centre.norm());
    const Vec3d spread = obb.axes.cwiseAbs().rowwise().sum() * (1.0 + 1e-9);
    const auto box = static_cast<std::uint32_t>(out.boxes.size());
    out.boxes.push_back({obb.centre, obb.axes, obb.halfExtents, spread,
                         static_cast<std::uint32_t>(&sweep - sweeps.data()),
                         Eigen::AlignedBox3d(obbBounds.min() - Vec3d::Constant(pad),
                                             obbBounds.max() + Vec3d::Constant(pad))});
    // The elements of the cells the box meets whose own grown box meets it.
    for (const std::uint32_t e : b.hash.elements(
             obbBounds, [&](const Eigen::AlignedBox3d& cell) { return overlaps(obb, cell); }))
      if (overlaps(obb, grown[e])) under.emplace_back(e, box);
  }
  std::sort(under.begin(), under.end());
  out.boxIndex.reserve(under.size());
  for (std::size_t i = 0; i < under.size(); ++i) {
    if (i == 0 || under[i].first != under[i - 1].first) {
      out.elements.push_back(under[i].first);
      out.boxStart.push_back(static_cast<std::uint32_t>(out.boxIndex.size()));
    }
    out.boxIndex.push_back(under[i].second);
  }
  out.boxStart.push_back(static_cast<std::uint32_t>(out.boxIndex.size()));
  return out;
}

void collectCandidates(const CutBody& b, const SweepCull& cull, std::size_t k,
                       ElementCandidates& out) {
  constexpr int kLeaf = 4;
  const DeformationOctree& d = b.deformation;
  const std::uint32_t e = cull.elements[k];
  const OctreeElement& el = d.element(e);
  const Index3 first = el.firstVoxel();
  const Index3 dims = b.grid.dims();
  const double inv = el.inverseSize();
  const VoxelOctree& oct = b.activity;
  const std::vector<CullBox>& boxes = cull.boxes;
  const double grow = cull.reach[e];
  const double blockGrow = grow + roundingSlack(b.elementBoxes[e], b.grid.voxelSize());
  // Per depth of the recursion, the boxes the block there meets (a block's list is read while
  // its children fill the next depth's): depth k's list is met[k * nb .. k * nb + metCount[k]).
  // The element's own list, from the hash, starts it.
  const std::uint32_t* list = cull.boxIndex.data() + cull.boxStart[k];
  const std::size_t nb = cull.boxStart[k + 1] - cull.boxStart[k];
  const auto depths = static_cast<std::size_t>(el.level) + 2;
  std::vector<std::uint32_t> met(depths * nb), metCount(depths, 0);
  std::copy(list, list + nb, met.begin());
  metCount[0] = static_cast<std::uint32_t>(nb);
  const auto visit = [&](const auto& self, const Index3& lo, int size, std::size_t depth) -> void {
    Index3 hi;  // last offset of the block inside the grid
    for (int a = 0; a < 3; ++a) {
      hi[a] = std::min(lo[a] + size, dims[a] - first[a]) - 1;
      if (hi[a] < lo[a]) return;
    }
    Vec3d corners[8];
    Eigen::AlignedBox3d hull;
    for (int c = 0; c < 8; ++c) {
      const Vec3d t(((c & 1) ? hi[0] : lo[0]) + 0.5, ((c & 2) ? hi[1] : lo[1]) + 0.5,
                    ((c & 4) ? hi[2] : lo[2]) + 0.5);
      corners[c] = d.pointInElement(e, t * inv);
      hull.extend(corners[c]);
    }
    const std::uint32_t* parent = met.data() + depth * nb;
    std::uint32_t* here = met.data() + (depth + 1) * nb;
    std::uint32_t count = 0;
    for (std::uint32_t j = 0; j < metCount[depth]; ++j)
      if (hullMeets(boxes[parent[j]], hull, corners, 8, blockGrow)) here[count++] = parent[j];
    metCount[depth + 1] = count;
    if (count == 0) return;
    if (size > kLeaf) {
      const int half = size / 2;
      for (int c = 0; c < 8; ++c)
        self(self,
             Index3{lo[0] + ((c & 1) ? half : 0), lo[1] + ((c & 2) ? half : 0),
                    lo[2] + ((c & 4) ? half : 0)},
             half, depth + 1);
      return;
    }
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y) {
        // The row's segment through the element, once per row (bitwise voxelPosition: the
        // voxel's offset in its owner is (x, y, z)).
        bool haveRow = false;
        detail::RowSegment row{Vec3d::Zero(), Vec3d::Zero()};
        for (int x = lo[0]; x <= hi[0]; ++x) {
          const std::size_t v = b.grid.index(Index3{first[0] + x, first[1] + y, first[2] + z});
          if (!oct.voxelActive(v) || d.owner(v) != e) continue;
          ++out.positioned;
          if (!haveRow) {
            row = detail::rowSegment(d.positions(), el.nodes, (y + 0.5) * inv, (z + 0.5) * inv);
            haveRow = true;
          }
          const Vec3d p = row.start + ((x + 0.5) * inv) * row.delta;
          const auto firstSweep = static_cast<std::uint32_t>(out.sweeps.size());
          for (std::uint32_t j = 0; j < count; ++j)
            if (holds(boxes[here[j]], p, grow)) out.sweeps.push_back(boxes[here[j]].sweep);
          const auto holding = static_cast<std::uint32_t>(out.sweeps.size()) - firstSweep;
          if (holding > 0) out.voxels.push_back({v, firstSweep, holding, p});
        }
      }
  };
  visit(visit, Index3{0, 0, 0}, el.size(), 0);
}

}  // namespace voxcut
