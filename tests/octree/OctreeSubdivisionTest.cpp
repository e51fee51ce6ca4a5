#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <random>

#include "ActiveTables.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/octree/OctreeSubdivision.h"
#include "voxcut/voxel/PlaneCut.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

VoxelGrid model(const char* name, int resolution) {
  VoxelizeParams p;
  p.resolution.resolution = resolution;
  return voxelize(loadModel(name).materials, p);
}

// The plane n.x = d as a "blade" on rest positions, decided like cutWithPlane.
std::optional<Hermite> planeTest(const VoxelGrid& g, const Vec3d& n, double d, std::size_t v,
                                 int a) {
  const double s0 = n.dot(g.position(v)) - d, s1 = n.dot(g.position(v + g.stride(a))) - d;
  if ((s0 < 0) == (s1 < 0)) return std::nullopt;
  Hermite h;
  h.t = std::clamp(static_cast<float>(s0 / (s0 - s1)), 1e-3f, 1.f - 1e-3f);
  const float sg = n[a] < 0 ? -1.f : 1.f;
  for (int i = 0; i < 3; ++i) h.n[i] = sg * static_cast<float>(n[i]);
  return h;
}

// Cuts with the octree: active links first, then subdivision; returns the stats. `asked`
// collects every link the subdivision handed to the link test; `openedOut`, if given, receives
// the origins of the level-1 cubes that were split.
SubdivisionStats cutWithOctree(VoxelGrid& g, VoxelOctree& oct, const Vec3d& n, double d,
                               std::vector<std::uint64_t>& asked,
                               std::vector<Index3>* openedOut = nullptr) {
  std::vector<LinkCut> cuts;
  for (std::uint32_t v : oct.activeVoxels)
    for (int a = 0; a < 3; ++a)
      if (oct.linkActive(v, a) && g.connected(v, a))
        if (const auto h = planeTest(g, n, d, v, a))
          cuts.push_back({VoxelGrid::linkId(v, a), *h, std::nullopt});
  for (const LinkCut& c : cuts) {
    g.setConnected(static_cast<std::size_t>(c.link / 3), static_cast<int>(c.link % 3), false);
    g.hermite().set(c.link, c.hermite);
  }
  SubdivisionHooks hooks;
  SubdivisionWorkspace workspace;
  std::mutex m;
  hooks.testLink = [&](std::size_t v, int a, VoxelPositionCache&) {
    EXPECT_LT(g.coord(v)[a] + 1, g.dims()[a]);
    const std::lock_guard<std::mutex> lock(m);
    asked.push_back(VoxelGrid::linkId(v, a));
    return planeTest(g, n, d, v, a);
  };
  const SubdivisionStats s = subdivideCutCubes(oct, g, cuts, hooks, workspace);
  // Split level-1 cubes are listed and opened with the frame activation: all 27 voxels and
  // 54 links active, their cells no longer covered (the last round leaves the cube map to
  // the frame activation).
  const std::vector<Index3> opened = oct.openedCubes;
  if (openedOut != nullptr) *openedOut = opened;
  activateNewCubeFrames(oct, g);
  EXPECT_TRUE(oct.openedCubes.empty());
  EXPECT_TRUE(oct.unmappedCubes.empty());
  for (const Index3& o : opened)
    for (int k = 0; k < 8; ++k)
      EXPECT_EQ(oct.cellCube[g.index(o.x + (k & 1), o.y + ((k >> 1) & 1), o.z + (k >> 2))], -1);
  for (const Index3& o : opened)
    for (int z = 0; z <= 2; ++z)
      for (int y = 0; y <= 2; ++y)
        for (int x = 0; x <= 2; ++x) {
          const std::size_t v = g.index(o.x + x, o.y + y, o.z + z);
          EXPECT_TRUE(oct.voxelActive(v)) << v;
          const int at[3] = {x, y, z};
          for (int a = 0; a < 3; ++a) {
            if (at[a] < 2) {
              EXPECT_TRUE(oct.linkActive(v, a)) << v;
            }
          }
        }
  compactCubes(oct);
  rebuildActiveVoxels(oct);
  return s;
}

void expectOctreeConsistent(const VoxelGrid& g, const VoxelOctree& oct) {
  std::vector<std::int32_t> cover(g.voxelCount(), -1);
  for (std::size_t c = 0; c < oct.cubes.size(); ++c) {
    const OctreeCube& cube = oct.cubes[c];
    ASSERT_FALSE(cube.deleted);
    const int s = 1 << cube.level;
    for (int z = 0; z <= s; ++z)
      for (int y = 0; y <= s; ++y)
        for (int x = 0; x <= s; ++x) {
          const Index3 p{cube.origin.x + x, cube.origin.y + y, cube.origin.z + z};
          const std::size_t v = g.index(p);
          const int d[3] = {x, y, z};
          for (int a = 0; a < 3; ++a) {
            // A surviving cube has no cut link, and its frame is active.
            if (d[a] < s) {
              ASSERT_TRUE(g.connected(v, a));
            }
            const int u = (a + 1) % 3, w = (a + 2) % 3;
            if (d[a] < s && (d[u] == 0 || d[u] == s) && (d[w] == 0 || d[w] == s)) {
              ASSERT_TRUE(oct.linkActive(v, a));
            }
          }
          if (x < s && y < s && z < s) {
            ASSERT_EQ(cover[v], -1);
            cover[v] = static_cast<std::int32_t>(c);
          }
        }
  }
  ASSERT_EQ(cover, oct.cellCube);
  // Every connected link not surrounded by cubes is active.
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    const Index3 c = g.coord(v);
    for (int a = 0; a < 3; ++a) {
      if (!g.connected(v, a)) continue;
      const int u = (a + 1) % 3, w = (a + 2) % 3;
      bool surrounded = true;
      for (int k = 0; k < 4; ++k) {
        Index3 cell = c;
        cell[u] -= k & 1;
        cell[w] -= k >> 1;
        surrounded = surrounded && cell[u] >= 0 && cell[w] >= 0 && oct.cellCube[g.index(cell)] >= 0;
      }
      if (!surrounded) {
        ASSERT_TRUE(oct.linkActive(v, a));
      }
    }
  }
}

TEST(OctreeSubdivision, PlanarCutsEqualTheBaselineLinkForLink) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (const char* name : {"bunny", "liver"}) {
    const VoxelGrid rest = model(name, 64);
    const Vec3d centre =
        rest.origin() +
        0.5 * rest.voxelSize() * Vec3d(rest.dims().x - 1, rest.dims().y - 1, rest.dims().z - 1);
    for (int trial = 0; trial < 4; ++trial) {
      const Vec3d n = Vec3d(U(rng), U(rng), U(rng)).normalized();
      const double d = n.dot(centre) + 0.2 * U(rng) * rest.voxelSize() * 10;
      VoxelGrid base = rest;
      cutWithPlane(base, {n, d});
      VoxelGrid g = rest;
      VoxelOctree oct = buildVoxelOctree(g, OctreeParams::uniform(g.materialNames().size(), 4, 0));
      const std::size_t before = oct.activeVoxels.size();
      std::vector<std::uint64_t> asked;
      std::vector<Index3> opened;
      const SubdivisionStats s = cutWithOctree(g, oct, n, d, asked, &opened);
      EXPECT_GT(s.rounds, 0);
      EXPECT_GT(opened.size(), 0u);
      EXPECT_GT(oct.activeVoxels.size(), before);
      for (std::size_t v = 0; v < g.voxelCount(); ++v)
        for (int a = 0; a < 3; ++a)
          ASSERT_EQ(g.connected(v, a), base.connected(v, a)) << name << " " << trial;
      ASSERT_EQ(g.hermite().sortedLinks(), base.hermite().sortedLinks());
      expectOctreeConsistent(g, oct);
      expectActiveTablesConsistent(g, oct);
      // A link is handed to the link test at most twice (a centre-line link lies in two
      // mid-planes), and far fewer links than the grid holds are asked about.
      std::sort(asked.begin(), asked.end());
      for (std::size_t i = 2; i < asked.size(); ++i)
        ASSERT_FALSE(asked[i] == asked[i - 2]) << asked[i];
      EXPECT_LT(asked.size(), g.voxelCount() / 4);
      EXPECT_GE(s.testedLinks, asked.size());
    }
  }
}

// A plane across the y axis crosses only links along y. In a level-1 cube it splits, the
// subdivision tests the centre links along y (both mid-planes holding them, across x and z,
// have cuts on their border) and not those along x or z (the mid-plane across y has none); the
// cuts still equal a test of every link.
TEST(OctreeSubdivision, LevelOneCubesTestOnlyTheCentreLinksACutCanCross) {
  const VoxelGrid rest = model("liver", 64);
  const double h = rest.voxelSize();
  for (const double offset : {12.37, 20.5, 27.81}) {
    const Vec3d n(0.0, 1.0, 0.0);
    const double d = rest.origin().y() + offset * h;
    VoxelGrid base = rest;
    cutWithPlane(base, {n, d});
    VoxelGrid g = rest;
    VoxelOctree oct = buildVoxelOctree(g, OctreeParams::uniform(g.materialNames().size(), 4, 0));
    std::vector<std::uint64_t> asked;
    std::vector<Index3> opened;
    cutWithOctree(g, oct, n, d, asked, &opened);
    ASSERT_FALSE(opened.empty());
    std::sort(asked.begin(), asked.end());
    const auto wasAsked = [&](const Index3& p, int a) {
      return std::binary_search(asked.begin(), asked.end(), VoxelGrid::linkId(g.index(p), a));
    };
    std::size_t alongY = 0;
    for (const Index3& o : opened) {
      const Index3 c{o.x + 1, o.y + 1, o.z + 1};
      for (int a = 0; a < 3; ++a) {
        Index3 below = c;
        --below[a];
        const bool centreAsked = wasAsked(below, a) || wasAsked(c, a);
        if (a != 1) {
          EXPECT_FALSE(centreAsked)
              << "offset " << offset << " cube " << o.x << "," << o.y << "," << o.z;
        } else {
          alongY += centreAsked ? 1 : 0;
        }
      }
    }
    EXPECT_GT(alongY, 0u);
    for (std::size_t v = 0; v < g.voxelCount(); ++v)
      for (int a = 0; a < 3; ++a) ASSERT_EQ(g.connected(v, a), base.connected(v, a)) << offset;
    ASSERT_EQ(g.hermite().sortedLinks(), base.hermite().sortedLinks());
  }
}

TEST(OctreeSubdivision, SameResultForAnyThreadCount) {
  const VoxelGrid rest = model("bunny", 64);
  const Vec3d n = Vec3d(0.3, 1.0, 0.2).normalized();
  const double d = n.dot(rest.origin() + rest.voxelSize() * Vec3d(32, 30, 25));
  VoxelGrid g1 = rest, g2 = rest;
  VoxelOctree o1 = buildVoxelOctree(g1, OctreeParams::uniform(1, 4, 0));
  VoxelOctree o2 = o1;
  std::vector<std::uint64_t> p1, p2;
  SubdivisionStats s1, s2;
  {
    ThreadLimit one(1);
    s1 = cutWithOctree(g1, o1, n, d, p1);
  }
  {
    ThreadLimit two(2);
    s2 = cutWithOctree(g2, o2, n, d, p2);
  }
  // The counts do not depend on the schedule either.
  EXPECT_EQ(s1.rounds, s2.rounds);
  EXPECT_EQ(s1.affectedCubes, s2.affectedCubes);
  EXPECT_EQ(s1.testedLinks, s2.testedLinks);
  EXPECT_EQ(s1.cutLinks, s2.cutLinks);
  ASSERT_EQ(o1.cubes.size(), o2.cubes.size());
  for (std::size_t c = 0; c < o1.cubes.size(); ++c) {
    ASSERT_EQ(o1.cubes[c].origin, o2.cubes[c].origin);
    ASSERT_EQ(o1.cubes[c].level, o2.cubes[c].level);
  }
  ASSERT_EQ(o1.state, o2.state);
  ASSERT_EQ(g1.hermite().sortedLinks(), g2.hermite().sortedLinks());
  ASSERT_EQ(o1.activeNext, o2.activeNext);
}

TEST(OctreeSubdivision, IncrementalActiveTablesEqualAFullRebuild) {
  // Two cuts in a row: each rebuild after the first starts from the tables of the one before.
  VoxelGrid g = model("liver", 64);
  VoxelOctree oct = buildVoxelOctree(g, OctreeParams::uniform(g.materialNames().size(), 4, 0));
  const Vec3d centre =
      g.origin() + 0.5 * g.voxelSize() * Vec3d(g.dims().x - 1, g.dims().y - 1, g.dims().z - 1);
  std::vector<std::uint64_t> asked;
  for (const Vec3d& n : {Vec3d(1.0, 0.2, 0.1).normalized(), Vec3d(0.1, 0.3, 1.0).normalized()}) {
    const std::size_t before = oct.activeVoxels.size();
    cutWithOctree(g, oct, n, n.dot(centre), asked);
    EXPECT_GT(oct.activeVoxels.size(), before);
    expectActiveTablesConsistent(g, oct);
    VoxelOctree full = oct;
    full.activeIndex.clear();  // forces the rebuild from a scan of the grid
    rebuildActiveVoxels(full);
    EXPECT_EQ(full.activeVoxels, oct.activeVoxels);
    EXPECT_EQ(full.activeNext, oct.activeNext);
    EXPECT_EQ(full.activeIndex, oct.activeIndex);
    EXPECT_EQ(full.state, oct.state);
  }
}

// A blade that starts and ends inside one cube: its sweep, a small rectangle, crosses links of
// the cube but none of its active frame links, so no cut leads the subdivision there. Given
// the sweep's boundary (points along the rectangle's edges and the cubes around them), the
// subdivision finds exactly the links a test of every link finds; without it, none. A
// rectangle that crosses no link leaves every cube as it was.
TEST(OctreeSubdivision, SweepInsideACubeIsFoundFromItsBoundary) {
  const VoxelGrid rest = model("bunny", 64);
  const VoxelOctree built = buildVoxelOctree(rest, OctreeParams::uniform(1, 4, 0));
  // The largest cube, and a rectangle around a point near its centre (voxel coordinates).
  std::size_t big = 0;
  for (std::size_t c = 0; c < built.cubes.size(); ++c)
    if (built.cubes[c].level > built.cubes[big].level) big = c;
  const OctreeCube& cube = built.cubes[big];
  const double size = 1 << cube.level;
  ASSERT_GE(cube.level, 3);
  const Vec3d n = Vec3d(0.3, 1.0, 0.45).normalized();
  const Vec3d u = n.cross(Vec3d::UnitX()).normalized(), w = n.cross(u);
  struct Rectangle {
    Vec3d c;
    double half;
  };
  const auto voxelCoords = [&](std::size_t v) {
    const Index3 p = rest.coord(v);
    return Vec3d(p.x, p.y, p.z);
  };
  const auto crossing = [&](const Rectangle& r, std::size_t v, int a) -> std::optional<Hermite> {
    const Vec3d p0 = voxelCoords(v), p1 = voxelCoords(v + rest.stride(a));
    const double s0 = n.dot(p0 - r.c), s1 = n.dot(p1 - r.c);
    if ((s0 < 0) == (s1 < 0)) return std::nullopt;
    const double t = s0 / (s0 - s1);
    const Vec3d x = p0 + t * (p1 - p0) - r.c;
    if (std::abs(u.dot(x)) > r.half || std::abs(w.dot(x)) > r.half) return std::nullopt;
    Hermite h;
    h.t = std::clamp(static_cast<float>(t), 1e-3f, 1.f - 1e-3f);
    for (int i = 0; i < 3; ++i) h.n[i] = static_cast<float>(n[a] < 0 ? -n[i] : n[i]);
    return h;
  };
  const auto boundaryOf = [&](const Rectangle& r, const VoxelOctree& oct) {
    SweepBoundary b;
    const Vec3d corner[4] = {r.c + r.half * (u + w), r.c + r.half * (u - w), r.c - r.half * (u + w),
                             r.c - r.half * (u - w)};
    std::vector<std::uint8_t> listed(oct.cubes.size(), 0);
    for (int e = 0; e < 4; ++e)
      for (int k = 0; k <= 40; ++k) {
        const Vec3d q = corner[e] + (k / 40.0) * (corner[(e + 1) % 4] - corner[e]);
        b.points.push_back(q);
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const std::int32_t id =
                  oct.cellCube[rest.index(static_cast<int>(std::floor(q.x())) + dx,
                                          static_cast<int>(std::floor(q.y())) + dy,
                                          static_cast<int>(std::floor(q.z())) + dz)];
              if (id >= 0 && !listed[static_cast<std::size_t>(id)]) {
                listed[static_cast<std::size_t>(id)] = 1;
                b.cubes.push_back(static_cast<std::uint32_t>(id));
              }
            }
      }
    std::sort(b.cubes.begin(), b.cubes.end());
    return b;
  };
  // Cuts with the octree as a cut step would: the active links, then the subdivision.
  const auto cut = [&](const Rectangle& r, VoxelGrid& g, VoxelOctree& oct, const SweepBoundary& b) {
    std::vector<LinkCut> cuts;
    for (std::uint32_t v : oct.activeVoxels)
      for (int a = 0; a < 3; ++a)
        if (oct.linkActive(v, a) && g.connected(v, a))
          if (const auto h = crossing(r, v, a))
            cuts.push_back({VoxelGrid::linkId(v, a), *h, std::nullopt});
    for (const LinkCut& c : cuts)
      g.setConnected(static_cast<std::size_t>(c.link / 3), static_cast<int>(c.link % 3), false);
    SubdivisionHooks hooks;
    SubdivisionWorkspace workspace;
    hooks.testLink = [&](std::size_t v, int a, VoxelPositionCache&) { return crossing(r, v, a); };
    const SubdivisionStats s = subdivideCutCubes(oct, g, cuts, hooks, workspace, true, b);
    activateNewCubeFrames(oct, g);
    compactCubes(oct);
    rebuildActiveVoxels(oct);
    std::vector<std::uint64_t> ids;
    for (const LinkCut& c : cuts) ids.push_back(c.link);
    std::sort(ids.begin(), ids.end());
    return std::make_pair(ids, s);
  };
  const Vec3d centre =
      Vec3d(cube.origin.x, cube.origin.y, cube.origin.z) + Vec3d::Constant(0.5 * size);
  const Rectangle r{centre + Vec3d(0.23, -0.41, 0.17), 0.3 * size};
  std::vector<std::uint64_t> expected;
  for (std::size_t v = 0; v < rest.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a)
      if (rest.occupied(v) && rest.hasLink(v, a) && rest.connected(v, a) && crossing(r, v, a))
        expected.push_back(VoxelGrid::linkId(v, a));
  ASSERT_GT(expected.size(), 10u);
  {
    VoxelGrid g = rest;
    VoxelOctree oct = built;
    const auto [ids, s] = cut(r, g, oct, boundaryOf(r, oct));
    EXPECT_EQ(ids, expected);
    EXPECT_GT(s.boundaryCubes, 0u);
    expectOctreeConsistent(g, oct);
    expectActiveTablesConsistent(g, oct);
  }
  {
    VoxelGrid g = rest;
    VoxelOctree oct = built;
    EXPECT_TRUE(cut(r, g, oct, {}).first.empty()) << "the frame alone should not lead there";
  }
  {
    // Half a voxel across, around the centre of a unit cell: it crosses no link.
    const Rectangle tiny{
        Vec3d(std::floor(r.c.x()) + 0.5, std::floor(r.c.y()) + 0.5, std::floor(r.c.z()) + 0.5),
        0.25};
    VoxelGrid g = rest;
    VoxelOctree oct = built;
    const auto before = oct.cubesPerLevel();
    const auto [ids, s] = cut(tiny, g, oct, boundaryOf(tiny, oct));
    EXPECT_TRUE(ids.empty());
    EXPECT_GT(s.testedLinks, 0u);
    EXPECT_EQ(oct.cubesPerLevel(), before);
  }
}

// A cut on a face that borders a cube outside the round starts the next round. Here the
// sweep's boundary reaches into cube A only (SweepBoundary: one point on its +x face), and a
// plane crosses that face: the seeded trace cuts links on the face A shares with cube B, which
// has no cut around it and is not listed, so B is split in a second round. The first round
// writes the cube map at once (the second round's marking reads it), the last leaves it to the
// frame activation; the octree is consistent after the deferred updates either way.
TEST(OctreeSubdivision, ACutOnAFaceOfACubeOutsideTheRoundStartsTheNext) {
  VoxelGrid g = model("bunny", 64);
  VoxelOctree oct = buildVoxelOctree(g, OctreeParams::uniform(g.materialNames().size(), 4, 0));
  // A: a cube of level >= 2 with a cube B of its level or above over the cell across its +x
  // face, at the face's centre.
  std::uint32_t a = 0;
  bool found = false;
  for (std::uint32_t c = 0; c < oct.cubes.size() && !found; ++c) {
    const OctreeCube& cube = oct.cubes[c];
    const int s = 1 << cube.level;
    if (cube.level < 2 || cube.origin.x + s + 1 >= g.dims().x) continue;
    const std::int32_t other =
        oct.cellCube[g.index(cube.origin.x + s, cube.origin.y + s / 2, cube.origin.z + s / 2)];
    if (other < 0 || oct.cubes[static_cast<std::size_t>(other)].level < cube.level) continue;
    a = c;
    found = true;
  }
  ASSERT_TRUE(found);
  const OctreeCube A = oct.cubes[a];
  const int s = 1 << A.level;
  const int yc = A.origin.y + s / 2;
  // The plane y = yc + 1/2 (in voxels) crosses every link along y from row yc.
  const Vec3d n(0, 1, 0);
  const double d = g.position(g.index(A.origin.x, yc, A.origin.z)).y() + 0.5 * g.voxelSize();
  SweepBoundary boundary;
  boundary.cubes = {a};
  boundary.points = {Vec3d(A.origin.x + s, yc + 0.5, A.origin.z + s / 2 + 0.25)};
  SubdivisionHooks hooks;
  SubdivisionWorkspace workspace;
  hooks.testLink = [&](std::size_t v, int ax, VoxelPositionCache&) {
    return planeTest(g, n, d, v, ax);
  };
  std::vector<LinkCut> cuts;
  const SubdivisionStats st = subdivideCutCubes(oct, g, cuts, hooks, workspace, true, boundary);
  // A, then B alone: around the cuts on their shared face, A's side holds no cube after the
  // first round (level-1 cubes opened, or none), which the second round's marking reads from
  // the cube map.
  EXPECT_EQ(st.rounds, 2u);
  EXPECT_EQ(st.affectedCubes, 2u);
  EXPECT_FALSE(oct.unmappedCubes.empty());  // B's sub-cubes, mapped by the frame activation
  for (const LinkCut& c : cuts) {
    ASSERT_FALSE(g.connected(static_cast<std::size_t>(c.link / 3), static_cast<int>(c.link % 3)));
    ASSERT_NE(g.hermite().find(c.link), nullptr);
  }
  activateNewCubeFrames(oct, g);
  EXPECT_TRUE(oct.unmappedCubes.empty());
  compactCubes(oct);
  rebuildActiveVoxels(oct);
  expectOctreeConsistent(g, oct);
  expectActiveTablesConsistent(g, oct);
}

// Given cuts whose Hermite data the subdivision is to set (givenStored false) get it even when
// no cube lies around them and no round runs.
TEST(OctreeSubdivision, GivenCutsGetTheirDataWithoutARound) {
  VoxelGrid g = model("bunny", 48);
  VoxelOctree oct = buildVoxelOctree(g, OctreeParams::uniform(1, 3, 0));
  std::vector<LinkCut> cuts;
  for (std::uint32_t v : oct.activeVoxels) {
    for (int a = 0; a < 3 && cuts.empty(); ++a) {
      if (!oct.linkActive(v, a) || !g.connected(v, a) || g.hermite().find(VoxelGrid::linkId(v, a)))
        continue;
      int cubes = 0;
      forEachCellAroundLink(g.dims(), g.coord(v), a,
                            [&](const Index3& c) { cubes += oct.cellCube[g.index(c)] >= 0; });
      if (cubes == 0)
        cuts.push_back({VoxelGrid::linkId(v, a), Hermite{0.25f, {1.f, 0.f, 0.f}}, std::nullopt});
    }
    if (!cuts.empty()) break;
  }
  ASSERT_EQ(cuts.size(), 1u);
  g.setConnected(static_cast<std::size_t>(cuts[0].link / 3), static_cast<int>(cuts[0].link % 3),
                 false);
  SubdivisionHooks hooks;
  SubdivisionWorkspace workspace;
  hooks.testLink = [](std::size_t, int, VoxelPositionCache&) -> std::optional<Hermite> {
    ADD_FAILURE();
    return std::nullopt;
  };
  const SubdivisionStats s = subdivideCutCubes(oct, g, cuts, hooks, workspace, true, {}, false);
  EXPECT_EQ(s.rounds, 0);
  const Hermite* h = g.hermite().find(cuts[0].link);
  ASSERT_NE(h, nullptr);
  EXPECT_EQ(h->t, 0.25f);
  EXPECT_FALSE(cuts[0].previous.has_value());
}

TEST(OctreeSubdivision, NothingHappensWithoutCuts) {
  VoxelGrid g = model("bunny", 48);
  VoxelOctree oct = buildVoxelOctree(g, OctreeParams::uniform(1, 3, 0));
  const auto before = oct.cubesPerLevel();
  std::vector<LinkCut> cuts;
  SubdivisionHooks hooks;
  SubdivisionWorkspace workspace;
  hooks.testLink = [](std::size_t, int, VoxelPositionCache&) -> std::optional<Hermite> {
    ADD_FAILURE();
    return std::nullopt;
  };
  const SubdivisionStats s = subdivideCutCubes(oct, g, cuts, hooks, workspace);
  EXPECT_EQ(s.rounds, 0);
  EXPECT_EQ(oct.cubesPerLevel(), before);
}

}  // namespace
}  // namespace voxcut
