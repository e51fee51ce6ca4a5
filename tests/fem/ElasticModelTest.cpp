#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "../topology/OctreeChecks.h"
#include "FemBodies.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ImplicitEuler.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/topology/CutTopology.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

using namespace test;

// --- Topology updates -------------------------------------------------------------------------

/// The identity map, marked as a change so that the model processes it.
TopologyChange identityMarkedChanged(const DeformationOctree& oc) {
  TopologyChange c = identityChange(oc);
  c.changed = true;
  return c;
}

TEST(ElasticModelTopology, IdentityUpdateChangesNothing) {
  Body a = smallBody(0.2, 1e-4);
  std::vector<std::uint8_t> fixed(a.octree.nodeCount(), 0);
  for (std::size_t n : {0, 5}) fixed.at(n) = 1;
  a.model.setFixed(fixed);
  perturb(a.octree, 5e-4);
  ImplicitEulerParams p;
  p.gravity = Vec3d(0, 0, -9.81);
  // The Cholesky preconditioner treats a new structure (a new sparsity revision) differently
  // from one it has seen for a while; the two-level one depends only on the matrix.
  p.preconditioner = PreconditionerKind::TwoLevel;
  ImplicitEuler sa(p);
  for (int s = 0; s < 5; ++s) sa.step(a.model, a.octree);
  DeformationOctree octree = a.octree;  // a copy, as a cut step would make
  ElasticModel model = a.model;
  ImplicitEuler sb = sa;
  const TopologyChange change = identityMarkedChanged(octree);
  model.updateTopology(octree, a.grid, change);
  sb.updateTopology(change);
  EXPECT_EQ(model.fixed(), a.model.fixed());
  EXPECT_EQ(sb.velocities(), sa.velocities());
  for (int s = 0; s < 5; ++s) {
    const StepStatus x = sa.step(a.model, a.octree), y = sb.step(model, octree);
    EXPECT_EQ(x.iterations, y.iterations);
  }
  EXPECT_EQ(octree.positions(), a.octree.positions());
}

TEST(ElasticModelTopology, RenumberedNodesAndRecomputedElements) {
  Body a = smallBody(0.2, 1e-4);
  perturb(a.octree, 5e-4);
  ImplicitEulerParams p;
  p.gravity = Vec3d(0, 0, -9.81);
  p.tolerance = 1e-12;
  p.maxIterations = 1000;
  ImplicitEuler sa(p);
  for (int s = 0; s < 3; ++s) sa.step(a.model, a.octree);

  // The same octree with its nodes numbered backwards.
  const DeformationOctree& old = a.octree;
  const auto count = static_cast<std::uint32_t>(old.nodeCount());
  auto renumber = [count](std::uint32_t n) { return count - 1 - n; };
  std::vector<OctreeElement> elements = old.elements();
  for (OctreeElement& e : elements)
    for (std::uint32_t& n : e.nodes) n = renumber(n);
  std::vector<Index3> coords(count);
  for (std::uint32_t n = 0; n < count; ++n) coords[renumber(n)] = old.nodeCoord(n);
  std::vector<HangingNode> hanging = old.hangingNodes();
  for (HangingNode& h : hanging) {
    h.node = renumber(h.node);
    for (int m = 0; m < h.masterCount; ++m)
      h.masters[static_cast<std::size_t>(m)] = renumber(h.masters[static_cast<std::size_t>(m)]);
  }
  std::stable_sort(hanging.begin(), hanging.end(), [](const HangingNode& x, const HangingNode& y) {
    return x.coarseLevel != y.coarseLevel ? x.coarseLevel > y.coarseLevel : x.node < y.node;
  });
  std::vector<VoxelEmbedding> embedding(a.grid.voxelCount());
  for (std::size_t v = 0; v < embedding.size(); ++v) embedding[v] = old.embedding(v);
  int maxLevel = 0;
  for (const OctreeElement& e : elements) maxLevel = std::max(maxLevel, e.level);
  DeformationOctree octree(a.grid, maxLevel, elements, coords, hanging, embedding);
  for (std::uint32_t n = 0; n < count; ++n) octree.positions()[renumber(n)] = old.positions()[n];

  TopologyChange change = identityMarkedChanged(octree);
  for (std::uint32_t n = 0; n < count; ++n) change.nodeSource[renumber(n)].nodes[0] = n;
  for (std::size_t e = 0; e < change.elementSource.size(); e += 3)
    change.elementSource[e] = kNewElement;
  ElasticModel model = a.model;
  ImplicitEuler sb = sa;
  model.updateTopology(octree, a.grid, change);
  sb.updateTopology(change);
  for (std::uint32_t e = 0; e < model.elementCount(); ++e) {
    const double scale = a.model.element(e).stiffness.cwiseAbs().maxCoeff();
    EXPECT_LE((model.element(e).stiffness - a.model.element(e).stiffness).cwiseAbs().maxCoeff(),
              e % 3 == 0 ? 1e-13 * scale : 0.0);
  }
  for (std::uint32_t n = 0; n < count; ++n) {
    EXPECT_EQ(sb.velocities()[renumber(n)], sa.velocities()[n]);
    EXPECT_EQ(model.nodeMass()[renumber(n)], a.model.nodeMass()[n]);
  }
  for (int s = 0; s < 5; ++s) {
    EXPECT_TRUE(sa.step(a.model, a.octree).converged);
    EXPECT_TRUE(sb.step(model, octree).converged);
  }
  for (std::uint32_t n = 0; n < count; ++n)
    EXPECT_LE((octree.positions()[renumber(n)] - a.octree.positions()[n]).norm(), 1e-12);
}

TEST(ElasticModelTopology, WeightedSourcesAndFixedFlags) {
  Body a = smallBody(0.0, 0.0);
  std::vector<std::uint8_t> fixed(a.octree.nodeCount(), 0);
  for (std::size_t n : {1, 2, 7}) fixed.at(n) = 1;
  a.model.setFixed(fixed);
  ImplicitEuler solver;
  std::vector<Vec3d> v(a.octree.nodeCount());
  for (std::size_t n = 0; n < v.size(); ++n) v[n] = Vec3d(1.0 * static_cast<double>(n), 2, 3);
  solver.setVelocities(v);
  TopologyChange change = identityMarkedChanged(a.octree);
  // Node 4 from nodes 1 and 2 (both fixed), node 6 from 7 (fixed) and 8 (free).
  change.nodeSource[4] = {2, {1, 2}, {0.25, 0.75}};
  change.nodeSource[6] = {2, {7, 8}, {0.5, 0.5}};
  ElasticModel model = a.model;
  model.updateTopology(a.octree, a.grid, change);
  solver.updateTopology(change);
  EXPECT_EQ(solver.velocities()[4], 0.25 * v[1] + 0.75 * v[2]);
  EXPECT_EQ(solver.velocities()[6], 0.5 * v[7] + 0.5 * v[8]);
  EXPECT_EQ(solver.velocities()[9], v[9]);
  EXPECT_EQ(model.requestedFixed()[4], 1);
  EXPECT_EQ(model.requestedFixed()[6], 0);
  EXPECT_EQ(model.requestedFixed()[7], 1);
  EXPECT_EQ(model.freeIndex(4), kNotFree);
}

TEST(ElasticModelTopology, GivenFixedFlagsEqualSetFixedAfterTheUpdate) {
  // updateTopology with fixed flags builds the constraints once: the same model as deriving
  // them from the sources and then calling setFixed.
  Body a = smallBody(0.0, 0.0);
  std::vector<std::uint8_t> before(a.octree.nodeCount(), 0);
  before.at(3) = 1;
  a.model.setFixed(before);
  TopologyChange change = identityMarkedChanged(a.octree);
  change.elementSource[0] = kNewElement;
  std::vector<std::uint8_t> after(a.octree.nodeCount(), 0);
  for (std::size_t n : {0, 1, 9}) after.at(n) = 1;
  ElasticModel once = a.model, twice = a.model;
  once.updateTopology(a.octree, a.grid, change, &after);
  twice.updateTopology(a.octree, a.grid, change);
  twice.setFixed(after);
  EXPECT_EQ(once.requestedFixed(), twice.requestedFixed());
  EXPECT_EQ(once.fixed(), twice.fixed());
  EXPECT_EQ(once.requestedFixed()[3], 0);
  EXPECT_EQ(once.freeNodes(), twice.freeNodes());
  EXPECT_EQ(once.sparsity().column, twice.sparsity().column);
  EXPECT_EQ(once.sparsity().source, twice.sparsity().source);
  EXPECT_EQ(once.aggregation().aggregate, twice.aggregation().aggregate);
}

/// Every array of the reduced system's structure is equal, bit for bit.
void expectSameStructure(const ElasticModel& a, const ElasticModel& b) {
  ASSERT_EQ(a.freeNodes(), b.freeNodes());
  for (auto rows :
       {&ElasticModel::prolongation, &ElasticModel::restriction, &ElasticModel::incidence}) {
    ASSERT_EQ((a.*rows)().start, (b.*rows)().start);
    ASSERT_EQ((a.*rows)().index, (b.*rows)().index);
    ASSERT_EQ((a.*rows)().weight, (b.*rows)().weight);
  }
  const BlockSparsity &x = a.sparsity(), &y = b.sparsity();
  ASSERT_EQ(x.rowStart, y.rowStart);
  ASSERT_EQ(x.column, y.column);
  ASSERT_EQ(x.diagonal, y.diagonal);
  ASSERT_EQ(x.mirror, y.mirror);
  ASSERT_EQ(x.sourceStart, y.sourceStart);
  ASSERT_EQ(x.source, y.source);
  ASSERT_EQ(x.sourceWeight, y.sourceWeight);
}

// A blade advancing through the bunny's ears a few links per frame, the bunny fixed at its
// base: after each cut the updated structure equals a full rebuild (setFixed) bit for bit,
// and most of its rows were copied from the structure before, not gathered anew.
TEST(ElasticModelTopology, CutUpdateEqualsAFullRebuildAndCopiesMostRows) {
  VoxelizeParams vp;
  vp.resolution.resolution = 81;
  VoxelGrid grid = voxelize(loadModel("bunny").materials, vp);
  DeformationOctree octree = buildDeformationOctree(grid);
  ElasticModel model(octree, grid, layeredMaterials(0.4));
  std::vector<std::uint8_t> fixed(octree.nodeCount(), 0);
  for (std::uint32_t n = 0; n < octree.nodeCount(); ++n)
    fixed[n] = octree.nodeCoord(n).z <= 6 ? 1 : 0;
  model.setFixed(fixed);
  ASSERT_GT(octree.hangingNodeCount(), 0u);
  const Index3 d = grid.dims();
  const auto frames = test::bladeFrames(grid, static_cast<int>(0.8 * d.y), d.x / 8, d.x * 5 / 8,
                                        0.8 * d.z, 0.2 * d.z, 12);
  std::size_t updates = 0, rows = 0, copied = 0;
  for (const auto& cut : frames) {
    if (cut.empty()) continue;
    for (std::uint64_t id : cut) grid.setConnected(id / 3, static_cast<int>(id % 3), false);
    const TopologyChange change = updateCutTopology(octree, grid, cut);
    if (!change.changed) continue;
    model.updateTopology(octree, grid, change);
    ElasticModel full = model;
    full.setFixed(model.requestedFixed());
    EXPECT_EQ(full.sparsityRowsReused(), 0u);
    expectSameStructure(model, full);
    ++updates;
    rows += model.freeNodeCount();
    copied += model.sparsityRowsReused();
  }
  ASSERT_GE(updates, 5u);
  // Each frame changes a strip a few elements wide: most rows lie away from it.
  EXPECT_GT(copied, rows / 2);
  EXPECT_LT(copied, rows);
  std::printf("%zu updates, %zu of %zu rows copied\n", updates, copied, rows);
}

TEST(ElasticModelTopology, FixingAHangingNodeFixesItsMasters) {
  Body a = smallBody(0.0, 0.0);
  ASSERT_GT(a.octree.hangingNodeCount(), 0u);
  const HangingNode h = a.octree.hangingNodes().back();
  std::vector<std::uint8_t> fixed(a.octree.nodeCount(), 0);
  fixed[h.node] = 1;
  a.model.setFixed(fixed);
  for (int m = 0; m < h.masterCount; ++m)
    EXPECT_EQ(a.model.fixed()[h.masters[static_cast<std::size_t>(m)]], 1);
  ImplicitEulerParams p;
  p.gravity = Vec3d(0, 0, -9.81);
  ImplicitEuler solver(p);
  for (int s = 0; s < 3; ++s) solver.step(a.model, a.octree);
  EXPECT_EQ(a.octree.positions()[h.node], a.octree.restPositions()[h.node]);
}

// The reduced system's structure is built in fixed row chunks joined in order: the same with
// one thread as with two, on a body with hanging nodes and several chunks of rows.
TEST(ElasticModelTopology, StructureIsTheSameWithOneAndTwoThreads) {
  const VoxelGrid g = compositeBox();
  const DeformationOctree oc = makeOctree(g, 0, 2);
  ASSERT_GT(oc.hangingNodeCount(), 0u);
  std::vector<std::uint8_t> fixed(oc.nodeCount(), 0);
  for (std::size_t n = 0; n < fixed.size(); n += 97) fixed[n] = 1;
  ElasticModel serial(oc, g, layeredMaterials(0.3), false);
  serial.setFixed(fixed);
  const ThreadLimit limit(2);
  ElasticModel parallel(oc, g, layeredMaterials(0.3), true);
  parallel.setFixed(fixed);
  ASSERT_GT(serial.freeNodeCount(), 3u * 128u);  // many chunks of rows
  expectSameStructure(serial, parallel);
  const BlockSparsity& a = serial.sparsity();
  // Every row holds its diagonal, columns ascend, and the prolongation's weights of a
  // hanging node sum to 1 (an unconstrained node reproduces constant fields).
  for (std::size_t i = 0; i < serial.freeNodeCount(); ++i) {
    EXPECT_EQ(a.column[a.diagonal[i]], i);
    EXPECT_TRUE(
        std::is_sorted(a.column.begin() + a.rowStart[i], a.column.begin() + a.rowStart[i + 1]));
  }
  const WeightedRows& p = serial.prolongation();
  for (const HangingNode& h : oc.hangingNodes()) {
    bool anyFixed = false;
    for (int m = 0; m < h.masterCount; ++m) anyFixed = anyFixed || serial.fixed()[h.masters[m]];
    if (anyFixed) continue;
    double sum = 0.0;
    for (std::uint32_t k = p.start[h.node]; k < p.start[h.node + 1]; ++k) sum += p.weight[k];
    EXPECT_NEAR(sum, 1.0, 1e-12) << "hanging node " << h.node;
  }
}

}  // namespace
}  // namespace voxcut
