#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include "CanonicalMesh.h"
#include "RandomGrids.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/surface/ContouredSurface.h"
#include "voxcut/surface/DualCell.h"
#include "voxcut/surface/DualContour.h"
#include "voxcut/voxel/BuiltinModels.h"
#include "voxcut/voxel/Pieces.h"
#include "voxcut/voxel/PlaneCut.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

using test::canonical;
using test::randomCutGrid;
using test::randomHermite;
using test::VertexKey;

// Connected links, sorted.
std::vector<std::uint64_t> connectedLinks(const VoxelGrid& g) {
  std::vector<std::uint64_t> out;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a)
      if (g.hasLink(v, a) && g.connected(v, a)) out.push_back(VoxelGrid::linkId(v, a));
  return out;
}

// Links whose state differs between two grids of the same dims.
std::vector<std::uint64_t> linkDiff(const VoxelGrid& before, const VoxelGrid& after) {
  std::vector<std::uint64_t> out;
  for (std::size_t v = 0; v < before.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a)
      if (before.hasLink(v, a) && before.connected(v, a) != after.connected(v, a))
        out.push_back(VoxelGrid::linkId(v, a));
  return out;
}

// Disconnects `links` of g, copying their Hermite data from `source`.
void applyCuts(VoxelGrid& g, const VoxelGrid& source, const std::vector<std::uint64_t>& links) {
  for (const std::uint64_t id : links) {
    g.setConnected(static_cast<std::size_t>(id / 3), static_cast<int>(id % 3), false);
    const Hermite* h = source.hermite().find(id);
    ASSERT_NE(h, nullptr);
    g.hermite().set(id, *h);
  }
}

// Vertex and triangle slots of a surface, to check a delta against.
struct Snapshot {
  std::vector<bool> alive;
  std::vector<Vec3d> positions;
  std::vector<std::uint64_t> voxels;
  std::vector<std::array<int, 3>> triangles;
};

Snapshot snapshot(const ContouredSurface& s) {
  Snapshot out;
  for (std::size_t v = 0; v < s.vertexSlots(); ++v)
    out.alive.push_back(s.alive(static_cast<std::int32_t>(v)));
  out.positions = s.positions();
  out.voxels = s.vertexVoxels();
  out.triangles = s.triangles();
  return out;
}

// The delta lists exactly the slots whose contents changed, and the surface equals a rebuild.
void expectExactUpdate(const Snapshot& before, const ContouredSurface& s, const SurfaceDelta& delta,
                       const VoxelGrid& g, const std::string& what) {
  ASSERT_TRUE(std::is_sorted(delta.removedVertices.begin(), delta.removedVertices.end())) << what;
  ASSERT_TRUE(std::is_sorted(delta.addedVertices.begin(), delta.addedVertices.end())) << what;
  const std::set<std::int32_t> removedV(delta.removedVertices.begin(), delta.removedVertices.end());
  const std::set<std::int32_t> addedV(delta.addedVertices.begin(), delta.addedVertices.end());
  ASSERT_EQ(removedV.size(), delta.removedVertices.size()) << what;
  ASSERT_EQ(addedV.size(), delta.addedVertices.size()) << what;
  for (std::size_t v = 0; v < s.vertexSlots(); ++v) {
    const auto id = static_cast<std::int32_t>(v);
    const bool was = v < before.alive.size() && before.alive[v];
    const bool is = s.alive(id);
    if (removedV.count(id)) {
      ASSERT_TRUE(was && !is && !addedV.count(id)) << what << " vertex " << v;
    } else if (addedV.count(id)) {
      ASSERT_TRUE(!was && is) << what << " vertex " << v;
    } else {
      ASSERT_EQ(was, is) << what << " vertex " << v;
      if (is) {
        ASSERT_EQ(before.positions[v], s.positions()[v]) << what;
        ASSERT_EQ(before.voxels[v], s.vertexVoxels()[v]) << what;
      }
    }
  }
  const std::set<std::int32_t> removedT(delta.removedTriangles.begin(),
                                        delta.removedTriangles.end());
  const std::set<std::int32_t> addedT(delta.addedTriangles.begin(), delta.addedTriangles.end());
  ASSERT_EQ(removedT.size(), delta.removedTriangles.size()) << what;
  for (std::size_t t = 0; t < s.triangles().size(); ++t) {
    const auto id = static_cast<std::int32_t>(t);
    const bool was = t < before.triangles.size() && before.triangles[t][0] >= 0;
    const bool is = s.triangles()[t][0] >= 0;
    if (removedT.count(id)) {
      ASSERT_TRUE(was && !is && !addedT.count(id)) << what << " triangle " << t;
    } else if (addedT.count(id)) {
      ASSERT_TRUE(!was && is) << what << " triangle " << t;
    } else {
      const std::array<int, 3> dead = {-1, -1, -1};
      ASSERT_EQ(was ? before.triangles[t] : dead, s.triangles()[t]) << what;
    }
    if (is) {
      for (int k = 0; k < 3; ++k) ASSERT_TRUE(s.alive(s.triangles()[t][k])) << what;
    }
  }
  // Nothing unchanged is churned: no removed vertex comes back as an added one.
  std::set<VertexKey> removedKeys;
  for (const std::int32_t v : delta.removedVertices) {
    const Vec3d& p = before.positions[static_cast<std::size_t>(v)];
    removedKeys.insert({p[0], p[1], p[2], before.voxels[static_cast<std::size_t>(v)]});
  }
  for (const std::int32_t v : delta.addedVertices) {
    const Vec3d& p = s.positions()[static_cast<std::size_t>(v)];
    ASSERT_FALSE(
        removedKeys.count({p[0], p[1], p[2], s.vertexVoxels()[static_cast<std::size_t>(v)]}))
        << what << " vertex " << v << " removed and added unchanged";
  }
  const SurfaceMesh m = s.mesh();
  ASSERT_EQ(m.positions.size(), s.vertexCount());
  ASSERT_EQ(m.triangles.size(), s.triangleCount());
  const SurfaceMesh full = dualContour(g);
  ASSERT_TRUE(canonical(m) == canonical(full)) << what;
  const SurfaceTopology t = surfaceTopology(m);
  ASSERT_TRUE(t.closed) << what;
  ASSERT_TRUE(t.manifold) << what;
}

// Patches of every cell, with its true neighbours; used to see the ring rule change a cell
// whose own links did not change.
std::map<std::size_t, std::pair<std::uint16_t, std::array<std::int8_t, 24>>> allPatches(
    const VoxelGrid& g) {
  std::map<std::size_t, std::pair<std::uint16_t, std::array<std::int8_t, 24>>> out;
  const Index3 d = g.dims();
  for (int z = 0; z + 1 < d.z; ++z)
    for (int y = 0; y + 1 < d.y; ++y)
      for (int x = 0; x + 1 < d.x; ++x) {
        const Index3 m{x, y, z};
        const DualCell cell = gatherDualCell(g, m);
        std::array<std::int8_t, 24> patch;
        dualCellPatches(cell, patch, gridNeighbour(g, m));
        out[g.index(m)] = {cell.connected, patch};
      }
  return out;
}

TEST(ContouredSurface, BuildEqualsDualContour) {
  for (unsigned seed = 1; seed <= 8; ++seed) {
    const VoxelGrid g = randomCutGrid(12, 0.3 + 0.05 * seed, (seed % 4) / 3.0, seed);
    const ContouredSurface s = ContouredSurface::build(g);
    const SurfaceMesh full = dualContour(g);
    const SurfaceMesh m = s.mesh();
    ASSERT_TRUE(canonical(m) == canonical(full)) << "seed " << seed;
    for (std::size_t v = 0; v < m.normals.size(); ++v) ASSERT_LE(m.normals[v].norm(), 1 + 1e-12);
  }
  VoxelizeParams p;
  p.resolution.resolution = 30;
  const VoxelGrid sphere = voxelize({{"s", makeSphere(0.05, 4)}}, p);
  const ContouredSurface s = ContouredSurface::build(sphere);
  EXPECT_TRUE(canonical(s.mesh()) == canonical(dualContour(sphere)));
  EXPECT_EQ(s.vertexCount(), dualContour(sphere).positions.size());
}

TEST(ContouredSurface, BuildDoesNotDependOnThreadCount) {
  const VoxelGrid g = randomCutGrid(20, 0.6, 0.7, 99);
  auto run = [&](int threads) {
    ThreadLimit limit(threads);
    return ContouredSurface::build(g);
  };
  const ContouredSurface a = run(1), b = run(2);
  const ContouredSurface c = ContouredSurface::build(g, {.qefThreshold = 0.1, .threaded = false});
  ASSERT_EQ(a.positions(), b.positions());
  ASSERT_EQ(a.triangles(), b.triangles());
  ASSERT_EQ(a.vertexVoxels(), b.vertexVoxels());
  ASSERT_EQ(a.positions(), c.positions());
  ASSERT_EQ(a.triangles(), c.triangles());
}

TEST(ContouredSurface, UpdateWithNothingChangedChangesNothing) {
  VoxelGrid g = randomCutGrid(10, 0.6, 0.6, 5);
  ContouredSurface s = ContouredSurface::build(g);
  const Snapshot before = snapshot(s);
  SurfaceDelta d = s.update(g, {});
  EXPECT_TRUE(d.removedVertices.empty() && d.addedVertices.empty() && d.removedTriangles.empty() &&
              d.addedTriangles.empty());
  // Listing links that did not change re-solves their cells and finds the same vertices.
  const std::vector<std::uint64_t> some = {VoxelGrid::linkId(g.index(4, 4, 4), 0),
                                           VoxelGrid::linkId(g.index(5, 3, 6), 2)};
  d = s.update(g, some);
  EXPECT_GT(d.solvedCells, 0u);
  EXPECT_TRUE(d.removedVertices.empty() && d.addedVertices.empty() && d.removedTriangles.empty() &&
              d.addedTriangles.empty());
  EXPECT_EQ(before.triangles, s.triangles());
}

// Random sequences of random cut sets on random grids: each update equals a rebuild, stays
// closed and manifold, and its delta is exact. The grids hold doubled segments (split
// vertices) and rings, and some updates change a cell only through the ring rule.
TEST(ContouredSurface, RandomCutSequencesEqualRebuilds) {
  std::size_t ringOnlyChanges = 0, splitPolygons = 0;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    std::mt19937 rng(seed * 7919);
    VoxelGrid g = randomCutGrid(12, 0.55 + 0.04 * (seed % 5), 0.5 + 0.1 * (seed % 5), seed);
    ContouredSurface s = ContouredSurface::build(g);
    for (int round = 0; round < 8; ++round) {
      std::vector<std::uint64_t> conn = connectedLinks(g);
      if (conn.empty()) break;
      std::shuffle(conn.begin(), conn.end(), rng);
      const std::size_t n = std::min(conn.size(), std::size_t{1} + rng() % (round % 2 ? 40 : 4));
      std::vector<std::uint64_t> cut(conn.begin(), conn.begin() + static_cast<std::ptrdiff_t>(n));
      const auto patchesBefore = allPatches(g);
      for (const std::uint64_t id : cut) {
        g.setConnected(static_cast<std::size_t>(id / 3), static_cast<int>(id % 3), false);
        g.hermite().set(id, randomHermite(static_cast<int>(id % 3), rng));
      }
      for (const auto& [cell, after] : allPatches(g)) {
        const auto& b = patchesBefore.at(cell);
        if (b.first == after.first && b.second != after.second) ++ringOnlyChanges;
      }
      if (round % 3 == 0) cut.push_back(cut.front());  // repeats are allowed
      const Snapshot before = snapshot(s);
      const SurfaceDelta d = s.update(g, cut);
      const std::string what = "seed " + std::to_string(seed) + " round " + std::to_string(round);
      expectExactUpdate(before, s, d, g, what);
      if (HasFatalFailure()) return;
      EXPECT_LE(d.solvedCells, 20 * cut.size());
    }
    // Polygons around split vertices: triangles beyond two per sheet.
    std::size_t sheets = 0;
    for (std::size_t v = 0; v < g.voxelCount(); ++v)
      for (int a = 0; a < 3; ++a)
        if (g.hasLink(v, a) && !g.connected(v, a))
          sheets += static_cast<std::size_t>(g.occupied(v)) + g.occupied(v + g.stride(a));
    splitPolygons += s.triangleCount() - 2 * sheets;
  }
  EXPECT_GT(ringOnlyChanges, 0u);
  EXPECT_GT(splitPolygons, 0u);
}

// Sealed links of a grid (cut links whose sheets would share every vertex), sorted.
std::vector<std::uint64_t> sealedLinks(const VoxelGrid& g) {
  std::vector<std::uint64_t> out;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a)
      if (isSealedLink(g, v, a)) out.push_back(VoxelGrid::linkId(v, a));
  return out;
}

// Cuts and reconnections inside mostly connected material, where many cut links are sealed
// and stop or start being sealed as links around them change: each update equals a rebuild.
TEST(ContouredSurface, SealedLinksComingAndGoingEqualRebuilds) {
  std::size_t sealedSeen = 0, gained = 0, lost = 0;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    std::mt19937 rng(seed * 104729);
    VoxelGrid g = randomCutGrid(12, 0.9, 0.97, seed);
    ContouredSurface s = ContouredSurface::build(g);
    for (int round = 0; round < 12; ++round) {
      const std::vector<std::uint64_t> sealedBefore = sealedLinks(g);
      std::vector<std::uint64_t> conn = connectedLinks(g), open;
      for (std::size_t v = 0; v < g.voxelCount(); ++v)
        for (int a = 0; a < 3; ++a)
          if (g.hasLink(v, a) && !g.connected(v, a) && g.occupied(v) && g.occupied(v + g.stride(a)))
            open.push_back(VoxelGrid::linkId(v, a));
      std::shuffle(conn.begin(), conn.end(), rng);
      std::shuffle(open.begin(), open.end(), rng);
      std::vector<std::uint64_t> changed;
      const std::size_t nCut = std::min<std::size_t>(conn.size(), 1 + rng() % 12);
      const std::size_t nJoin = std::min<std::size_t>(open.size(), rng() % 6);
      for (std::size_t i = 0; i < nCut; ++i) {
        g.setConnected(static_cast<std::size_t>(conn[i] / 3), static_cast<int>(conn[i] % 3), false);
        g.hermite().set(conn[i], randomHermite(static_cast<int>(conn[i] % 3), rng));
        changed.push_back(conn[i]);
      }
      for (std::size_t i = 0; i < nJoin; ++i) {
        g.setConnected(static_cast<std::size_t>(open[i] / 3), static_cast<int>(open[i] % 3), true);
        g.hermite().erase(open[i]);
        changed.push_back(open[i]);
      }
      const std::vector<std::uint64_t> sealedAfter = sealedLinks(g);
      sealedSeen += sealedAfter.size();
      for (const std::uint64_t id : sealedAfter)
        if (!std::binary_search(sealedBefore.begin(), sealedBefore.end(), id) &&
            !std::count(changed.begin(), changed.end(), id))
          ++gained;
      for (const std::uint64_t id : sealedBefore)
        if (!std::binary_search(sealedAfter.begin(), sealedAfter.end(), id) &&
            !std::count(changed.begin(), changed.end(), id))
          ++lost;
      const Snapshot before = snapshot(s);
      const SurfaceDelta d = s.update(g, changed);
      expectExactUpdate(before, s, d, g,
                        "seed " + std::to_string(seed) + " round " + std::to_string(round));
      if (HasFatalFailure()) return;
    }
  }
  // Sealed links abound, and links that did not change became sealed or stopped being so.
  EXPECT_GT(sealedSeen, 100u);
  EXPECT_GT(gained, 0u);
  EXPECT_GT(lost, 0u);
}

// Voxels emptied (their 6 links cut, listed) also update exactly.
TEST(ContouredSurface, EmptiedVoxelsEqualRebuilds) {
  std::mt19937 rng(11);
  VoxelGrid g = randomCutGrid(12, 0.7, 0.8, 11);
  ContouredSurface s = ContouredSurface::build(g);
  for (int round = 0; round < 5; ++round) {
    std::vector<std::uint64_t> changed;
    for (int k = 0; k < 6; ++k) {
      const std::size_t v =
          g.index(1 + static_cast<int>(rng() % 10), 1 + static_cast<int>(rng() % 10),
                  1 + static_cast<int>(rng() % 10));
      g.setMaterial(v, 0);
      for (int a = 0; a < 3; ++a)
        for (const std::size_t lo : {v, v - g.stride(a)}) {
          g.setConnected(lo, a, false);
          g.hermite().set(VoxelGrid::linkId(lo, a), randomHermite(a, rng));
          changed.push_back(VoxelGrid::linkId(lo, a));
        }
    }
    const Snapshot before = snapshot(s);
    const SurfaceDelta d = s.update(g, changed);
    expectExactUpdate(before, s, d, g, "round " + std::to_string(round));
    if (HasFatalFailure()) return;
  }
}

// A plane cut applied in batches in random order, until the model is in two pieces.
void cutInBatches(VoxelGrid g, const Plane& plane, std::size_t batch, unsigned seed) {
  VoxelGrid target = g;
  ASSERT_GT(cutWithPlane(target, plane), batch);
  std::vector<std::uint64_t> links = linkDiff(g, target);
  std::mt19937 rng(seed);
  std::shuffle(links.begin(), links.end(), rng);
  ContouredSurface s = ContouredSurface::build(g);
  const std::size_t batches = (links.size() + batch - 1) / batch;
  for (std::size_t b = 0; b < batches; ++b) {
    const auto first = links.begin() + static_cast<std::ptrdiff_t>(b * batch);
    const std::vector<std::uint64_t> cut(
        first, first + static_cast<std::ptrdiff_t>(std::min(batch, links.size() - b * batch)));
    applyCuts(g, target, cut);
    const Snapshot before = snapshot(s);
    const SurfaceDelta d = s.update(g, cut);
    // A rebuild to compare with for the first batches, every few batches and the last one.
    if (b < 3 || b % 4 == 0 || b + 1 == batches) {
      expectExactUpdate(before, s, d, g, "batch " + std::to_string(b));
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
  const SurfaceTopology t = surfaceTopology(s.mesh());
  EXPECT_TRUE(t.closed && t.manifold);
  EXPECT_GE(t.pieces, 2);
  EXPECT_EQ(t.pieces, findPieces(g).count);
  EXPECT_TRUE(canonical(s.mesh()) == canonical(dualContour(g)));
}

TEST(ContouredSurface, BoxAndSphereCutInTwoInBatches) {
  VoxelizeParams p;
  p.resolution.resolution = 24;
  cutInBatches(voxelize({{"b", makeBox(Vec3d(0.1, 0.06, 0.08))}}, p), {Vec3d(1, 0.3, 0.2), 0.004},
               25, 1);
  cutInBatches(voxelize({{"s", makeSphere(0.05, 4)}}, p), {Vec3d(0.2, 1, -0.4), -0.003}, 40, 2);
}

TEST(ContouredSurface, BunnyPlaneCutInBatches) {
  const Model bunny = loadModel("bunny");
  VoxelizeParams p;
  p.resolution.resolution = 50;
  const VoxelGrid g = voxelize(bunny.materials, p);
  const Vec3d centre = g.origin() + 0.5 * g.voxelSize() * Vec3d(g.dims().x, g.dims().y, g.dims().z);
  const Vec3d n(0.3, 1.0, 0.2);
  cutInBatches(g, {n, n.dot(centre)}, 150, 3);
}

}  // namespace
}  // namespace voxcut
