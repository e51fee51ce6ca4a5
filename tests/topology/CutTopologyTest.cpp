#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <random>

#include "OctreeChecks.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/topology/CutTopology.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/voxel/PlaneCut.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

using test::bladeFrames;
using test::expectNoGap;
using test::expectOctreeInvariants;
using test::nodeConnectedComponents;

VoxelGrid solidBox(const Index3& dims, const Index3& lo, const Index3& hi) {
  VoxelGrid g(dims, Vec3d(0.02, -0.01, 0.03), 0.005);
  for (int z = lo.z; z < hi.z; ++z)
    for (int y = lo.y; y < hi.y; ++y)
      for (int x = lo.x; x < hi.x; ++x) g.setMaterial(g.index(x, y, z), 1);
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a)
      g.setConnected(v, a, g.occupied(v) && g.hasLink(v, a) && g.occupied(v + g.stride(a)));
  return g;
}

/// Disconnects the connected links crossed by the plane n.x = d (voxel coordinates) whose
/// lower voxel satisfies `where`; returns their ids ascending.
template <class Where>
std::vector<std::uint64_t> cutPlane(VoxelGrid& g, const Vec3d& n, double d, Where&& where) {
  std::vector<std::uint64_t> ids;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    const Index3 c = g.coord(v);
    const double sv = n.dot(Vec3d(c.x, c.y, c.z)) - d;
    for (int a = 0; a < 3; ++a) {
      if (!g.hasLink(v, a) || !g.connected(v, a) || !where(c)) continue;
      Index3 w = c;
      ++w[a];
      const double sw = n.dot(Vec3d(w.x, w.y, w.z)) - d;
      if ((sv < 0) != (sw < 0)) {
        g.setConnected(v, a, false);
        ids.push_back(VoxelGrid::linkId(v, a));
      }
    }
  }
  return ids;
}

void shake(DeformationOctree& oc, unsigned seed, double amount = 0.3) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(-amount, amount);
  for (std::size_t n = 0; n < oc.nodeCount(); ++n)
    oc.positions()[n] = oc.restPositions()[n] + oc.voxelSize() * Vec3d(d(rng), d(rng), d(rng));
  oc.updateHangingNodes();
}

std::vector<Vec3d> voxelPositions(const VoxelGrid& g, const DeformationOctree& oc) {
  std::vector<Vec3d> out(g.voxelCount(), Vec3d::Zero());
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    if (g.occupied(v)) out[v] = oc.voxelPosition(v);
  return out;
}

/// Sizes, weights and references of a TopologyChange from `before` to `after`.
void expectChangeConsistent(const DeformationOctree& before, const DeformationOctree& after,
                            const TopologyChange& tc) {
  ASSERT_EQ(tc.elementSource.size(), after.elementCount());
  ASSERT_EQ(tc.nodeSource.size(), after.nodeCount());
  for (std::uint32_t e = 0; e < after.elementCount(); ++e) {
    const std::uint32_t s = tc.elementSource[e];
    if (s == kNewElement) continue;
    ASSERT_LT(s, before.elementCount());
    EXPECT_EQ(before.element(s).level, after.element(e).level);
    EXPECT_EQ(before.element(s).coord, after.element(e).coord);
  }
  for (std::uint32_t n = 0; n < after.nodeCount(); ++n) {
    const NodeSource& s = tc.nodeSource[n];
    ASSERT_TRUE(s.count == 1 || s.count == 2 || s.count == 4 || s.count == 8) << int(s.count);
    double sum = 0;
    Vec3d rest = Vec3d::Zero();
    for (int i = 0; i < s.count; ++i) {
      ASSERT_LT(s.nodes[static_cast<std::size_t>(i)], before.nodeCount());
      sum += s.weights[static_cast<std::size_t>(i)];
      rest += s.weights[static_cast<std::size_t>(i)] *
              before.restPositions()[s.nodes[static_cast<std::size_t>(i)]];
    }
    EXPECT_NEAR(sum, 1.0, 1e-14);
    EXPECT_LE((rest - after.restPositions()[n]).norm(), 1e-12);
  }
}

struct CutCase {
  VoxelGrid grid;
  DeformationOctree octree;
};

/// A 24^3 box inside a 28^3 grid, octree from level 2 (merged to 3), deformed at random.
CutCase boxCase() {
  CutCase c{solidBox({28, 28, 28}, {2, 2, 2}, {26, 26, 26}), {}};
  DeformationOctreeParams p;
  p.startLevel = 2;
  p.maxLevel = 3;
  c.octree = buildDeformationOctree(c.grid, p);
  shake(c.octree, 3);
  return c;
}

/// Updates after a cut and checks everything the brief lists; returns the change.
TopologyChange cutAndCheck(CutCase& c, const std::vector<std::uint64_t>& links, int finest) {
  const DeformationOctree before = c.octree;
  const std::vector<Vec3d> moved = voxelPositions(c.grid, c.octree);
  CutTopologyParams p;
  p.finestLevel = finest;
  const TopologyChange tc = updateCutTopology(c.octree, c.grid, links, p);
  EXPECT_TRUE(tc.changed);
  expectOctreeInvariants(c.grid, c.octree, 2, finest, false);
  expectChangeConsistent(before, c.octree, tc);
  // Material does not move.
  const std::vector<Vec3d> after = voxelPositions(c.grid, c.octree);
  for (std::size_t v = 0; v < after.size(); ++v)
    EXPECT_LE((after[v] - moved[v]).norm(), 1e-12) << v;
  // A cut link's two voxels share an element copy only at the finest level (elsewhere the
  // refinement went on until they came apart).
  for (std::uint64_t id : links) {
    const std::size_t v = id / 3, w = v + c.grid.stride(static_cast<int>(id % 3));
    if (c.octree.owner(v) == c.octree.owner(w)) {
      EXPECT_LE(c.octree.element(c.octree.owner(v)).level, finest);
    }
  }
  // Positions of kept nodes carried over.
  for (std::uint32_t n = 0; n < c.octree.nodeCount(); ++n) {
    const NodeSource& s = tc.nodeSource[n];
    Vec3d x = Vec3d::Zero();
    for (int i = 0; i < s.count; ++i)
      x += s.weights[static_cast<std::size_t>(i)] *
           before.positions()[s.nodes[static_cast<std::size_t>(i)]];
    EXPECT_LE((x - c.octree.positions()[n]).norm(), 1e-12);
  }
  DeformationOctree shaken = c.octree;
  shake(shaken, 17);
  test::expectConforming(shaken, 1e-12);
  expectNoGap(c.grid, shaken, 1e-12);
  return tc;
}

TEST(CutTopology, PlaneThroughSeparatesTheBox) {
  for (int finest : {0, 1}) {
    SCOPED_TRACE("finest level " + std::to_string(finest));
    CutCase c = boxCase();
    EXPECT_EQ(nodeConnectedComponents(c.octree), 1);
    const auto links =
        cutPlane(c.grid, Vec3d(1, 0.3, 0.2), 15.3, [](const Index3&) { return true; });
    ASSERT_GT(links.size(), 400u);
    cutAndCheck(c, links, finest);
    EXPECT_EQ(nodeConnectedComponents(c.octree), 2);
  }
}

TEST(CutTopology, PartialCutStaysOnePieceWithoutGaps) {
  CutCase c = boxCase();
  const auto links =
      cutPlane(c.grid, Vec3d(0.2, 1, -0.1), 13.6, [](const Index3& p) { return p.x < 15; });
  ASSERT_GT(links.size(), 100u);
  cutAndCheck(c, links, 0);
  EXPECT_EQ(nodeConnectedComponents(c.octree), 1);
}

TEST(CutTopology, ProgressiveCutSeparatesAtTheEnd) {
  CutCase c = boxCase();
  const Vec3d n(0.1, -0.2, 1);
  for (int step = 0; step < 4; ++step) {
    SCOPED_TRACE("step " + std::to_string(step));
    const int lo = step * 7, hi = step == 3 ? 100 : (step + 1) * 7;
    const auto links =
        cutPlane(c.grid, n, 12.4, [&](const Index3& p) { return p.y >= lo && p.y < hi; });
    ASSERT_FALSE(links.empty());
    cutAndCheck(c, links, 0);
    EXPECT_EQ(nodeConnectedComponents(c.octree), step == 3 ? 2 : 1);
  }
}

/// Every array of two octrees and two changes is equal, bit for bit.
void expectSame(const DeformationOctree& a, const DeformationOctree& b, const TopologyChange& ta,
                const TopologyChange& tb) {
  ASSERT_EQ(a.elementCount(), b.elementCount());
  ASSERT_EQ(a.nodeCount(), b.nodeCount());
  for (std::uint32_t e = 0; e < a.elementCount(); ++e) {
    ASSERT_EQ(a.element(e).coord, b.element(e).coord);
    ASSERT_EQ(a.element(e).level, b.element(e).level);
    ASSERT_EQ(a.element(e).nodes, b.element(e).nodes);
    ASSERT_EQ(a.nextCopy(e), b.nextCopy(e));
  }
  for (std::uint32_t n = 0; n < a.nodeCount(); ++n) ASSERT_EQ(a.nodeCoord(n), b.nodeCoord(n));
  EXPECT_EQ(a.positions(), b.positions());
  EXPECT_EQ(a.restPositions(), b.restPositions());
  ASSERT_EQ(a.hangingNodeCount(), b.hangingNodeCount());
  for (std::size_t i = 0; i < a.hangingNodeCount(); ++i) {
    const HangingNode &ha = a.hangingNodes()[i], &hb = b.hangingNodes()[i];
    ASSERT_EQ(ha.node, hb.node);
    ASSERT_EQ(ha.element, hb.element);
    ASSERT_EQ(ha.masters, hb.masters);
  }
  for (std::size_t v = 0; v < a.gridDims().x * std::size_t(a.gridDims().y) * a.gridDims().z; ++v) {
    ASSERT_EQ(a.owner(v), b.owner(v));
    ASSERT_EQ(a.embedding(v).offset, b.embedding(v).offset);
  }
  EXPECT_EQ(ta.changed, tb.changed);
  EXPECT_EQ(ta.elementSource, tb.elementSource);
  ASSERT_EQ(ta.nodeSource.size(), tb.nodeSource.size());
  for (std::size_t n = 0; n < ta.nodeSource.size(); ++n) {
    ASSERT_EQ(ta.nodeSource[n].count, tb.nodeSource[n].count);
    ASSERT_EQ(ta.nodeSource[n].nodes, tb.nodeSource[n].nodes);
    ASSERT_EQ(ta.nodeSource[n].weights, tb.nodeSource[n].weights);
  }
}

/// The lowest element level of an octree.
int finestElementLevel(const DeformationOctree& oc) {
  int out = 99;
  for (const OctreeElement& e : oc.elements()) out = std::min(out, e.level);
  return out;
}

TEST(CutTopology, ThroughCutKeepsTheElementLevels) {
  // A plane through the whole box leaves every cut cube in two parts that share no node: no
  // element needs refining, only duplicating.
  CutCase c = boxCase();
  const int before = finestElementLevel(c.octree);
  const std::size_t elements = c.octree.elementCount();
  const auto links = cutPlane(c.grid, Vec3d(1, 0.3, 0.2), 15.3, [](const Index3&) { return true; });
  cutAndCheck(c, links, 0);
  EXPECT_EQ(finestElementLevel(c.octree), before);
  EXPECT_LT(c.octree.elementCount(), 2 * elements);
  EXPECT_EQ(nodeConnectedComponents(c.octree), 2);
}

TEST(CutTopology, PartialCutRefinesOnlyAlongItsFront) {
  // The cut stops at x = 15: only there do its two sides stay glued inside an element.
  CutCase c = boxCase();
  const auto links =
      cutPlane(c.grid, Vec3d(0.2, 1, -0.1), 13.6, [](const Index3& p) { return p.x < 15; });
  cutAndCheck(c, links, 0);
  std::size_t finest = 0;
  for (const OctreeElement& e : c.octree.elements()) {
    if (e.level != 0) continue;
    ++finest;
    EXPECT_GE(e.coord.x, 15 - 4);
    EXPECT_LE(e.coord.x, 15 + 4);
  }
  EXPECT_GT(finest, 0u);
  EXPECT_EQ(nodeConnectedComponents(c.octree), 1);
}

/// Every start-level region of the octree's grid.
std::vector<std::uint64_t> allRegions(const VoxelGrid& g, int level) {
  std::vector<std::uint64_t> out;
  const Index3 d = g.dims();
  for (int z = 0; z < d.z; z += 1 << level)
    for (int y = 0; y < d.y; y += 1 << level)
      for (int x = 0; x < d.x; x += 1 << level)
        out.push_back(DeformationOctree::cubeKey(level, {x >> level, y >> level, z >> level}));
  return out;
}

/// Coarsens every region of a box case and checks the octree, the map and the pieces.
TopologyChange coarsenAndCheck(CutCase& c, int frontLevel, int components) {
  const DeformationOctree before = c.octree;
  CoarsenParams p;
  p.startLevel = 2;
  p.surfaceLevel = 2;
  p.frontLevel = frontLevel;
  const CoarsenResult r = coarsenCutTopology(c.octree, c.grid, allRegions(c.grid, 2), p);
  expectOctreeInvariants(c.grid, c.octree, 2, 0, false);
  expectChangeConsistent(before, c.octree, r.change);
  EXPECT_EQ(nodeConnectedComponents(c.octree), components);
  DeformationOctree shaken = c.octree;
  shake(shaken, 23);
  test::expectConforming(shaken, 1e-12);
  expectNoGap(c.grid, shaken, 1e-12);
  return r.change;
}

TEST(CutTopology, CoarseningUndoesAProgressiveCutsRefinement) {
  CutCase c = boxCase();
  const std::size_t nodes = c.octree.nodeCount();
  const Vec3d n(0.1, -0.2, 1);
  for (int step = 0; step < 4; ++step) {
    const int lo = step * 7, hi = step == 3 ? 100 : (step + 1) * 7;
    cutAndCheck(c, cutPlane(c.grid, n, 12.4, [&](const Index3& p) { return p.y >= lo && p.y < hi; }),
                0);
  }
  EXPECT_EQ(finestElementLevel(c.octree), 0);
  const std::size_t refined = c.octree.nodeCount();
  const TopologyChange tc = coarsenAndCheck(c, 1, 2);
  EXPECT_TRUE(tc.changed);
  // Cut through: nothing is glued, so every region returns to the start level.
  EXPECT_EQ(finestElementLevel(c.octree), 2);
  EXPECT_LT(c.octree.nodeCount(), refined);
  EXPECT_LT(c.octree.nodeCount(), 2 * nodes);
  // Nothing left to do: a second pass changes nothing.
  EXPECT_FALSE(coarsenAndCheck(c, 1, 2).changed);
}

TEST(CutTopology, CoarseningKeepsAStoppedCutsFrontAtTheFrontLevel) {
  CutCase c = boxCase();
  cutAndCheck(c, cutPlane(c.grid, Vec3d(0.2, 1, -0.1), 13.6, [](const Index3& p) { return p.x < 15; }),
              0);
  coarsenAndCheck(c, 1, 1);
  EXPECT_EQ(finestElementLevel(c.octree), 1);
  // The cut stays open where it is: its links' voxels share a copy only at the front level.
  for (std::size_t v = 0; v < c.grid.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a) {
      if (!c.grid.occupied(v) || !c.grid.hasLink(v, a) || c.grid.connected(v, a)) continue;
      const std::size_t w = v + c.grid.stride(a);
      if (!c.grid.occupied(w) || c.octree.owner(v) != c.octree.owner(w)) continue;
      EXPECT_LE(c.octree.element(c.octree.owner(v)).level, 1);
    }
}

TEST(CutTopology, CoarseningIsTheSameForOneAndTwoThreads) {
  auto run = [](int threads) {
    ThreadLimit limit(threads);
    CutCase c = boxCase();
    for (int step = 0; step < 3; ++step) {
      const int lo = step * 9, hi = (step + 1) * 9;
      const auto links = cutPlane(c.grid, Vec3d(1, 0.7, -0.4), 14.1,
                                  [&](const Index3& p) { return p.z >= lo && p.z < hi; });
      (void)updateCutTopology(c.octree, c.grid, links);
    }
    CoarsenParams p;
    p.startLevel = 2;
    p.surfaceLevel = 2;
    TopologyChange tc = coarsenCutTopology(c.octree, c.grid, allRegions(c.grid, 2), p).change;
    return std::pair{std::move(c), std::move(tc)};
  };
  const auto [a, ta] = run(1);
  const auto [b, tb] = run(2);
  EXPECT_TRUE(ta.changed);
  expectSame(a.octree, b.octree, ta, tb);
}

TEST(CutTopology, NothingCutChangesNothing) {
  CutCase c = boxCase();
  const DeformationOctree before = c.octree;
  const TopologyChange tc = updateCutTopology(c.octree, c.grid, {});
  EXPECT_FALSE(tc.changed);
  ASSERT_EQ(c.octree.elementCount(), before.elementCount());
  for (std::uint32_t e = 0; e < c.octree.elementCount(); ++e) EXPECT_EQ(tc.elementSource[e], e);
  CutTopologyParams bad;
  bad.finestLevel = 8;
  EXPECT_THROW((void)updateCutTopology(c.octree, c.grid, {}, bad), InputError);
}

TEST(CutTopology, SameForOneAndTwoThreads) {
  auto run = [](int threads) {
    ThreadLimit limit(threads);
    CutCase c = boxCase();
    const auto links =
        cutPlane(c.grid, Vec3d(1, 0.7, -0.4), 14.1, [](const Index3& p) { return p.z < 20; });
    TopologyChange tc = updateCutTopology(c.octree, c.grid, links);
    return std::pair{std::move(c), std::move(tc)};
  };
  const auto [a, ta] = run(1);
  const auto [b, tb] = run(2);
  ASSERT_EQ(a.octree.elementCount(), b.octree.elementCount());
  ASSERT_EQ(a.octree.nodeCount(), b.octree.nodeCount());
  for (std::uint32_t e = 0; e < a.octree.elementCount(); ++e) {
    EXPECT_EQ(a.octree.element(e).coord, b.octree.element(e).coord);
    EXPECT_EQ(a.octree.element(e).level, b.octree.element(e).level);
    EXPECT_EQ(a.octree.element(e).nodes, b.octree.element(e).nodes);
  }
  EXPECT_EQ(a.octree.positions(), b.octree.positions());
  EXPECT_EQ(ta.elementSource, tb.elementSource);
  ASSERT_EQ(a.octree.hangingNodeCount(), b.octree.hangingNodeCount());
  for (std::size_t i = 0; i < a.octree.hangingNodeCount(); ++i)
    EXPECT_EQ(a.octree.hangingNodes()[i].masters, b.octree.hangingNodes()[i].masters);
  for (std::size_t v = 0; v < a.grid.voxelCount(); ++v)
    ASSERT_EQ(a.octree.owner(v), b.octree.owner(v));
}

TEST(CutTopology, BunnyEarCut) {
  VoxelizeParams vp;
  vp.resolution.resolution = 101;
  VoxelGrid g = voxelize(loadModel("bunny").materials, vp);
  DeformationOctree oc = buildDeformationOctree(g);
  const std::size_t before = oc.elementCount();
  // A plane across the upper part of the grid (the ears), in voxel coordinates.
  const auto links =
      cutPlane(g, Vec3d(0.2, 1, 0.1), 0.78 * g.dims().y, [](const Index3&) { return true; });
  ASSERT_GT(links.size(), 50u);
  const std::vector<Vec3d> moved = voxelPositions(g, oc);
  Timer timer;
  const TopologyChange tc = updateCutTopology(oc, g, links);
  const double ms = timer.ms();
  std::printf("bunny: %zu cut links, elements %zu -> %zu, nodes %zu, update %.2f ms\n",
              links.size(), before, oc.elementCount(), oc.nodeCount(), ms);
  EXPECT_TRUE(tc.changed);
  const std::vector<Vec3d> after = voxelPositions(g, oc);
  for (std::size_t v = 0; v < after.size(); ++v) ASSERT_LE((after[v] - moved[v]).norm(), 1e-12);
  shake(oc, 9);
  expectNoGap(g, oc, 1e-12);
}

// A blade advancing through the bunny's ears a few links per frame: each update keeps the
// material in place, the octree valid and gap-free, and the results equal for 1 and 2
// threads after every frame (this runs the refinement rounds for ambiguous hanging nodes).
TEST(CutTopology, BunnyBladeSequence) {
  VoxelizeParams vp;
  vp.resolution.resolution = 101;
  const VoxelGrid start = voxelize(loadModel("bunny").materials, vp);
  const Index3 d = start.dims();
  const auto frames = bladeFrames(start, static_cast<int>(0.8 * d.y), d.x / 8, d.x * 5 / 8,
                                  0.8 * d.z, 0.2 * d.z, 30);
  struct Run {
    VoxelGrid grid;
    DeformationOctree octree;
  };
  std::array<Run, 2> runs{Run{start, buildDeformationOctree(start)},
                          Run{start, buildDeformationOctree(start)}};
  for (Run& r : runs) shake(r.octree, 21);
  std::size_t links = 0, updates = 0;
  for (const auto& cut : frames) {
    if (cut.empty()) continue;
    std::array<TopologyChange, 2> tc;
    for (int t = 0; t < 2; ++t) {
      ThreadLimit limit(t + 1);
      Run& r = runs[static_cast<std::size_t>(t)];
      for (std::uint64_t id : cut) r.grid.setConnected(id / 3, static_cast<int>(id % 3), false);
      const std::vector<Vec3d> moved =
          t == 0 ? voxelPositions(r.grid, r.octree) : std::vector<Vec3d>{};
      tc[static_cast<std::size_t>(t)] = updateCutTopology(r.octree, r.grid, cut);
      if (t == 0) {
        const std::vector<Vec3d> after = voxelPositions(r.grid, r.octree);
        for (std::size_t v = 0; v < after.size(); ++v)
          ASSERT_LE((after[v] - moved[v]).norm(), 1e-12) << v;
      }
    }
    expectSame(runs[0].octree, runs[1].octree, tc[0], tc[1]);
    links += cut.size();
    ++updates;
  }
  ASSERT_GT(updates, 5u);
  ASSERT_GT(links, 30u);
  expectOctreeInvariants(runs[0].grid, runs[0].octree, 3, 0, false);
  DeformationOctree shaken = runs[0].octree;
  shake(shaken, 5);
  test::expectConforming(shaken, 1e-12);
  expectNoGap(runs[0].grid, shaken, 1e-12);
}

}  // namespace
}  // namespace voxcut
