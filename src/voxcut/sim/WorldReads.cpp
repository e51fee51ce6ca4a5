/// @file WorldReads.cpp
/// What the world lets an application read (sim/World.h): surfaces, their changes, the
/// pseudo voxel octree, nodes, energy, contacts and the cut set's hash.

#include <algorithm>
#include <string>

#include "voxcut/core/Fnv.h"
#include "voxcut/sim/WorldImpl.h"
#include "voxcut/surface/VertexNormals.h"

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
  for (const auto& t : b.surface.triangles()) {
    if (t[0] < 0) continue;
    m.triangles.push_back({index[static_cast<std::size_t>(t[0])],
                           index[static_cast<std::size_t>(t[1])],
                           index[static_cast<std::size_t>(t[2])]});
  }
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

// ---- tools ----

}  // namespace voxcut
