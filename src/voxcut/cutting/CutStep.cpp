#include "voxcut/cutting/CutStep.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"

namespace voxcut {
namespace {

// F^T n up to a positive factor, with F = dx/dX of element e at trilinear coordinates xi (rest
// frame). Column i of F is the derivative along xi_i of the trilinear map (divided by the
// element's size, a positive factor left out: the caller normalises), so component i of F^T n
// is that derivative of the scalar field x . n: the corners are projected on n first (8 dot
// products), then differentiated like any trilinear field.
Vec3d pullBackNormal(const DeformationOctree& d, std::uint32_t e, const Vec3d& xi, const Vec3d& n) {
  const auto& nodes = d.element(e).nodes;
  const Vec3d* x = d.positions().data();
  double q[8];
  for (int c = 0; c < 8; ++c) q[c] = x[nodes[c]].dot(n);
  // d/dxi_0: the x-differences blended over (xi_1, xi_2), and likewise for the other axes.
  const auto lerp = [](double a, double b, double t) { return a + t * (b - a); };
  const double dx00 = q[1] - q[0], dx10 = q[3] - q[2], dx01 = q[5] - q[4], dx11 = q[7] - q[6];
  const double dy00 = q[2] - q[0], dy10 = q[3] - q[1], dy01 = q[6] - q[4], dy11 = q[7] - q[5];
  const double dz00 = q[4] - q[0], dz10 = q[5] - q[1], dz01 = q[6] - q[2], dz11 = q[7] - q[3];
  return {lerp(lerp(dx00, dx10, xi[1]), lerp(dx01, dx11, xi[1]), xi[2]),
          lerp(lerp(dy00, dy10, xi[0]), lerp(dy01, dy11, xi[0]), xi[2]),
          lerp(lerp(dz00, dz10, xi[0]), lerp(dz01, dz11, xi[0]), xi[1])};
}

// Blade test of link (v, a) whose ends are now at pv and pw; Hermite data in the rest frame.
// Only the sweeps listed in `which` (ascending indices into sweeps; all when null) are tested:
// a caller that knows the link is far from the others leaves them out.
std::optional<Hermite> testLink(const CutBody& b, const std::vector<BladeSweep>& sweeps,
                                std::size_t v, int a, const Vec3d& pv, const Vec3d& pw,
                                const std::uint32_t* which = nullptr, std::size_t count = 0) {
  const std::size_t w = v + b.grid.stride(a);
  std::optional<SweepHit> hit;
  const std::size_t tests = which != nullptr ? count : sweeps.size();
  for (std::size_t k = 0; k < tests; ++k) {
    const BladeSweep& sweep = sweeps[which != nullptr ? which[k] : k];
    if (const auto h = intersectSegment(sweep, pv, pw, v, w); h && (!hit || h->t < hit->t)) hit = h;
  }
  if (!hit) return std::nullopt;
  // Pull the normal back with the element holding the nearer end.
  const std::size_t near = hit->t < 0.5 ? v : w;
  const std::uint32_t e = b.deformation.owner(near);
  Vec3d xi = b.deformation.localCoordinates(near);
  xi[a] += (near == v ? hit->t : hit->t - 1.0) * b.deformation.element(e).inverseSize();
  Vec3d n = pullBackNormal(b.deformation, e, xi, hit->normal);
  const double len = n.norm();
  n = len > 0 ? Vec3d(n / len) : hit->normal;
  if (n[a] < 0) n = -n;
  Hermite h;
  h.t = static_cast<float>(std::clamp(hit->t, 1e-3, 1.0 - 1e-3));
  for (int i = 0; i < 3; ++i) h.n[i] = static_cast<float>(n[i]);
  return h;
}

// The subdivision's link test (see SubdivisionHooks::testLink): the ends positioned on the
// way, each voxel once per task (the cache).
std::optional<Hermite> testCubeLink(const CutBody& b, const std::vector<BladeSweep>& sweeps,
                                    std::size_t v, int a, VoxelPositionCache& cache) {
  const auto position = [&](std::size_t u) {
    if (const Vec3d* p = cache.find(u)) return *p;
    const Vec3d p = b.deformation.voxelPosition(u);
    cache.put(u, p);
    return p;
  };
  return testLink(b, sweeps, v, a, position(v), position(v + b.grid.stride(a)));
}

// The parameter range [t0, t1] of segment p + t (q - p), t in [0, 1], inside `box` (slabs per
// axis); false when it misses the box.
bool clipToBox(const Vec3d& p, const Vec3d& q, const Eigen::AlignedBox3d& box, double& t0,
               double& t1) {
  if (box.isEmpty()) return false;
  t0 = 0.0;
  t1 = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double d = q[a] - p[a];
    if (d == 0.0) {
      if (p[a] < box.min()[a] || p[a] > box.max()[a]) return false;
      continue;
    }
    double lo = (box.min()[a] - p[a]) / d, hi = (box.max()[a] - p[a]) / d;
    if (lo > hi) std::swap(lo, hi);
    t0 = std::max(t0, lo);
    t1 = std::min(t1, hi);
    if (!(t0 <= t1)) return false;
  }
  return true;
}

// The boundary of the sweeps as the subdivision needs it (SweepBoundary): every sweep edge
// that no other sweep shares (by its corners' ids), sampled every half voxel; each sample
// inside an element is taken back to the rest grid through that element's map (every copy
// that holds it), and the cubes over the unit cells around it (one cell either way on each
// axis) are listed, ascending.
SweepBoundary sweepBoundary(const CutBody& b, const std::vector<BladeSweep>& sweeps) {
  struct Edge {
    std::uint64_t lo, hi;
    Vec3d p, q;
  };
  std::vector<Edge> edges;
  for (const BladeSweep& s : sweeps)
    for (std::size_t k = 0; k < 4; ++k) {
      const std::size_t k1 = (k + 1) % 4;
      edges.push_back({std::min(s.ids[k], s.ids[k1]), std::max(s.ids[k], s.ids[k1]), s.corners[k],
                       s.corners[k1]});
    }
  std::sort(edges.begin(), edges.end(), [](const Edge& x, const Edge& y) {
    return std::tie(x.lo, x.hi) < std::tie(y.lo, y.hi);
  });
  Eigen::AlignedBox3d all;
  for (const auto& box : b.elementBoxes) all.extend(box);
  const DeformationOctree& d = b.deformation;
  const VoxelOctree& oct = b.activity;
  const Index3 dims = b.grid.dims();
  const double h = b.grid.voxelSize();
  std::vector<std::uint8_t> listed(oct.cubes.size(), 0);
  SweepBoundary out;
  const Vec3d pad = Vec3d::Constant(1e-9 * h);
  const auto inBox = [&](std::uint32_t e, const Vec3d& x) {
    const Eigen::AlignedBox3d& box = b.elementBoxes[e];
    return (x.array() >= (box.min() - pad).array()).all() &&
           (x.array() <= (box.max() + pad).array()).all();
  };
  // Point x at trilinear coordinates t of element e: its rest voxel coordinates (an element's
  // corner nodes lie half a voxel before its first voxel's centre and size - 1/2 after it),
  // and the cubes around it.
  Index3 lastCell{-2, -2, -2};
  const auto take = [&](std::uint32_t e, const Vec3d& t) {
    const OctreeElement& el = d.element(e);
    const Index3 f = el.firstVoxel();
    Vec3d q;
    Index3 cell;
    for (int k = 0; k < 3; ++k) {
      q[k] = f[k] - 0.5 + el.size() * t[k];
      cell[k] = static_cast<int>(std::floor(q[k]));
    }
    out.points.push_back(q);
    if (cell == lastCell) return;  // its cubes are listed already
    lastCell = cell;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const Index3 c{cell.x + dx, cell.y + dy, cell.z + dz};
          if (c.x < 0 || c.y < 0 || c.z < 0 || c.x + 1 >= dims.x || c.y + 1 >= dims.y ||
              c.z + 1 >= dims.z)
            continue;
          const std::int32_t cube = oct.cellCube[b.grid.index(c)];
          if (cube < 0 || listed[static_cast<std::size_t>(cube)] != 0) continue;
          listed[static_cast<std::size_t>(cube)] = 1;
          out.cubes.push_back(static_cast<std::uint32_t>(cube));
        }
  };
  std::uint32_t hint = kNoElement;  // the element that held the previous sample, and where
  Vec3d hintT = Vec3d::Constant(0.5);
  const auto sample = [&](const Vec3d& x) {
    if (!all.contains(x)) return;
    Vec3d t;
    // Strictly inside the previous sample's element: the maps of the other cubes' elements
    // do not reach it (the octree is conforming, short of inverted elements), only the other
    // copies of the same cube can.
    if (hint != kNoElement && inBox(hint, x) && d.trilinearCoordinates(hint, x, t, hintT) &&
        (t.array() > 1e-6).all() && (t.array() < 1.0 - 1e-6).all()) {
      hintT = t;
      const OctreeElement& el = d.element(hint);
      for (std::uint32_t c = d.firstCopy(el.level, el.coord); c != kNoElement; c = d.nextCopy(c)) {
        Vec3d tc = t;
        if (c == hint || (inBox(c, x) && d.trilinearCoordinates(c, x, tc))) take(c, tc);
      }
      return;
    }
    hint = kNoElement;
    b.hash.forEachNear(x, [&](std::uint32_t e) {
      if (!inBox(e, x) || !d.trilinearCoordinates(e, x, t)) return;
      take(e, t);
      hint = e;
      hintT = t;
    });
  };
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i + 1;
    while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) ++j;
    // Only the part of the edge inside the elements' box can hold a sample that counts, so a
    // blade far longer than the body costs no more than one that spans it.
    double t0 = 0.0, t1 = 1.0;
    if (j == i + 1 && clipToBox(edges[i].p, edges[i].q, all, t0, t1)) {
      const Edge& e = edges[i];
      const Vec3d p = t0 > 0.0 ? Vec3d(e.p + t0 * (e.q - e.p)) : e.p;
      const Vec3d q = t1 < 1.0 ? Vec3d(e.p + t1 * (e.q - e.p)) : e.q;
      const double len = (q - p).norm();
      const int n = std::isfinite(len) ? static_cast<int>(std::ceil(len / (0.5 * h))) : 0;
      for (int k = 0; k <= std::min(n, 1 << 22); ++k)
        sample(n > 0 ? Vec3d(p + (static_cast<double>(k) / n) * (q - p)) : p);
    }
    i = j;
  }
  std::sort(out.cubes.begin(), out.cubes.end());
  return out;
}

}  // namespace

CutBody makeCutBody(VoxelGrid grid, const CutBodyParams& params, bool threaded) {
  CutBody b;
  b.grid = std::move(grid);
  DeformationOctreeParams dp = params.deformation;
  dp.threaded = threaded;
  b.deformation = buildDeformationOctree(b.grid, dp);
  setActivity(b, params.useOctree, params.octree, threaded);
  // Room for the Hermite data of future cuts, so that a frame does not pay for a rehash.
  b.grid.hermite().reserve(2 * b.grid.hermite().size() + 4096);
  b.obbMargin = params.obbMargin > 0 ? params.obbMargin : 0.5 * b.grid.voxelSize();
  return b;
}

void setActivity(CutBody& b, bool useOctree, const OctreeParams& octree, bool threaded) {
  b.useOctree = useOctree;
  b.updatesPending = false;  // a new octree: nothing of the old one is left to update
  if (useOctree) {
    OctreeParams op = octree;
    const std::size_t n = b.grid.materialNames().size();
    if (op.maxInternalLevel.empty()) op = OctreeParams::uniform(n, 4, 0);
    b.activity = buildVoxelOctree(b.grid, op, threaded);
  } else {
    b.activity = allActive(b.grid, threaded);
  }
}

CutStepResult cutStep(CutBody& b, const BladeSweep& sweep, SubdivisionWorkspace& workspace,
                      bool threaded) {
  return cutStep(b, std::vector<BladeSweep>{sweep}, workspace, threaded);
}

CutStepResult cutStep(CutBody& b, const BladeSweep& sweep, bool threaded) {
  SubdivisionWorkspace workspace;
  return cutStep(b, std::vector<BladeSweep>{sweep}, workspace, threaded);
}

CutStepResult cutStep(CutBody& b, const std::vector<BladeSweep>& sweeps, bool threaded) {
  SubdivisionWorkspace workspace;
  return cutStep(b, sweeps, workspace, threaded);
}

namespace {

// Culling (docs/algorithms.md, "Culling that follows the sweep"). A link crosses the swept
// surface only when its low voxel lies within one link's length of it, so the candidates are
// the active voxels inside the sweeps' OBBs enlarged by the longest a link can be this frame.
// They are found from the top down: the elements whose boxes meet an enlarged OBB (through the
// spatial hash), then, in each, blocks of voxels halved until they are small, a block kept
// while the hull of its corner voxels' positions meets an enlarged OBB, then its voxels one by
// one. The work follows the swept area, not the volume of the elements the sweep touches.
struct CullBox {
  Vec3d centre;
  Eigen::Matrix3d axes;  // orthonormal columns
  Vec3d halfExtents;
  std::uint32_t sweep;         // the index of the sweep it encloses
  Eigen::AlignedBox3d bounds;  // its axis-aligned bounds, a cheaper first test
};

// The longest any link can be now: along axis a, a voxel step inside an element moves by at
// most its longest edge along a over its size (the derivative of the trilinear map along a
// blends those 4 edges), and a link that crosses into a neighbour is two such pieces of the
// same line, so the largest ratio over all elements bounds every link.
double longestLink(const DeformationOctree& d, bool threaded) {
  const std::size_t n = d.elementCount();
  constexpr std::size_t kGrain = 2048;
  std::vector<double> partial((n + kGrain - 1) / kGrain, 0.0);
  const Vec3d* x = d.positions().data();
  parallelFor(
      0, partial.size(), 1,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t c = c0; c < c1; ++c) {
          double m = 0.0;
          for (std::size_t e = c * kGrain; e < std::min(n, (c + 1) * kGrain); ++e) {
            const OctreeElement& el = d.element(static_cast<std::uint32_t>(e));
            double edge = 0.0;
            for (int k = 0; k < 8; ++k)
              for (int a = 0; a < 3; ++a)
                if (((k >> a) & 1) == 0)
                  edge = std::max(edge, (x[el.nodes[k | (1 << a)]] - x[el.nodes[k]]).squaredNorm());
            m = std::max(m, std::sqrt(edge) * el.inverseSize());
          }
          partial[c] = m;
        }
      },
      threaded);
  double m = 0.0;
  for (double p : partial) m = std::max(m, p);
  return m;
}

// Whether the convex hull of points p[0..n) meets box (tested along the box's axes only:
// it may keep a hull that misses, never drop one that meets).
bool hullMeets(const CullBox& box, const Vec3d* p, int n) {
  Eigen::AlignedBox3d hull;
  for (int k = 0; k < n; ++k) hull.extend(p[k]);
  if (!hull.intersects(box.bounds)) return false;
  for (int i = 0; i < 3; ++i) {
    const Vec3d axis = box.axes.col(i);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (int k = 0; k < n; ++k) {
      const double s = axis.dot(p[k] - box.centre);
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    if (lo > box.halfExtents[i] || hi < -box.halfExtents[i]) return false;
  }
  return true;
}

// An active voxel near the sweeps: its index in the grid, its position, and the
// sweeps whose enlarged boxes hold it (sweepCount indices from firstSweep in the element's list).
struct Candidate {
  std::size_t voxel;
  std::uint32_t firstSweep;
  std::uint32_t sweepCount;
  Vec3d position;
};

// The candidates of one element and the sweep indices they list.
struct ElementCandidates {
  std::vector<Candidate> voxels;
  std::vector<std::uint32_t> sweeps;
};

// The candidates among the active voxels that element e owns, in ascending voxel order within
// each block and blocks in a fixed order: the voxel offsets [lo, lo + size) of e (size a power
// of two), halved while the block is larger than kLeaf and its corner voxels' hull meets a box.
// A block tests only the boxes its parent met, a voxel only those its block met.
void collectCandidates(const CutBody& b, std::uint32_t e, const std::vector<CullBox>& boxes,
                       ElementCandidates& out) {
  constexpr int kLeaf = 4;
  const DeformationOctree& d = b.deformation;
  const OctreeElement& el = d.element(e);
  const Index3 first = el.firstVoxel();
  const Index3 dims = b.grid.dims();
  const double inv = el.inverseSize();
  const VoxelOctree& oct = b.activity;
  // Per depth of the recursion, the boxes the block there meets (a block's list is read while
  // its children fill the next depth's): depth k's list is met[k * nb .. k * nb + metCount[k]).
  const std::size_t nb = boxes.size();
  const auto depths = static_cast<std::size_t>(el.level) + 2;
  std::vector<std::uint32_t> met(depths * nb), metCount(depths, 0);
  for (std::size_t k = 0; k < nb; ++k) met[k] = static_cast<std::uint32_t>(k);
  metCount[0] = static_cast<std::uint32_t>(nb);
  const auto visit = [&](const auto& self, const Index3& lo, int size, std::size_t depth) -> void {
    Index3 hi;  // last offset of the block inside the grid
    for (int a = 0; a < 3; ++a) {
      hi[a] = std::min(lo[a] + size, dims[a] - first[a]) - 1;
      if (hi[a] < lo[a]) return;
    }
    Vec3d corners[8];
    for (int k = 0; k < 8; ++k) {
      const Vec3d t(((k & 1) ? hi[0] : lo[0]) + 0.5, ((k & 2) ? hi[1] : lo[1]) + 0.5,
                    ((k & 4) ? hi[2] : lo[2]) + 0.5);
      corners[k] = d.pointInElement(e, t * inv);
    }
    const std::uint32_t* parent = met.data() + depth * nb;
    std::uint32_t* here = met.data() + (depth + 1) * nb;
    std::uint32_t count = 0;
    for (std::uint32_t j = 0; j < metCount[depth]; ++j)
      if (hullMeets(boxes[parent[j]], corners, 8)) here[count++] = parent[j];
    metCount[depth + 1] = count;
    if (count == 0) return;
    if (size > kLeaf) {
      const int h = size / 2;
      for (int k = 0; k < 8; ++k)
        self(
            self,
            Index3{lo[0] + ((k & 1) ? h : 0), lo[1] + ((k & 2) ? h : 0), lo[2] + ((k & 4) ? h : 0)},
            h, depth + 1);
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
          if (!haveRow) {
            row = detail::rowSegment(d.positions(), el.nodes, (y + 0.5) * inv, (z + 0.5) * inv);
            haveRow = true;
          }
          const Vec3d p = row.start + ((x + 0.5) * inv) * row.delta;
          const auto firstSweep = static_cast<std::uint32_t>(out.sweeps.size());
          for (std::uint32_t j = 0; j < count; ++j)
            if (hullMeets(boxes[here[j]], &p, 1)) out.sweeps.push_back(boxes[here[j]].sweep);
          const auto holding = static_cast<std::uint32_t>(out.sweeps.size()) - firstSweep;
          if (holding > 0) out.voxels.push_back({v, firstSweep, holding, p});
        }
      }
  };
  visit(visit, Index3{0, 0, 0}, el.size(), 0);
}

// The elements under the sweeps (ascending) and the enlarged boxes their voxels are culled by.
struct SweepCull {
  std::vector<std::uint32_t> elements;
  std::vector<CullBox> boxes;
};

SweepCull cullElements(CutBody& b, const std::vector<BladeSweep>& sweeps, bool threaded) {
  if (threaded) wakeWorkers();  // the culling is serial, the candidates' search is not
  b.deformation.updateElementBounds(b.elementBoxes, threaded);
  b.hash.build(b.elementBoxes, threaded);
  const double reach = longestLink(b.deformation, threaded);
  SweepCull out;
  std::vector<std::uint8_t> marked(b.elementBoxes.size(), 0);
  for (const BladeSweep& sweep : sweeps) {
    Obb obb = sweepObb(sweep, b.obbMargin);
    // Enlarged by the longest link, and by a rounding allowance for the hull tests.
    obb.halfExtents += Vec3d::Constant(reach * (1.0 + 1e-9) + 1e-9 * b.grid.voxelSize());
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
    out.boxes.push_back({obb.centre, obb.axes, obb.halfExtents,
                         static_cast<std::uint32_t>(&sweep - sweeps.data()),
                         Eigen::AlignedBox3d(obbBounds.min() - Vec3d::Constant(pad),
                                             obbBounds.max() + Vec3d::Constant(pad))});
    // The elements of the cells the box meets whose own box meets it.
    for (const std::uint32_t e : b.hash.elements(
             obbBounds, [&](const Eigen::AlignedBox3d& cell) { return overlaps(obb, cell); }))
      if (marked[e] == 0 && overlaps(obb, b.elementBoxes[e])) marked[e] = 1;
  }
  for (std::size_t e = 0; e < marked.size(); ++e)
    if (marked[e] != 0) out.elements.push_back(static_cast<std::uint32_t>(e));
  return out;
}

// What the intersection test finds: the crossed links (in the order of the elements under the
// sweeps), how many links it tested, and with the octree the sweeps' boundary and the cubes
// around the cuts (sub-step (1) of the subdivision).
struct LinkTestResult {
  std::vector<LinkCut> cuts;
  std::size_t tested = 0;
  SweepBoundary boundary;
  std::vector<std::uint8_t> cubeMarks;
};

// Intersection test: each active connected link (v, a) whose low voxel v is a candidate, once.
// The far end is positioned on the way.
LinkTestResult testCandidateLinks(CutBody& b, const std::vector<BladeSweep>& sweeps,
                                  const std::vector<ElementCandidates>& candidates, bool threaded) {
  VoxelGrid& g = b.grid;
  const std::size_t n = candidates.size();
  std::vector<std::vector<LinkCut>> found(n);
  std::vector<std::size_t> tested(n, 0);
  // With the octree, the sweeps' boundary (for the subdivision) is found meanwhile, as one
  // more task, the first: it reads none of what the test writes.
  SweepBoundary boundary;
  const std::size_t side = b.useOctree ? 1 : 0;
  // With the octree, sub-step (1) of the subdivision for these cuts: each element's task marks
  // the cubes around its cuts once it has tested its links.
  std::vector<std::uint8_t> cubeMarks(b.useOctree ? b.activity.cubes.size() : 0, 0);
  parallelFor(
      0, n + side, 1,
      [&](std::size_t j0, std::size_t j1) {
        if (j0 < side) {
          boundary = sweepBoundary(b, sweeps);
          ++j0;
        }
        for (std::size_t c = j0 - side; c < j1 - side; ++c) {
          for (const Candidate& cand : candidates[c].voxels) {
            const std::uint32_t* which = candidates[c].sweeps.data() + cand.firstSweep;
            const std::size_t v = cand.voxel;
            for (int a = 0; a < 3; ++a) {
              if (!b.activity.linkActive(v, a) || !g.connected(v, a)) continue;
              ++tested[c];
              if (const auto h = testLink(b, sweeps, v, a, cand.position,
                                          b.deformation.voxelPosition(v + g.stride(a)), which,
                                          cand.sweepCount)) {
                found[c].push_back({VoxelGrid::linkId(v, a), *h, std::nullopt});
                if (side) prefetchCubesAroundLink(b.activity, g, found[c].back().link);
              }
            }
          }
          if (side)
            for (const LinkCut& lc : found[c])
              markCubesAroundLink(b.activity, g, lc.link, cubeMarks);
        }
      },
      threaded);

  LinkTestResult out;
  out.boundary = std::move(boundary);
  out.cubeMarks = std::move(cubeMarks);
  for (std::size_t c = 0; c < n; ++c) {
    out.tested += tested[c];
    out.cuts.insert(out.cuts.end(), found[c].begin(), found[c].end());
  }
  return out;
}

// The crossed links are disconnected and get their Hermite data; with the octree, the
// subdivision sets the data beside its first phase (it reads only the link bits), so the
// data is not set here when it runs.
void applyCuts(CutBody& b, std::vector<LinkCut>& cuts) {
  for (const LinkCut& lc : cuts)
    b.grid.setConnected(static_cast<std::size_t>(lc.link / 3), static_cast<int>(lc.link % 3),
                        false);
  if (!b.useOctree) storeHermite(b.grid.hermite(), cuts.data(), cuts.data() + cuts.size());
}

// Octree subdivision around the new cuts and in the cubes that the sweeps' boundary reaches
// into (nothing to subdivide or update without either).
// Records the subdivision's and the deferred updates' times and counts in r.
void subdivideAroundCuts(CutBody& b, const std::vector<BladeSweep>& sweeps,
                         SubdivisionWorkspace& workspace, LinkTestResult& found, CutStepResult& r,
                         bool threaded) {
  VoxelGrid& g = b.grid;
  SweepBoundary& boundary = found.boundary;
  std::vector<std::uint8_t>& cubeMarks = found.cubeMarks;
  Timer timer;
  if (b.useOctree && (!r.cuts.empty() || !boundary.cubes.empty())) {
    SubdivisionHooks hooks;
    hooks.testLink = [&](std::size_t v, int a, VoxelPositionCache& cache) {
      return testCubeLink(b, sweeps, v, a, cache);
    };
    r.subdivision = subdivideCutCubes(b.activity, g, r.cuts, hooks, workspace, threaded, boundary,
                                      false, &cubeMarks);
    r.subdivisionMs = timer.ms();
    b.updatesPending = true;
  } else if (b.useOctree) {
    r.subdivisionMs = timer.ms();
  }
}

}  // namespace

double runDeferredUpdates(CutBody& b, bool threaded) {
  if (!b.updatesPending) return 0.0;
  Timer timer;
  activateNewCubeFrames(b.activity, b.grid, threaded);
  compactCubes(b.activity, threaded);
  rebuildActiveVoxels(b.activity, threaded);
  b.updatesPending = false;
  return timer.ms();
}

CutStepResult cutStep(CutBody& b, const std::vector<BladeSweep>& sweeps,
                      SubdivisionWorkspace& workspace, bool threaded) {
  CutStepResult r = cutStepLeavingUpdates(b, sweeps, workspace, threaded);
  r.deferredMs += runDeferredUpdates(b, threaded);
  return r;
}

CutStepResult cutStepLeavingUpdates(CutBody& b, const std::vector<BladeSweep>& sweeps,
                                    SubdivisionWorkspace& workspace, bool threaded) {
  CutStepResult r;
  r.deferredMs = runDeferredUpdates(b, threaded);  // a previous step's, before this subdivision
  Timer timer;
  const SweepCull cull = cullElements(b, sweeps, threaded);
  r.markedElements = cull.elements.size();
  const double cullMs = timer.ms();

  // Voxel position update: the candidates near the sweep, positioned.
  timer.restart();
  std::vector<ElementCandidates> candidates(cull.elements.size());
  parallelFor(
      0, cull.elements.size(), 1,
      [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k)
          collectCandidates(b, cull.elements[k], cull.boxes, candidates[k]);
      },
      threaded);
  r.positionUpdateMs = timer.ms();

  timer.restart();
  LinkTestResult found = testCandidateLinks(b, sweeps, candidates, threaded);
  r.testedLinks = found.tested;
  r.cuts = std::move(found.cuts);
  applyCuts(b, r.cuts);
  r.intersectionMs = cullMs + timer.ms();

  subdivideAroundCuts(b, sweeps, workspace, found, r, threaded);
  std::sort(r.cuts.begin(), r.cuts.end(),
            [](const LinkCut& x, const LinkCut& y) { return x.link < y.link; });
  return r;
}

std::uint64_t cutSetHash(std::vector<LinkCut> cuts) {
  std::sort(cuts.begin(), cuts.end(),
            [](const LinkCut& x, const LinkCut& y) { return x.link < y.link; });
  std::uint64_t h = 0xcbf29ce484222325ULL;
  auto mix = [&](std::int64_t value) {
    for (int i = 0; i < 8; ++i) {
      h ^= static_cast<std::uint64_t>(value >> (8 * i)) & 0xffu;
      h *= 0x100000001b3ULL;
    }
  };
  for (const LinkCut& c : cuts) {
    mix(static_cast<std::int64_t>(c.link));
    mix(std::llround(static_cast<double>(c.hermite.t) * 1e6));
    for (int i = 0; i < 3; ++i) mix(std::llround(static_cast<double>(c.hermite.n[i]) * 1e6));
  }
  return h;
}

}  // namespace voxcut
