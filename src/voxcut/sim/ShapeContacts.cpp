/// @file ShapeContacts.cpp
/// Contacts of a body's surface with obstacles and probes (docs/algorithms.md, "Contact"):
/// which shapes may come near which elements, the point contacts of a step, its active-set
/// correction and the deepest penetration.

#include <algorithm>

#include "voxcut/sim/WorldImpl.h"

namespace voxcut {

// Contact: each surface vertex inside an obstacle or probe, or headed inside it within this
// step at its current velocity, becomes a point contact of the implicit step
// (docs/algorithms.md, "Contact"). Vertices in slot order, shapes in order (obstacles, then
// probes).
std::vector<ContactHit> World::Impl::findContacts(const SimBody& b, const ContactShapes& shapes,
                                                  const ActiveSetEdits& edits,
                                                  std::vector<PointContact>& found) const {
  std::vector<ContactHit> hits;
  found.clear();
  if (shapes.size() == 0) return hits;
  const double dt = settings.timeStep;
  const std::size_t chunks = vertexChunks(shapes.vertices);
  ChunkedList<PointContact> chunkContacts(chunks);
  ChunkedList<ContactHit> chunkHits(chunks);
  forEachVertexChunked(
      b, settings.threaded, shapes.vertices,
      [&](std::size_t ch, std::size_t v, const Vec3d& x) {
        const VertexEmbedding& em = b.embedding[v];
        const std::array<double, 8> w = trilinearWeights(em.local);
        const Vec3d vp = pointVelocity(b, em.element, w);
        for (std::size_t s = 0; s < shapes.size(); ++s) {
          if (!shapes.mayTouch(em.element, s)) continue;
          const std::uint64_t key = v * shapes.size() + s;
          const bool forced = std::binary_search(edits.forced.begin(), edits.forced.end(), key);
          // Only a gap below dt |v_p| can be predicted to close; a forced contact needs its gap
          // wherever the vertex is.
          const double bound = forced ? std::numeric_limits<double>::infinity() : dt * vp.norm();
          Vec3d n;
          const double gap = shapes.distance(s, x, n, bound);
          const bool predicted = gap < 0.0 || gap + dt * n.dot(vp) < 0.0;
          if (predicted ? std::binary_search(edits.dropped.begin(), edits.dropped.end(), key)
                        : !forced)
            continue;
          PointContact pc;
          pc.element = em.element;
          pc.weight = w;
          pc.normal = n;
          pc.gap = gap;
          pc.stiffness = b.contactStiffness;
          setFriction(pc, shapes.friction[s], -gap, vp, shapes.velocity[s]);
          chunkContacts[ch].push_back(pc);
          chunkHits[ch].push_back({static_cast<std::uint32_t>(v), s, n, x - gap * n});
        }
      },
      &shapes.startPositions);
  chunkContacts.appendTo(found);
  chunkHits.appendTo(hits);
  return hits;
}

bool World::Impl::correctActiveSet(const SimBody& b, const ContactShapes& shapes,
                                   const std::vector<ContactHit>& hits, ActiveSetEdits& edits,
                                   double& deepest) const {
  const std::size_t shapeCount = shapes.size();
  const std::vector<double>& force = b.solver.contactForces();
  bool changed = false;
  std::vector<std::uint64_t> inSet;
  inSet.reserve(hits.size());
  for (std::size_t k = 0; k < hits.size(); ++k) {
    const std::uint64_t key = std::uint64_t{hits[k].vertex} * shapeCount + hits[k].source;
    inSet.push_back(key);
    if (force[k] < 0.0) {
      edits.dropped.push_back(key);
      changed = true;
    }
  }
  // Keys come out ascending: hits are in vertex order, shapes in order within a vertex.
  std::sort(edits.dropped.begin(), edits.dropped.end());
  // Vertices that end more than a fiftieth of a voxel inside a shape they had no contact with,
  // but for those dropped this frame (they pulled): forced and dropped, a key stays out, so
  // forcing it again would only solve the same set once more.
  const double tolerance = 0.02 * b.cut.grid.voxelSize();
  ChunkedList<std::uint64_t> chunkForced(vertexChunks(shapes.vertices));
  ChunkedMax chunkDeepest(vertexChunks(shapes.vertices));
  forEachVertexChunked(b, settings.threaded, shapes.vertices,
                       [&](std::size_t ch, std::size_t v, const Vec3d& x) {
                         for (std::size_t s = 0; s < shapeCount; ++s) {
                           if (!shapes.mayTouch(b.embedding[v].element, s)) continue;
                           Vec3d n;
                           const double gap = shapes.distance(s, x, n, 0.0);
                           chunkDeepest.raise(ch, -gap);
                           if (!(gap < -tolerance)) continue;
                           const std::uint64_t key = v * shapeCount + s;
                           if (!std::binary_search(inSet.begin(), inSet.end(), key) &&
                               !std::binary_search(edits.dropped.begin(), edits.dropped.end(),
                                                   key))
                             chunkForced[ch].push_back(key);
                         }
                       });
  deepest = chunkDeepest.value();
  const std::size_t forcedBefore = edits.forced.size();
  chunkForced.appendTo(edits.forced);
  if (edits.forced.size() != forcedBefore) changed = true;
  std::sort(edits.forced.begin(), edits.forced.end());
  // A key both forced and dropped (it went in, then pulled): left out.
  std::vector<std::uint64_t> forced;
  std::set_difference(edits.forced.begin(), edits.forced.end(), edits.dropped.begin(),
                      edits.dropped.end(), std::back_inserter(forced));
  edits.forced = std::move(forced);
  return changed;
}

void World::Impl::nearShapes(const SimBody& b, ContactShapes& shapes) const {
  const DeformationOctree& d = b.cut.deformation;
  const std::vector<Vec3d>& velocity = b.solver.velocities();
  const double dt = settings.timeStep;
  // A node moves at most dt (|v| + |g| dt) in a step unless forces beyond gravity act; twice
  // that, and a voxel, to spare (the step's re-solves and the contacts' own pushes).
  const double spare = b.cut.grid.voxelSize() + 2.0 * dt * dt * settings.gravity.norm();
  shapes.near.assign(d.elementCount(), 0);
  std::vector<double> motion(d.elementCount(), 0.0);  // how far the element's nodes may move
  parallelFor(
      0, d.elementCount(), 512,
      [&](std::size_t lo, std::size_t hi) {
        for (std::size_t e = lo; e < hi; ++e) {
          const OctreeElement& el = d.element(static_cast<std::uint32_t>(e));
          Eigen::AlignedBox3d box;
          double speed = 0.0;
          for (std::uint32_t n : el.nodes) {
            box.extend(d.positions()[n]);
            if (!velocity.empty()) speed = std::max(speed, velocity[n].norm());
          }
          motion[e] = 2.0 * dt * speed + spare;
          std::uint64_t bits = 0;
          for (std::size_t s = 0; s < std::min<std::size_t>(shapes.size(), 64); ++s)
            if (shapes.lowerBound(s, box, motion[e]) < motion[e]) bits |= std::uint64_t{1} << s;
          shapes.near[e] = bits;
        }
      },
      settings.threaded);
  // Then the vertices of those elements that a shape can reach within their element's motion:
  // an element's vertices lie anywhere in its ball, most of them farther than that.
  std::vector<std::uint32_t> all;
  for (std::size_t v = 0; v < b.embedding.size(); ++v)
    if (b.embedding[v].element != kNoElement && shapes.mayTouchAny(b.embedding[v].element))
      all.push_back(static_cast<std::uint32_t>(v));
  ChunkedList<std::uint32_t> chunkNear(vertexChunks(all));
  ChunkedList<Vec3d> chunkAt(vertexChunks(all));
  forEachVertexChunked(
      b, settings.threaded, all, [&](std::size_t ch, std::size_t v, const Vec3d& x) {
        const std::uint32_t e = b.embedding[v].element;
        for (std::size_t s = 0; s < shapes.size(); ++s) {
          Vec3d n;
          if (shapes.mayTouch(e, s) && shapes.distance(s, x, n, motion[e]) < motion[e]) {
            chunkNear[ch].push_back(static_cast<std::uint32_t>(v));
            chunkAt[ch].push_back(x);
            return;
          }
        }
      });
  shapes.vertices.clear();
  shapes.startPositions.clear();
  chunkNear.appendTo(shapes.vertices);
  chunkAt.appendTo(shapes.startPositions);
}

// The deepest any surface vertex of the body lies inside an obstacle or probe (m; 0 when
// none). The maximum does not depend on how the vertices are split among threads.
double World::Impl::deepestPenetration(const SimBody& b, const ContactShapes& shapes) const {
  if (shapes.size() == 0) return 0.0;
  const std::size_t chunks = vertexChunks(shapes.vertices);
  ChunkedMax deepest(chunks);
  parallelFor(
      0, chunks, 1,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t ch = c0; ch < c1; ++ch) {
          for (std::size_t k = ch * kVertexChunk;
               k < std::min(shapes.vertices.size(), (ch + 1) * kVertexChunk); ++k) {
            const std::uint32_t v = shapes.vertices[k];
            for (std::size_t s = 0; s < shapes.size(); ++s) {
              if (!shapes.mayTouch(b.embedding[v].element, s)) continue;
              Vec3d n;
              deepest.raise(ch, -shapes.distance(s, b.vertexPositions[v], n, 0.0));
            }
          }
        }
      },
      settings.threaded);
  return deepest.value();
}

}  // namespace voxcut
