#include "voxcut/cutting/CutStep.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "voxcut/core/Fnv.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/cutting/SweepCull.h"

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

// Where a link crosses the sweeps: the smallest crossing parameter, and the sweep (the first
// of those with that parameter).
struct LinkHit {
  double t = 0.0;
  std::uint32_t sweep = 0;
  [[nodiscard]] bool before(const LinkHit& o) const {
    return t < o.t || (t == o.t && sweep < o.sweep);
  }
};

// Blade test of link (v, a) whose ends are now at pv and pw; Hermite data in the rest frame.
// Only the sweeps listed in `which` (indices into sweeps; all when null) are tested: a caller
// that knows the link is far from the others leaves them out. With `where`, the hit's t and
// sweep go there (to merge the hits of one link tested against different sweeps).
std::optional<Hermite> testLink(const CutBody& b, const std::vector<BladeSweep>& sweeps,
                                std::size_t v, int a, const Vec3d& pv, const Vec3d& pw,
                                const std::uint32_t* which = nullptr, std::size_t count = 0,
                                LinkHit* where = nullptr) {
  const std::size_t w = v + b.grid.stride(a);
  std::optional<SweepHit> hit;
  LinkHit first;
  const std::size_t tests = which != nullptr ? count : sweeps.size();
  for (std::size_t k = 0; k < tests; ++k) {
    const auto index = static_cast<std::uint32_t>(which != nullptr ? which[k] : k);
    if (const auto h = intersectSegment(sweeps[index], pv, pw, v, w)) {
      const LinkHit here{h->t, index};
      if (!hit || here.before(first)) {
        hit = h;
        first = here;
      }
    }
  }
  if (!hit) return std::nullopt;
  if (where != nullptr) *where = first;
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
// axis) are listed, ascending. `under`: the elements under the sweeps (SweepCull); only they
// can hold a point of a sweep.
SweepBoundary sweepBoundary(const CutBody& b, const std::vector<BladeSweep>& sweeps,
                            const std::vector<std::uint32_t>& under, std::size_t& samples) {
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
  const DeformationOctree& d = b.deformation;
  const VoxelOctree& oct = b.activity;
  const Index3 dims = b.grid.dims();
  const double h = b.grid.voxelSize();
  std::vector<std::uint8_t> listed(oct.cubes.size(), 0);
  SweepBoundary out;
  const Vec3d pad = Vec3d::Constant(1e-9 * h);
  // Only a point in an element's box can be a sample that counts, so the edges are sampled in
  // the box around the elements under the sweeps: a frame's samples follow the part of the
  // blade near material, however far apart the body's pieces lie.
  Eigen::AlignedBox3d all;
  for (const std::uint32_t e : under) {
    all.extend(b.elementBoxes[e].min() - pad);
    all.extend(b.elementBoxes[e].max() + pad);
  }
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
    ++samples;
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
    // Only the part of the edge inside that box can hold a sample that counts, so a blade far
    // longer than the body costs no more than one that spans the material near it. The points
    // lie every half voxel along the whole edge, whatever part the box keeps.
    double t0 = 0.0, t1 = 1.0;
    if (j == i + 1 && clipToBox(edges[i].p, edges[i].q, all, t0, t1)) {
      const Edge& e = edges[i];
      const double len = (e.q - e.p).norm();
      const double n = std::isfinite(len) ? std::ceil(len / (0.5 * h)) : 0.0;
      if (n == 0.0) {
        sample(e.p);
      } else {
        const double k0 = std::floor(t0 * n), k1 = std::min(std::ceil(t1 * n), n);
        for (double k = k0; k <= std::min(k1, k0 + (1 << 22)); ++k)
          sample(k == n ? e.q : Vec3d(e.p + (k / n) * (e.q - e.p)));
      }
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

// What the intersection test finds: the crossed links (sorted by link id), how many links it
// tested, and with the octree the sweeps' boundary and the cubes around the cuts (sub-step (1)
// of the subdivision).
struct LinkTestResult {
  std::vector<LinkCut> cuts;
  std::size_t tested = 0;
  std::size_t boundarySamples = 0;
  SweepBoundary boundary;
  std::vector<std::uint8_t> cubeMarks;
};

// A crossed link as one element's task found it.
struct FoundCut {
  LinkCut cut;
  LinkHit hit;
};

// Intersection test (SweepCull.h): every active connected link (u, a) of a candidate is tested
// against the candidate's sweeps, from its low end u when u is a candidate, and from its high
// end w too when u's element has the smaller reach: a link is no longer than the larger reach
// of its ends' elements, so the end in the element with the larger reach lies within it of
// every sweep the link crosses and is a candidate for that sweep. A link tested from both
// ends against different sweeps takes the hit with the smallest t over both (ties: the first
// sweep), as a test against all its sweeps at once would. The other end is positioned on the
// way.
LinkTestResult testCandidateLinks(CutBody& b, const std::vector<BladeSweep>& sweeps,
                                  const SweepCull& cull,
                                  const std::vector<ElementCandidates>& candidates, bool threaded) {
  VoxelGrid& g = b.grid;
  const DeformationOctree& d = b.deformation;
  const std::size_t n = candidates.size();
  std::vector<std::vector<FoundCut>> found(n);
  std::vector<std::size_t> tested(n, 0);
  // With the octree, the sweeps' boundary (for the subdivision) is found meanwhile, as one
  // more task, the first: it reads none of what the test writes.
  SweepBoundary boundary;
  std::size_t boundarySamples = 0;
  const std::size_t side = b.useOctree ? 1 : 0;
  // With the octree, sub-step (1) of the subdivision for these cuts: each element's task marks
  // the cubes around its cuts once it has tested its links.
  std::vector<std::uint8_t> cubeMarks(b.useOctree ? b.activity.cubes.size() : 0, 0);
  parallelFor(
      0, n + side, 1,
      [&](std::size_t j0, std::size_t j1) {
        if (j0 < side) {
          boundary = sweepBoundary(b, sweeps, cull.elements, boundarySamples);
          ++j0;
        }
        for (std::size_t c = j0 - side; c < j1 - side; ++c) {
          const double reach = cull.reach[cull.elements[c]];
          const auto test = [&](std::size_t u, int a, const Vec3d& pu, const Vec3d& pw,
                                const Candidate& cand) {
            ++tested[c];
            LinkHit hit;
            if (const auto h = testLink(b, sweeps, u, a, pu, pw,
                                        candidates[c].sweeps.data() + cand.firstSweep,
                                        cand.sweepCount, &hit)) {
              found[c].push_back({{VoxelGrid::linkId(u, a), *h, std::nullopt}, hit});
              if (side) prefetchCubesAroundLink(b.activity, g, found[c].back().cut.link);
            }
          };
          for (const Candidate& cand : candidates[c].voxels) {
            const std::size_t v = cand.voxel;
            for (int a = 0; a < 3; ++a)
              if (b.activity.linkActive(v, a) && g.connected(v, a))
                test(v, a, cand.position, d.voxelPosition(v + g.stride(a)), cand);
            // Downwards, where the low end's element reaches less far than this one.
            const Index3 at = g.coord(v);
            for (int a = 0; a < 3; ++a) {
              if (at[a] == 0) continue;
              const std::size_t u = v - g.stride(a);
              if (!b.activity.linkActive(u, a) || !g.connected(u, a) ||
                  !(cull.reach[d.owner(u)] < reach))
                continue;
              test(u, a, d.voxelPosition(u), cand.position, cand);
            }
          }
          if (side)
            for (const FoundCut& f : found[c])
              markCubesAroundLink(b.activity, g, f.cut.link, cubeMarks);
        }
      },
      threaded);

  LinkTestResult out;
  out.boundary = std::move(boundary);
  out.boundarySamples = boundarySamples;
  out.cubeMarks = std::move(cubeMarks);
  std::vector<FoundCut> all;
  for (std::size_t c = 0; c < n; ++c) {
    out.tested += tested[c];
    all.insert(all.end(), found[c].begin(), found[c].end());
  }
  // One cut per link: the first hit of those found for it.
  std::sort(all.begin(), all.end(), [](const FoundCut& x, const FoundCut& y) {
    return x.cut.link != y.cut.link ? x.cut.link < y.cut.link : x.hit.before(y.hit);
  });
  for (std::size_t i = 0; i < all.size(); ++i)
    if (i == 0 || all[i].cut.link != all[i - 1].cut.link) out.cuts.push_back(all[i].cut);
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
  const SweepCull cull = cullSweeps(b, sweeps, threaded);
  r.markedElements = cull.elements.size();
  for (const std::uint32_t e : cull.elements) r.linkReach = std::max(r.linkReach, cull.reach[e]);
  const double cullMs = timer.ms();

  // Voxel position update: the candidates near the sweep, positioned.
  timer.restart();
  std::vector<ElementCandidates> candidates(cull.elements.size());
  parallelFor(
      0, cull.elements.size(), 1,
      [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k)
          collectCandidates(b, cull, k, candidates[k]);
      },
      threaded);
  r.positionUpdateMs = timer.ms();
  for (const ElementCandidates& c : candidates) {
    r.positionedVoxels += c.positioned;
    r.candidateVoxels += c.voxels.size();
  }

  timer.restart();
  LinkTestResult found = testCandidateLinks(b, sweeps, cull, candidates, threaded);
  r.testedLinks = found.tested;
  r.boundarySamples = found.boundarySamples;
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
  Fnv1a h;
  for (const LinkCut& c : cuts) {
    h.add(static_cast<std::int64_t>(c.link));
    h.add(static_cast<std::int64_t>(std::llround(static_cast<double>(c.hermite.t) * 1e6)));
    for (int i = 0; i < 3; ++i)
      h.add(static_cast<std::int64_t>(std::llround(static_cast<double>(c.hermite.n[i]) * 1e6)));
  }
  return h.value();
}

}  // namespace voxcut
