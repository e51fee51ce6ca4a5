#include "voxcut/sim/BodyContacts.h"

#include <algorithm>

#include "voxcut/core/Parallel.h"

namespace voxcut {
namespace {

/// Whether voxel `to` is `from` or joined to it by at most two connected links.
bool nearbyThroughLinks(const VoxelGrid& g, std::size_t from, std::size_t to) {
  if (from == to) return true;
  auto neighbours = [&](std::size_t v, auto&& fn) {
    const Index3 c = g.coord(v);
    for (int a = 0; a < 3; ++a) {
      if (c[a] + 1 < g.dims()[a] && g.connected(v, a)) fn(v + g.stride(a));
      if (c[a] > 0 && g.connected(v - g.stride(a), a)) fn(v - g.stride(a));
    }
  };
  bool found = false;
  neighbours(from, [&](std::size_t w) {
    if (found) return;
    if (w == to) {
      found = true;
      return;
    }
    neighbours(w, [&](std::size_t u) { found = found || u == to; });
  });
  return found;
}

/// The unit normal `rest` (b's rest frame) carried into the current frame by element e's
/// deformation at trilinear coordinates t: F^-T rest, F the map's derivative there (by central
/// differences; its scale drops out).
Vec3d currentNormal(const DeformationOctree& d, std::uint32_t e, const Vec3d& t,
                    const Vec3d& rest) {
  constexpr double kStep = 1e-4;
  Eigen::Matrix3d jacobian;
  for (int i = 0; i < 3; ++i) {
    Vec3d lo = t, hi = t;
    lo[i] -= kStep;
    hi[i] += kStep;
    jacobian.col(i) = d.pointInElement(e, hi) - d.pointInElement(e, lo);
  }
  const double det = jacobian.determinant();
  if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return rest;
  const Vec3d n = jacobian.inverse().transpose() * rest;
  const double len = n.norm();
  return len > 0.0 && std::isfinite(len) ? Vec3d(n / len) : rest;
}

/// The voxel of grid g holding trilinear coordinates t of element e (clamped into the element;
/// it must lie on the grid).
std::size_t voxelAt(const DeformationOctree& d, const VoxelGrid& g, std::uint32_t e,
                    const Vec3d& t) {
  const OctreeElement& el = d.element(e);
  const int size = el.size();
  const Index3 first = el.firstVoxel();
  Index3 c;
  for (int i = 0; i < 3; ++i)
    c[i] = first[i] + std::clamp(static_cast<int>(t[i] * size), 0, size - 1);
  return g.index(c);
}

/// Whether the current point x lies in the material of b's element copy e, and then its
/// trilinear coordinates t there, its depth below b's boundary in b's rest frame and the
/// boundary's normal (rest frame).
/// `restPoint` (may be null): where the point is in b's rest frame, as far as known: Newton starts
/// from its coordinates in e when they lie near e (same answer, fewer steps).
bool pointDepth(const SimBody& b, std::uint32_t e, const Vec3d& x, Vec3d& t, double& depth,
                Vec3d& normal, const Vec3d* restPoint = nullptr) {
  const DeformationOctree& d = b.cut.deformation;
  const VoxelGrid& g = b.cut.grid;
  const OctreeElement& el = d.element(e);
  const int size = el.size();
  const Index3 first = el.firstVoxel();
  Vec3d start = Vec3d::Constant(0.5);
  if (restPoint != nullptr) {
    const Vec3d guess = (*restPoint - d.nodeGridPosition(first)) / (size * g.voxelSize());
    if ((guess.array() > -0.25).all() && (guess.array() < 1.25).all())
      start = guess.cwiseMax(0.0).cwiseMin(1.0);
  }
  if (!d.trilinearCoordinates(e, x, t, start)) return false;
  for (int i = 0; i < 3; ++i)  // an element at the grid's edge reaches past it
    if (first[i] + std::clamp(static_cast<int>(t[i] * size), 0, size - 1) >= g.dims()[i])
      return false;
  const std::size_t vx = voxelAt(d, g, e, t);
  if (!g.occupied(vx) || d.owner(vx) != e) return false;  // not this copy's material
  const Vec3d rest = d.nodeGridPosition(first) + (size * g.voxelSize()) * t;
  return b.restDistance.depth(g, vx, rest, depth, normal);
}

/// The elements of b (whose element boxes `bHash` holds) whose boxes meet `box`; for self,
/// less element `own` of the same body and the elements sharing a node with it (its own
/// neighbourhood; its nodes sorted, each candidate node found by binary search). Ascending.
std::vector<std::uint32_t> candidatesOf(const SimBody& b, const LayeredHash& bHash,
                                        std::uint32_t own, const Eigen::AlignedBox3d& box,
                                        bool self) {
  std::vector<std::uint32_t> candidates = bHash.elementsInBox(box);
  if (self) {
    const DeformationOctree& d = b.cut.deformation;
    std::array<std::uint32_t, 8> ownNodes = d.element(own).nodes;
    std::sort(ownNodes.begin(), ownNodes.end());
    std::erase_if(candidates, [&](std::uint32_t e) {
      if (e == own) return true;
      for (std::uint32_t n : d.element(e).nodes)
        if (std::binary_search(ownNodes.begin(), ownNodes.end(), n)) return true;
      return false;
    });
  }
  return candidates;
}

}  // namespace

void buildElementHash(const SimBody& body, LayeredHash& hash, bool threaded) {
  std::vector<Eigen::AlignedBox3d> boxes;
  body.cut.deformation.updateElementBounds(boxes, threaded);
  hash.build(boxes, threaded);
}

void groupVerticesByElement(const SimBody& body, VerticesByElement& groups) {
  if (groups.valid && groups.cutLinks == body.cutLinks && groups.revision == body.surfaceRevision &&
      groups.slots == body.embedding.size())
    return;
  const std::size_t elements = body.cut.deformation.elementCount();
  groups.start.assign(elements + 1, 0);
  for (const VertexEmbedding& em : body.embedding)
    if (em.element != kNoElement) ++groups.start[em.element + 1];
  for (std::size_t e = 0; e < elements; ++e) groups.start[e + 1] += groups.start[e];
  groups.order.resize(groups.start.back());
  std::vector<std::uint32_t> next(groups.start.begin(), groups.start.end() - 1);
  for (std::size_t v = 0; v < body.embedding.size(); ++v)
    if (body.embedding[v].element != kNoElement)
      groups.order[next[body.embedding[v].element]++] = static_cast<std::uint32_t>(v);
  groups.cutLinks = body.cutLinks;
  groups.revision = body.surfaceRevision;
  groups.slots = body.embedding.size();
  groups.valid = true;
}

namespace {

/// B's element velocities (the mean of their nodes'; empty before B's first step), and in
/// `fastest` the fastest of them.
std::vector<Vec3d> elementVelocities(const SimBody& b, double& fastest) {
  const DeformationOctree& db = b.cut.deformation;
  const std::vector<Vec3d>& bVelocity = b.solver.velocities();
  std::vector<Vec3d> elementVelocity;
  fastest = 0.0;
  if (bVelocity.empty()) return elementVelocity;
  elementVelocity.resize(db.elementCount());
  for (std::size_t e = 0; e < db.elementCount(); ++e) {
    Vec3d sum = Vec3d::Zero();
    for (std::uint32_t n : db.element(static_cast<std::uint32_t>(e)).nodes) sum += bVelocity[n];
    elementVelocity[e] = sum / 8.0;
    fastest = std::max(fastest, elementVelocity[e].norm());
  }
  return elementVelocity;
}

/// Per element of A holding vertices: the box its vertices can reach in the step (its nodes
/// where they are and moved on by dt v, grown by B's fastest motion `fastestB`).
std::vector<Eigen::AlignedBox3d> reachBoxes(const SimBody& a, const SimBody& b,
                                            const std::vector<std::uint32_t>& start, double dt,
                                            double fastestB, bool threaded) {
  const DeformationOctree& da = a.cut.deformation;
  const std::vector<Vec3d>& velocity = a.solver.velocities();
  const std::size_t elements = da.elementCount();
  std::vector<Eigen::AlignedBox3d> reach(elements);
  parallelFor(
      0, elements, 256,
      [&](std::size_t lo, std::size_t hi) {
        for (std::size_t ea = lo; ea < hi; ++ea) {
          if (start[ea] == start[ea + 1]) continue;
          Eigen::AlignedBox3d& box = reach[ea];
          for (std::uint32_t n : da.element(static_cast<std::uint32_t>(ea)).nodes) {
            box.extend(da.positions()[n]);
            if (!velocity.empty()) box.extend(da.positions()[n] + dt * velocity[n]);
          }
          // (and a millionth of a voxel: the moved vertices are computed another way, and a
          // rounding must not leave one just outside a box that touches this one)
          const double pad = dt * fastestB + 1e-6 * b.cut.grid.voxelSize();
          box.extend(box.min() - Vec3d::Constant(pad));
          box.extend(box.max() + Vec3d::Constant(pad));
        }
      },
      threaded);
  return reach;
}

/// The self candidates of A's elements (less their own neighbourhood) kept in `cache`: kept
/// while they hold (nothing has moved out of the skin they were queried with), else queried
/// again with a voxel of skin.
void refreshSelfCandidates(const SimBody& a, const LayeredHash& hash,
                           const std::vector<std::uint32_t>& start,
                           const std::vector<Eigen::AlignedBox3d>& reach,
                           SelfCandidateCache& cache, bool threaded) {
  const DeformationOctree& da = a.cut.deformation;
  const std::size_t elements = da.elementCount();
  bool usable = cache.valid && cache.cutLinks == a.cutLinks &&
                cache.nodes.size() == da.positions().size() && cache.query.size() == elements;
  if (usable) {
    Vec3d moved = Vec3d::Zero();  // per axis, the farthest any node has moved since
    for (std::size_t n = 0; n < cache.nodes.size(); ++n)
      moved = moved.cwiseMax((da.positions()[n] - cache.nodes[n]).cwiseAbs());
    for (std::size_t ea = 0; ea < elements && usable; ++ea)
      if (start[ea] != start[ea + 1])
        usable = cache.query[ea].contains(
            Eigen::AlignedBox3d(reach[ea].min() - moved, reach[ea].max() + moved));
  }
  if (usable) return;
  const double skin = a.cut.grid.voxelSize();
  cache.nodes = da.positions();
  cache.cutLinks = a.cutLinks;
  cache.query.assign(elements, Eigen::AlignedBox3d());
  cache.candidates.assign(elements, {});
  parallelFor(
      0, elements, 32,
      [&](std::size_t lo, std::size_t hi) {
        for (std::size_t ea = lo; ea < hi; ++ea) {
          if (start[ea] == start[ea + 1]) continue;
          cache.query[ea] = Eigen::AlignedBox3d(reach[ea].min() - Vec3d::Constant(skin),
                                                reach[ea].max() + Vec3d::Constant(skin));
          cache.candidates[ea] =
              candidatesOf(a, hash, static_cast<std::uint32_t>(ea), cache.query[ea], true);
        }
      },
      threaded);
  cache.valid = true;
  ++cache.queries;
}

/// Vertex v of A against the `candidates` elements of B: the deepest contact (depth 0 when
/// none), its depth now in `currentDepth`.
BodyContactPoint deepestContact(const SimBody& a, const SimBody& b, const LayeredHash& bHash,
                                bool self, double dt, std::uint32_t v,
                                const std::vector<std::uint32_t>& candidates,
                                const std::vector<Vec3d>& elementVelocity) {
  const DeformationOctree& da = a.cut.deformation;
  const DeformationOctree& db = b.cut.deformation;
  const VoxelGrid& gb = b.cut.grid;
  const VertexEmbedding& em = a.embedding[v];
  const Vec3d now = da.pointInElement(em.element, em.local);
  const Vec3d vp = pointVelocity(a, em.element, trilinearWeights(em.local));
  // Its rest position, the start of Newton's method in b's elements for self.
  const OctreeElement& own = da.element(em.element);
  const Vec3d rest =
      da.nodeGridPosition(own.firstVoxel()) + (own.size() * a.cut.grid.voxelSize()) * em.local;
  BodyContactPoint best;
  for (std::uint32_t e : candidates) {
    const Vec3d ve = elementVelocity.empty() ? Vec3d::Zero() : elementVelocity[e];
    const Vec3d x = now + dt * (vp - ve);
    if (!bHash.elementBox(e).contains(x)) continue;
    Vec3d t, n;
    double depth = 0.0;
    if (!pointDepth(b, e, x, t, depth, n, self ? &rest : nullptr)) continue;
    if (self && nearbyThroughLinks(gb, static_cast<std::size_t>(a.surface.vertexVoxels()[v]),
                                   voxelAt(db, gb, e, t)))
      continue;
    if (!(depth > best.depth)) continue;
    best.vertex = v;
    best.element = em.element;
    best.weight = trilinearWeights(em.local);
    best.other = e;
    best.otherWeight = trilinearWeights(t);
    best.normal = currentNormal(db, e, t, n);
    best.depth = depth;
    best.otherVelocity = ve;
  }
  if (!(best.depth > 0.0)) return best;
  Vec3d t, n;
  if (!pointDepth(b, best.other, now, t, best.currentDepth, n, self ? &rest : nullptr))
    best.currentDepth = 0.0;
  best.currentDepth = std::max(best.currentDepth, 0.0);
  return best;
}

}  // namespace

std::vector<BodyContactPoint> findBodyContacts(const SimBody& a, const SimBody& b,
                                               const LayeredHash& bHash, bool self, double dt,
                                               bool threaded, SelfCandidateCache* cache,
                                               const VerticesByElement* groups) {
  // A's vertices by element.
  const std::size_t elements = a.cut.deformation.elementCount();
  VerticesByElement local;
  if (groups == nullptr) {
    groupVerticesByElement(a, local);
    groups = &local;
  }
  const std::vector<std::uint32_t>& start = groups->start;
  const std::vector<std::uint32_t>& order = groups->order;
  // A vertex is moved on by dt times its velocity relative to the element it is tested
  // against, so two bodies (or two parts of one) moving together do not see each other ahead
  // of where they are.
  double fastestB = 0.0;
  const std::vector<Vec3d> elementVelocity = elementVelocities(b, fastestB);
  const std::vector<Eigen::AlignedBox3d> reach = reachBoxes(a, b, start, dt, fastestB, threaded);
  // The elements of B whose boxes meet that box, less its own neighbourhood for self: from the
  // cache while it holds, else queried (and kept).
  if (cache != nullptr && self) refreshSelfCandidates(a, bHash, start, reach, *cache, threaded);
  // Most elements have no candidates, and their vertices are not even placed.
  constexpr std::size_t kChunk = 32;
  const std::size_t chunks = (elements + kChunk - 1) / kChunk;
  ChunkedList<BodyContactPoint> found(chunks);
  parallelFor(
      0, chunks, 1,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t ch = c0; ch < c1; ++ch)
          for (std::size_t ea = ch * kChunk; ea < std::min(elements, (ch + 1) * kChunk); ++ea) {
            if (start[ea] == start[ea + 1]) continue;
            std::vector<std::uint32_t> fresh;
            if (cache == nullptr || !self)
              fresh = candidatesOf(b, bHash, static_cast<std::uint32_t>(ea), reach[ea], self);
            const std::vector<std::uint32_t>& candidates =
                cache != nullptr && self ? cache->candidates[ea] : fresh;
            if (candidates.empty()) continue;
            for (std::uint32_t k = start[ea]; k < start[ea + 1]; ++k) {
              const BodyContactPoint best =
                  deepestContact(a, b, bHash, self, dt, order[k], candidates, elementVelocity);
              if (best.depth > 0.0) found[ch].push_back(best);
            }
          }
      },
      threaded);
  std::vector<BodyContactPoint> out;
  found.appendTo(out);
  // In vertex order, whatever the thread count (chunks went by element).
  std::sort(out.begin(), out.end(), [](const BodyContactPoint& x, const BodyContactPoint& y) {
    return x.vertex < y.vertex;
  });
  return out;
}

}  // namespace voxcut
