/// @file BodyBuild.cpp
/// The world's bodies (sim/World.h): a body built from a voxel grid (its octrees, model,
/// solver, surface and distance field), removed, and its materials, fixed boxes and octree
/// setting changed while the world runs.

#include "voxcut/sim/World.h"

#include <algorithm>
#include <string>

#include "voxcut/sim/WorldChecks.h"
#include "voxcut/sim/WorldImpl.h"
#include "voxcut/voxel/Pieces.h"

namespace voxcut {

// ---- bodies ----

BodyId World::addBody(VoxelGrid grid, const BodySettings& settings) {
  impl_->edited();
  Impl& w = *impl_;
  const WorldSettings& ws = w.settings;
  impl_->check([&] { checkBodySettings(settings); });
  impl_->check([&] { checkGrid(grid, "grid"); });
  SimBody& b = w.bodies.emplace_back();
  try {
    CutBodyParams cp;
    cp.useOctree = ws.useOctree;
    cp.octree = voxelOctreeParams(settings, grid);
    cp.deformation.startLevel = settings.elementLevel;
    cp.deformation.maxLevel = std::min(settings.elementLevel + 1, 7);
    cp.deformation.surfaceLevel = settings.surfaceLevel;
    b.settings = settings;
    b.elastic = elasticMaterials(settings, grid);
    b.cut = makeCutBody(std::move(grid), cp, ws.threaded);
    ImplicitEulerParams solver;
    solver.timeStep = ws.timeStep;
    solver.gravity = ws.gravity;
    solver.tolerance = ws.solver.tolerance;
    solver.maxIterations = ws.solver.maxIterations;
    solver.projectionHistory = ws.solver.projectionHistory;
    solver.preconditioner = preconditionerOf(ws.solver.preconditioner);
    b.solver = ImplicitEuler(solver);
    w.rebuildModel(b);
    double stiffest = 0.0;
    for (const ElasticMaterial& m : b.elastic) stiffest = std::max(stiffest, m.youngModulus);
    b.contactStiffness = ws.contact.stiffness > 0.0 ? ws.contact.stiffness
                                                    : 10.0 * stiffest * b.cut.grid.voxelSize();
    b.fronts.resize(w.tools.size());
    b.frontSegments.assign(w.tools.size(), 0);
    DualContourParams dc;
    dc.threaded = ws.threaded;
    b.surface = ContouredSurface::build(b.cut.grid, dc);
    b.restDistance.build(b.cut.grid, kRestDistanceBand);
    w.embedVertices(b, nullptr);
    w.updateVertexPositions(b);
  } catch (...) {
    w.bodies.pop_back();
    throw;
  }
  return w.bodySlots.add();
}

void World::removeBody(BodyId body) {
  impl_->edited();
  Impl& w = *impl_;
  const std::size_t p = w.bodyAt(body);
  w.bodies.erase(w.bodies.begin() + static_cast<std::ptrdiff_t>(p));
  w.bodySlots.removeAt(p);
}

std::size_t World::bodyCount() const {
  return impl_->bodies.size();
}

std::vector<BodyId> World::bodies() const {
  return impl_->bodySlots.all();
}

bool World::contains(BodyId body) const {
  return impl_->bodySlots.find(body).has_value();
}

void World::setFixed(BodyId body, std::vector<FixedBox> fixed) {
  impl_->edited();
  SimBody& b = impl_->body(body);
  impl_->check([&] { checkFixedBoxes(fixed, "fixed"); });
  const bool had = !b.settings.fixed.empty();
  b.settings.fixed = std::move(fixed);
  if (had || !b.settings.fixed.empty())
    b.model.setFixed(b.settings.fixed.empty() ? std::vector<std::uint8_t>{} : Impl::fixedFlags(b));
}

void World::setMaterial(BodyId body, const SceneMaterial& material) {
  impl_->edited();
  SimBody& b = impl_->body(body);
  impl_->check([&] { checkMaterial(material, "material"); });
  const std::vector<std::string>& names = b.cut.grid.materialNames();
  const auto it = std::find(names.begin(), names.end(), material.name);
  if (it == names.end()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    throw InputError(impl_->prefix() + "material.name: the body has no material '" +
                     material.name + "' (it has: " + list + ")");
  }
  std::erase_if(b.settings.materials,
                [&](const SceneMaterial& m) { return m.name == material.name; });
  b.settings.materials.push_back(material);
  b.elastic = elasticMaterials(b.settings, b.cut.grid);
  impl_->rebuildModel(b);
}

BodyInfo World::bodyInfo(BodyId body) const {
  const SimBody& b = impl_->body(body);
  BodyInfo info;
  info.elements = b.cut.deformation.elementCount();
  info.nodes = b.cut.deformation.nodeCount();
  info.cutLinks = b.cutLinks;
  info.surfaceVertices = b.surface.vertexCount();
  info.surfaceTriangles = b.surface.triangleCount();
  info.voxelSize = b.cut.grid.voxelSize();
  info.materialNames = b.cut.grid.materialNames();
  info.materialColours = b.cut.grid.materialColours();
  info.solver = solverChoiceOf(b.solver.chosenPreconditioner());
  info.selfCandidateQueries = b.selfCandidates.queries;
  return info;
}

void World::setUseOctree(bool on) {
  impl_->edited();
  impl_->settings.useOctree = on;
  for (SimBody& b : impl_->bodies)
    setActivity(b.cut, on, voxelOctreeParams(b.settings, b.cut.grid), impl_->settings.threaded);
}

int World::pieces(BodyId body) const {
  return findPieces(impl_->body(body).cut.grid).count;
}

}  // namespace voxcut
