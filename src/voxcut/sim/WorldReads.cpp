/// @file WorldReads.cpp
/// What the world lets an application read (sim/World.h): surfaces, their changes, the
/// pseudo voxel octree, nodes, energy, contacts, the cut set's hash, and the inspection reads
/// (voxels and pieces, penetration, the body's invariants).

#include <algorithm>
#include <numeric>
#include <sstream>
#include <string>

#include "voxcut/collision/LayeredHash.h"
#include "voxcut/core/Fnv.h"
#include "voxcut/sim/BodyContacts.h"
#include "voxcut/sim/WorldImpl.h"
#include "voxcut/surface/SurfaceMesh.h"
#include "voxcut/surface/VertexNormals.h"
#include "voxcut/voxel/Pieces.h"

namespace voxcut {

const std::vector<std::string>& frameStageNames() {
  static const std::vector<std::string> names{
      "voxel_position_update", "intersection_test", "octree_subdivision",
      "deferred_updates",      "cut_topology",      "surface_update",
      "object_collision",      "deformation",       "surface_vertices"};
  return names;
}

ActivityView World::activity(BodyId body, std::size_t maxLinks,
                             const Eigen::AlignedBox3d* within) const {
  const SimBody& b = impl_->body(body);
  const VoxelGrid& grid = b.cut.grid;
  const VoxelOctree& act = b.cut.activity;
  const DeformationOctree& def = b.cut.deformation;
  const auto in = [&](const Vec3d& x) { return within == nullptr || within->contains(x); };
  // The links that count: active, still connected (a cut link takes no part any more), and
  // within the box.
  const auto counts = [&](std::uint32_t v, int a) {
    return act.linkActive(v, a) && grid.connected(v, a) &&
           (within == nullptr ||
            (in(def.voxelPosition(v)) && in(def.voxelPosition(v + grid.stride(a)))));
  };
  ActivityView view;
  for (const std::uint32_t v : act.activeVoxels)
    for (int a = 0; a < 3; ++a) view.activeLinks += counts(v, a);
  const std::size_t every =
      maxLinks == 0 ? 1 : std::max<std::size_t>(1, (view.activeLinks + maxLinks - 1) / maxLinks);
  std::size_t seen = 0;
  if (maxLinks > 0)
    for (const std::uint32_t v : act.activeVoxels)
      for (int a = 0; a < 3; ++a) {
        if (!counts(v, a) || seen++ % every != 0) continue;
        view.links.push_back({def.voxelPosition(v), def.voxelPosition(v + grid.stride(a))});
      }
  for (const OctreeCube& c : act.cubes) {
    if (c.deleted) continue;
    const int side = 1 << c.level;
    std::array<Vec3d, 8> corners;
    Eigen::AlignedBox3d box;
    for (int k = 0; k < 8; ++k) {
      const Index3 at{c.origin[0] + side * (k & 1), c.origin[1] + side * ((k >> 1) & 1),
                      c.origin[2] + side * (k >> 2)};
      corners[static_cast<std::size_t>(k)] = def.voxelPosition(grid.index(at));
      box.extend(corners[static_cast<std::size_t>(k)]);
    }
    if (within != nullptr && !within->intersects(box)) continue;
    view.cubes.push_back(corners);
    view.cubeLevels.push_back(c.level);
  }
  return view;
}

SurfaceView World::surface(BodyId body) {
  SimBody& b = impl_->body(body);
  if (b.normalsFrame != impl_->frame) {
    // As surfaceMesh's: a live vertex on no triangle of non-zero area gets +z; a dead slot zero.
    vertexNormals(b.vertexPositions, b.surface.triangles(), b.vertexNormals, Vec3d::UnitZ());
    for (std::size_t v = 0; v < b.vertexNormals.size(); ++v)
      if (!b.surface.alive(static_cast<std::int32_t>(v))) b.vertexNormals[v] = Vec3d::Zero();
    b.normalsFrame = impl_->frame;
  }
  SurfaceView v;
  v.positions = b.vertexPositions;
  v.normals = b.vertexNormals;
  v.triangles = b.surface.triangles();
  v.triangleTags = b.surface.triangleTags();
  v.revision = b.surfaceRevision;
  return v;
}

SurfaceChanges World::surfaceChanges(BodyId body, std::uint64_t since) const {
  const SimBody& b = impl_->body(body);
  SurfaceChanges c;
  c.from = since;
  c.to = b.surfaceRevision;
  if (since == b.surfaceRevision) return c;
  if (since > b.surfaceRevision || b.surfaceLog.empty() ||
      b.surfaceLog.front().revision > since + 1) {
    c.full = true;
    return c;
  }
  auto merge = [](std::vector<std::int32_t>& into, const std::vector<std::int32_t>& from) {
    into.insert(into.end(), from.begin(), from.end());
  };
  for (const SurfaceLogEntry& e : b.surfaceLog) {
    if (e.revision <= since) continue;
    merge(c.addedVertices, e.delta.addedVertices);
    merge(c.removedVertices, e.delta.removedVertices);
    merge(c.addedTriangles, e.delta.addedTriangles);
    merge(c.removedTriangles, e.delta.removedTriangles);
  }
  for (auto* list :
       {&c.addedVertices, &c.removedVertices, &c.addedTriangles, &c.removedTriangles}) {
    std::sort(list->begin(), list->end());
    list->erase(std::unique(list->begin(), list->end()), list->end());
  }
  return c;
}

SurfaceMesh World::surfaceMesh(BodyId body) const {
  const SimBody& b = impl_->body(body);
  SurfaceMesh m;
  std::vector<int> index(b.surface.vertexSlots(), -1);
  for (std::size_t v = 0; v < index.size(); ++v) {
    if (!b.surface.alive(static_cast<std::int32_t>(v))) continue;
    index[v] = static_cast<int>(m.positions.size());
    m.positions.push_back(b.vertexPositions[v]);
    m.vertexVoxel.push_back(b.surface.vertexVoxels()[v]);
  }
  const std::vector<std::array<int, 3>>& triangles = b.surface.triangles();
  const std::vector<TriangleTag>& tags = b.surface.triangleTags();
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const auto& t = triangles[i];
    if (t[0] < 0) continue;
    m.triangles.push_back({index[static_cast<std::size_t>(t[0])],
                           index[static_cast<std::size_t>(t[1])],
                           index[static_cast<std::size_t>(t[2])]});
    if (i < tags.size()) m.triangleTags.push_back(tags[i]);
  }
  if (m.triangleTags.size() != m.triangles.size()) m.triangleTags.clear();
  // Normals follow the deformation: area-weighted from the deformed triangles, as surface()'s
  // (+z for a vertex on no triangle of non-zero area).
  m.normals = vertexNormals(m.positions, m.triangles, Vec3d::UnitZ());
  return m;
}

double World::maxDisplacement() const {
  // Over the material (every occupied voxel's centre), not the nodes: a corner of a coarse
  // element that holds a few voxels lies outside the body, and its displacement extrapolates
  // the element's rotation over the empty part.
  double best = 0.0;
  for (const SimBody& b : impl_->bodies) {
    const VoxelGrid& grid = b.cut.grid;
    const DeformationOctree& octree = b.cut.deformation;
    const std::size_t n = grid.voxelCount();
    constexpr std::size_t kChunk = 4096;
    const std::size_t chunks = (n + kChunk - 1) / kChunk;
    ChunkedMax partial(chunks);
    parallelFor(
        0, chunks, 1,
        [&](std::size_t c0, std::size_t c1) {
          for (std::size_t c = c0; c < c1; ++c)
            for (std::size_t v = kChunk * c; v < std::min(n, kChunk * (c + 1)); ++v)
              if (grid.occupied(v))
                partial.raise(c, (octree.voxelPosition(v) - grid.position(v)).norm());
        },
        impl_->settings.threaded);
    best = std::max(best, partial.value());
  }
  return best;
}

// ---- energy ----
BodyEnergy World::energy(BodyId body) const {
  const SimBody& b = impl_->body(body);
  const DeformationOctree& d = b.cut.deformation;
  BodyEnergy e;
  if (!b.solver.velocities().empty()) e.kinetic = b.solver.kineticEnergy(b.model);
  const std::vector<double>& mass = b.model.nodeMass();
  for (std::size_t n = 0; n < mass.size(); ++n)
    e.gravitational -= mass[n] * impl_->settings.gravity.dot(d.positions()[n]);
  e.elastic = elasticEnergy(b.model, d);
  return e;
}
// ---- end energy ----

NodeState World::nodes(BodyId body) const {
  const SimBody& b = impl_->body(body);
  NodeState s;
  s.positions = b.cut.deformation.positions();
  s.restPositions = b.cut.deformation.restPositions();
  s.velocities = b.solver.velocities();
  s.velocities.resize(s.positions.size(), Vec3d::Zero());
  s.masses = b.model.nodeMass();
  return s;
}

const std::vector<Contact>& World::contacts() const {
  return impl_->contacts;
}

std::uint64_t World::cutSetHash() const {
  if (impl_->bodies.size() == 1) return voxcut::cutSetHash(impl_->bodies[0].cuts);
  // Several bodies: each body's hash in body order, mixed.
  Fnv1a h;
  for (const SimBody& b : impl_->bodies) h.add(voxcut::cutSetHash(b.cuts));
  return h.value();
}

// ---- inspection ----

BodyVoxels World::voxels(BodyId body) const {
  const SimBody& b = impl_->body(body);
  const VoxelGrid& grid = b.cut.grid;
  const PieceLabels labels = findPieces(grid);
  BodyVoxels s;
  for (std::size_t v = 0; v < grid.voxelCount(); ++v) {
    if (!grid.occupied(v)) continue;
    s.restPositions.push_back(grid.position(v));
    s.positions.push_back(b.cut.deformation.voxelPosition(v));
    s.pieces.push_back(labels.label[v]);
  }
  s.pieceVoxels = labels.voxels;
  return s;
}

double World::penetration(BodyId body, BodyId other) const {
  const SimBody& a = impl_->body(body);
  const SimBody& b = impl_->body(other);
  LayeredHash hash;
  buildElementHash(b, hash, impl_->settings.threaded);
  double deepest = 0.0;
  for (const BodyContactPoint& c :
       findBodyContacts(a, b, hash, body == other, 0.0, impl_->settings.threaded))
    deepest = std::max(deepest, c.currentDepth);
  return deepest;
}

namespace {

// The node-grid point c as element copy e's trilinear map puts it now (extrapolating).
Vec3d pointAt(const DeformationOctree& d, std::uint32_t e, const Index3& c) {
  const OctreeElement& el = d.element(e);
  const Index3 f = el.firstVoxel();
  const double s = el.size();
  return d.pointInElement(e, Vec3d((c.x - f.x) / s, (c.y - f.y) / s, (c.z - f.z) / s));
}

// Components of the elements joined by shared node ids.
int meshComponents(const DeformationOctree& d) {
  std::vector<std::uint32_t> parent(d.nodeCount());
  std::iota(parent.begin(), parent.end(), 0u);
  const auto find = [&](std::uint32_t n) {
    while (parent[n] != n) n = parent[n] = parent[parent[n]];
    return n;
  };
  for (const OctreeElement& e : d.elements())
    for (const std::uint32_t n : e.nodes) parent[find(n)] = find(e.nodes[0]);
  std::vector<std::uint8_t> root(d.nodeCount(), 0);
  int count = 0;
  for (const OctreeElement& e : d.elements()) {
    const std::uint32_t r = find(e.nodes[0]);
    count += root[r] == 0;
    root[r] = 1;
  }
  return count;
}

// The first broken invariant of the body's deformation octree and grid ("" when none).
std::string octreeProblem(const SimBody& b) {
  const VoxelGrid& g = b.cut.grid;
  const DeformationOctree& d = b.cut.deformation;
  const double tol = 1e-9 * (1.0 + d.restVoxelBounds().diagonal().norm());
  std::ostringstream out;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    if (!g.occupied(v)) continue;
    const std::uint32_t e = d.owner(v);
    const Index3 p = g.coord(v);
    if (e >= d.elementCount()) {
      out << "occupied voxel " << v << " lies in no element";
      return out.str();
    }
    const OctreeElement& el = d.element(e);
    const Index3 f = el.firstVoxel();
    for (int a = 0; a < 3; ++a)
      if (p[a] < f[a] || p[a] >= f[a] + el.size()) {
        out << "voxel " << v << " owned by element " << e << ", which does not cover it";
        return out.str();
      }
  }
  for (const HangingNode& h : d.hangingNodes()) {
    const double off = (pointAt(d, h.element, d.nodeCoord(h.node)) - d.positions()[h.node]).norm();
    if (off > tol) {
      out << "hanging node " << h.node << " lies " << off << " m off element " << h.element;
      return out.str();
    }
  }
  // Connected links between voxels of two element copies: the copies agree on the 4 corners of
  // the face between the voxels.
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    if (!g.occupied(v)) continue;
    const Index3 p = g.coord(v);
    for (int a = 0; a < 3; ++a) {
      if (p[a] + 1 >= g.dims()[a] || !g.connected(v, a)) continue;
      const std::size_t w = v + g.stride(a);
      if (!g.occupied(w)) continue;
      const std::uint32_t ev = d.owner(v), ew = d.owner(w);
      if (ev == ew) continue;
      const int u = (a + 1) % 3, t = (a + 2) % 3;
      for (int k = 0; k < 4; ++k) {
        Index3 c = p;
        c[a] += 1;
        c[u] += k & 1;
        c[t] += k >> 1;
        const double gap = (pointAt(d, ev, c) - pointAt(d, ew, c)).norm();
        if (gap > tol) {
          out << "gap of " << gap << " m at connected link " << v << " axis " << a;
          return out.str();
        }
      }
    }
  }
  const int pieces = findPieces(g).count, mesh = meshComponents(d);
  if (mesh != pieces) {
    out << "the deformation mesh has " << mesh << " components, the voxels " << pieces
        << " pieces";
    return out.str();
  }
  return "";
}

// The first surface vertex embedded elsewhere than a fresh lookup puts it ("" when none).
std::string embeddingProblem(const SimBody& b) {
  const DeformationOctree& d = b.cut.deformation;
  std::ostringstream out;
  if (b.embedding.size() != b.surface.vertexSlots()) {
    out << b.embedding.size() << " vertex embeddings for " << b.surface.vertexSlots()
        << " vertex slots";
    return out.str();
  }
  for (std::size_t v = 0; v < b.embedding.size(); ++v) {
    if (!b.surface.alive(static_cast<std::int32_t>(v))) continue;
    const std::uint32_t e = d.owner(static_cast<std::size_t>(b.surface.vertexVoxels()[v]));
    const OctreeElement& el = d.element(e);
    const Vec3d local = (b.surface.positions()[v] - d.nodeGridPosition(el.firstVoxel())) /
                        (d.voxelSize() * el.size());
    if (b.embedding[v].element != e || b.embedding[v].local != local) {
      out << "surface vertex " << v << " embedded in element " << b.embedding[v].element
          << " at (" << b.embedding[v].local.transpose() << "), not in " << e << " at ("
          << local.transpose() << ")";
      return out.str();
    }
  }
  return "";
}

}  // namespace

std::string World::selfCheck(BodyId body) const {
  const SimBody& b = impl_->body(body);
  std::string problem = octreeProblem(b);
  if (problem.empty()) problem = embeddingProblem(b);
  if (problem.empty() && !surfaceTopology(surfaceMesh(body)).closed)
    problem = "the surface is not closed";
  return problem;
}

// ---- tools ----

}  // namespace voxcut
