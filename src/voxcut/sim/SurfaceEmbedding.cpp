/// @file SurfaceEmbedding.cpp
/// A body's model and embedded surface: the element matrices with the fixed nodes, and the
/// surface vertices embedded in the deformation octree's elements (docs/algorithms.md,
/// "Embedded surface").

#include <algorithm>

#include "voxcut/sim/WorldImpl.h"

namespace voxcut {

// The element matrices from the body's materials, with its fixed nodes.
void World::Impl::rebuildModel(SimBody& b) const {
  b.model = ElasticModel(b.cut.deformation, b.cut.grid, b.elastic, settings.threaded);
  if (!b.settings.fixed.empty()) b.model.setFixed(fixedFlags(b));
}

// A node in a fixed box is fixed when an element copy using it holds material within a voxel
// of the box: a copy reaches past its own voxels (a piece cut off next to the box, in a coarse
// element whose corners reach into the box) and must not pin material that lies away from it.
std::vector<std::uint8_t> World::Impl::fixedFlags(const SimBody& b) {
  const DeformationOctree& d = b.cut.deformation;
  const VoxelGrid& g = b.cut.grid;
  const std::vector<Vec3d>& rest = d.restPositions();
  std::vector<std::uint8_t> holds(d.elementCount(), 0);
  const Index3 gd = g.dims();
  for (const FixedBox& box : b.settings.fixed) {
    // The voxels whose centres lie within a voxel of the box (a box that holds only nodes,
    // around a body's end face, holds the voxels next to them).
    FixedBox near = box;
    near.lo -= Vec3d::Constant(g.voxelSize());
    near.hi += Vec3d::Constant(g.voxelSize());
    Index3 lo, hi;
    for (int a = 0; a < 3; ++a) {
      const double l = (box.lo[a] - g.origin()[a]) / g.voxelSize();
      const double h = (box.hi[a] - g.origin()[a]) / g.voxelSize();
      lo[a] = static_cast<int>(std::clamp(std::floor(l) - 1.0, 0.0, static_cast<double>(gd[a])));
      hi[a] = static_cast<int>(std::clamp(std::ceil(h) + 2.0, 0.0, static_cast<double>(gd[a])));
    }
    for (int z = lo.z; z < hi.z; ++z)
      for (int y = lo.y; y < hi.y; ++y)
        for (int x = lo.x; x < hi.x; ++x) {
          const std::size_t v = g.index(x, y, z);
          if (g.occupied(v) && inside(near, g.position(v))) holds[d.owner(v)] = 1;
        }
  }
  std::vector<std::uint8_t> fixed(rest.size(), 0);
  for (std::uint32_t e = 0; e < d.elementCount(); ++e) {
    if (!holds[e]) continue;
    for (std::uint32_t n : d.element(e).nodes)
      for (const FixedBox& box : b.settings.fixed)
        if (inside(box, rest[n])) fixed[n] = 1;
  }
  return fixed;
}

void World::Impl::embedVertices(SimBody& b, const std::vector<std::int32_t>* only) const {
  const DeformationOctree& d = b.cut.deformation;
  const std::vector<Vec3d>& rest = b.surface.positions();
  const std::vector<std::uint64_t>& voxel = b.surface.vertexVoxels();
  b.embedding.resize(b.surface.vertexSlots());
  b.vertexPositions.resize(b.surface.vertexSlots(), Vec3d::Zero());
  auto embed = [&](std::size_t v) {
    if (!b.surface.alive(static_cast<std::int32_t>(v))) {
      b.embedding[v] = VertexEmbedding{};
      return;
    }
    const std::uint32_t e = d.owner(static_cast<std::size_t>(voxel[v]));
    VOXCUT_ASSERT(e != kNoElement, "a surface vertex's voxel is occupied");
    const OctreeElement& el = d.element(e);
    const double size = d.voxelSize() * el.size();
    b.embedding[v] = VertexEmbedding{e, (rest[v] - d.nodeGridPosition(el.firstVoxel())) / size};
  };
  if (only) {
    for (std::int32_t v : *only) embed(static_cast<std::size_t>(v));
    return;
  }
  parallelFor(
      0, b.embedding.size(), 4096,
      [&](std::size_t lo, std::size_t hi) {
        for (std::size_t v = lo; v < hi; ++v) embed(v);
      },
      settings.threaded);
}

void World::Impl::updateVertexPositions(SimBody& b) const {
  const DeformationOctree& d = b.cut.deformation;
  parallelFor(
      0, b.embedding.size(), 4096,
      [&](std::size_t lo, std::size_t hi) {
        for (std::size_t v = lo; v < hi; ++v)
          if (b.embedding[v].element != kNoElement)
            b.vertexPositions[v] = d.pointInElement(b.embedding[v].element, b.embedding[v].local);
      },
      settings.threaded);
}

// After a topology change, each surface vertex's element id: the new id of its element when
// that element was kept (same cube, same voxels: the vertex's trilinear coordinates in it are
// the same), else looked up again from its voxel. One pass over the vertices with a table the
// size of the elements; only the vertices in refined or copied elements read the grid-sized
// embedding.
void World::Impl::renumberVertexElements(SimBody& b, const TopologyChange& change) const {
  std::vector<std::uint32_t> kept;  // old element -> its new id, or kNoElement
  for (std::size_t e = 0; e < change.elementSource.size(); ++e) {
    const std::uint32_t old = change.elementSource[e];
    if (old == kNewElement) continue;
    if (old >= kept.size()) kept.resize(static_cast<std::size_t>(old) + 1, kNoElement);
    kept[old] = static_cast<std::uint32_t>(e);
  }
  std::vector<std::int32_t> again;
  for (std::size_t v = 0; v < b.embedding.size(); ++v) {
    VertexEmbedding& em = b.embedding[v];
    if (em.element == kNoElement) continue;
    const std::uint32_t now = em.element < kept.size() ? kept[em.element] : kNoElement;
    if (now != kNoElement)
      em.element = now;
    else
      again.push_back(static_cast<std::int32_t>(v));
  }
  embedVertices(b, &again);
}

// After the surface's update for the cuts: its new vertices embedded (and, when elements were
// renumbered, the others' element ids renumbered), and the change logged for readers.
void World::Impl::embedSurfaceChange(SimBody& b, SurfaceDelta delta, const TopologyChange& change) {
  b.embedding.resize(b.surface.vertexSlots());
  b.vertexPositions.resize(b.surface.vertexSlots(), Vec3d::Zero());
  for (std::int32_t v : delta.removedVertices) b.embedding[static_cast<std::size_t>(v)] = {};
  if (change.changed) renumberVertexElements(b, change);
  embedVertices(b, &delta.addedVertices);
  if (delta.addedVertices.empty() && delta.removedVertices.empty() &&
      delta.addedTriangles.empty() && delta.removedTriangles.empty())
    return;
  // A bounded log: a reader further behind reads everything again (SurfaceChanges::full).
  constexpr std::size_t kLogLength = 256;
  b.surfaceLog.push_back({++b.surfaceRevision, std::move(delta)});
  if (b.surfaceLog.size() > kLogLength) b.surfaceLog.pop_front();
}

}  // namespace voxcut
