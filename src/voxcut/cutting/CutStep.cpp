#include "voxcut/cutting/CutStep.h"

#include <algorithm>
#include <cmath>
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
std::optional<Hermite> testLink(const CutBody& b, const std::vector<BladeSweep>& sweeps,
                                std::size_t v, int a, const Vec3d& pv, const Vec3d& pw) {
  const std::size_t w = v + b.grid.stride(a);
  std::optional<SweepHit> hit;
  for (const BladeSweep& sweep : sweeps)
    if (const auto h = intersectSegment(sweep, pv, pw, v, w); h && (!hit || h->t < hit->t)) hit = h;
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
    b.hash.forEachInCell(b.hash.cellOf(x), [&](std::uint32_t e) {
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
  if (useOctree) {
    OctreeParams op = octree;
    const std::size_t n = b.grid.materialNames().size();
    if (op.maxInternalLevel.empty()) op = OctreeParams::uniform(n, 4, 0);
    b.activity = buildVoxelOctree(b.grid, op, threaded);
  } else {
    b.activity = allActive(b.grid, threaded);
  }
  b.activePositions.assign(b.activity.activeVoxels.size(), Vec3d::Zero());
  b.activeMarked.clear();
  refreshActiveEmbeddings(b, threaded);
}

void refreshActiveEmbeddings(CutBody& b, bool threaded) {
  const std::uint64_t stamps[2] = {b.activity.activeStamp, b.deformation.embeddingStamp()};
  if (b.activeEmbeddingsFor[0] == stamps[0] && b.activeEmbeddingsFor[1] == stamps[1] &&
      b.activeEmbeddings.size() == b.activity.activeVoxels.size())
    return;
  b.deformation.gatherEmbeddings(b.activity.activeVoxels, b.activeEmbeddings, threaded);
  b.activeEmbeddingsFor[0] = stamps[0];
  b.activeEmbeddingsFor[1] = stamps[1];
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

// Culling, the first part of the intersection test: the hash of element boxes (from the nodes)
// and the elements under the sweeps' OBBs (1 each).
std::vector<std::uint8_t> markElementsUnderSweeps(CutBody& b, const std::vector<BladeSweep>& sweeps,
                                                  bool threaded) {
  if (threaded) wakeWorkers();  // the culling is serial, the position update is not
  b.deformation.updateElementBounds(b.elementBoxes, threaded);
  b.hash.build(b.elementBoxes, 0.0, threaded);
  std::vector<std::uint8_t> marked(b.elementBoxes.size(), 0);
  for (const BladeSweep& sweep : sweeps) {
    const Obb obb = sweepObb(sweep, b.obbMargin);
    Eigen::AlignedBox3d obbBounds;
    for (int k = 0; k < 8; ++k) {
      Vec3d corner = obb.centre;
      for (int i = 0; i < 3; ++i)
        corner += ((k >> i) & 1 ? 1.0 : -1.0) * obb.halfExtents[i] * obb.axes.col(i);
      obbBounds.extend(corner);
    }
    b.hash.markElements(
        obbBounds, [&](const Eigen::AlignedBox3d& cell) { return overlaps(obb, cell); }, marked);
  }
  return marked;
}

// Voxel position update, stored in active order, with whether each active voxel's element
// is marked (from the embeddings kept in active order, see CutBody). When
// the blade reaches under half the elements (a frame of a running scene, and the bunny's
// single-frame cut), only the voxels in marked elements are positioned and a
// link to a voxel outside them positions that end on the way; else (a longer sweep) every
// active voxel is positioned in one pass, which is cheaper than positioning the many ends
// outside one by one (docs/performance.md, "Single-frame cutting test"). The positions are
// bitwise the same.
void positionActiveVoxels(CutBody& b, const std::vector<std::uint8_t>& marked, bool fewMarked,
                          bool threaded) {
  refreshActiveEmbeddings(b, threaded);
  b.deformation.updateVoxelPositions(b.activeEmbeddings, marked, fewMarked, b.activePositions,
                                     b.activeMarked, threaded);
}

// What the intersection test finds: the crossed links (in the order of the active voxels'
// chunks), how many links it tested, and with the octree the sweeps' boundary and the cubes
// around the cuts (sub-step (1) of the subdivision).
struct LinkTestResult {
  std::vector<LinkCut> cuts;
  std::size_t tested = 0;
  SweepBoundary boundary;
  std::vector<std::uint8_t> cubeMarks;
};

// Intersection test: each active connected link (v, a) once, from its low voxel v, when
// either end lies in a marked element. Per chunk of entries, first the candidates, without
// a branch per link: the octree's active links come and go from one entry to the next
// (frames, shell), and branching on each costs more than the test of the links that pass
// (docs/performance.md, "Single-frame cutting test"); then the candidates are tested.
LinkTestResult testActiveLinks(CutBody& b, const std::vector<BladeSweep>& sweeps, bool fewMarked,
                               bool threaded) {
  VoxelGrid& g = b.grid;
  const std::vector<std::uint32_t>& active = b.activity.activeVoxels;
  const std::vector<VoxelEmbedding>& embeddings = b.activeEmbeddings;
  const auto positionOf = [&](std::size_t i, bool isMarked) {
    return isMarked || !fewMarked ? b.activePositions[i]
                                  : b.deformation.voxelPosition(embeddings[i]);
  };
  VOXCUT_ASSERT(active.size() < (std::size_t{1} << 30),
                "too many active voxels for the link table");
  const auto nActive = static_cast<std::uint32_t>(active.size());
  b.activeMarked.push_back(0);  // entry nActive: what a missing link's far end reads
  const std::uint8_t* inMarked = b.activeMarked.data();
  const std::vector<std::array<std::uint32_t, 3>>& next = b.activity.activeNext;
  constexpr std::size_t kChunk = 1024;
  std::vector<std::vector<LinkCut>> found((active.size() + kChunk - 1) / kChunk);
  std::vector<std::size_t> tested(found.size(), 0);
  // With the octree, the sweeps' boundary (for the subdivision) is found meanwhile, as one
  // more task, the first: it reads none of what the test writes.
  SweepBoundary boundary;
  const std::size_t side = b.useOctree ? 1 : 0;
  // With the octree, sub-step (1) of the subdivision for these cuts: each chunk marks the cubes
  // around its cuts once it has tested its links (their cells fetched as the cuts are found).
  std::vector<std::uint8_t> cubeMarks(b.useOctree ? b.activity.cubes.size() : 0, 0);
  parallelFor(
      0, found.size() + side, 1,
      [&](std::size_t j0, std::size_t j1) {
        if (j0 < side) {
          boundary = sweepBoundary(b, sweeps);
          ++j0;
        }
        std::array<std::uint32_t, 3 * kChunk> candidates;  // entry * 4 + axis
        std::array<std::uint32_t, 3 * kChunk> farEnds;     // the entry across
        for (std::size_t c = j0 - side; c < j1 - side; ++c) {
          std::size_t count = 0;
          const std::size_t end = std::min(active.size(), (c + 1) * kChunk);
          for (std::size_t i = c * kChunk; i < end; ++i) {
            const unsigned here = inMarked[i];
            const auto first = static_cast<std::uint32_t>(4 * i);
            for (std::uint32_t a = 0; a < 3; ++a) {
              const std::uint32_t j = next[i][a];  // kNoActive is above every entry
              candidates[count] = first + a;
              farEnds[count] = j;
              count += static_cast<unsigned>(j < nActive) & (here | inMarked[std::min(j, nActive)]);
            }
          }
          for (std::size_t k = 0; k < count; ++k) {
            const std::size_t i = candidates[k] >> 2;
            const int a = static_cast<int>(candidates[k] & 3u);
            const std::size_t v = active[i];
            if (!g.connected(v, a)) continue;
            const std::uint32_t j = farEnds[k];
            ++tested[c];
            if (const auto h = testLink(b, sweeps, v, a, positionOf(i, inMarked[i] != 0),
                                        positionOf(j, inMarked[j] != 0))) {
              found[c].push_back({VoxelGrid::linkId(v, a), *h, std::nullopt});
              if (side) prefetchCubesAroundLink(b.activity, g, found[c].back().link);
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
  for (std::size_t c = 0; c < found.size(); ++c) {
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
    timer.restart();
    activateNewCubeFrames(b.activity, g, threaded);
    compactCubes(b.activity, threaded);
    rebuildActiveVoxels(b.activity, threaded);
    refreshActiveEmbeddings(b, threaded);
    r.deferredMs = timer.ms();
  } else if (b.useOctree) {
    r.subdivisionMs = timer.ms();
  }
}

}  // namespace

CutStepResult cutStep(CutBody& b, const std::vector<BladeSweep>& sweeps,
                      SubdivisionWorkspace& workspace, bool threaded) {
  CutStepResult r;
  Timer timer;
  const std::vector<std::uint8_t> marked = markElementsUnderSweeps(b, sweeps, threaded);
  for (std::uint8_t m : marked) r.markedElements += m;
  const double cullMs = timer.ms();

  timer.restart();
  const bool fewMarked = 2 * r.markedElements < marked.size();
  positionActiveVoxels(b, marked, fewMarked, threaded);
  r.positionUpdateMs = timer.ms();

  timer.restart();
  LinkTestResult found = testActiveLinks(b, sweeps, fewMarked, threaded);
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
