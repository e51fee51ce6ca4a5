#include "voxcut/octree/OctreeSubdivision.h"

#include <algorithm>
#include <atomic>

#include "voxcut/core/Parallel.h"

namespace voxcut {
namespace {

// Link bits are shared by neighbouring cubes' tasks (one byte holds a voxel's three links), so
// in this phase every access goes through atomics.
bool linkConnected(const VoxelGrid& grid, std::size_t v, int a) {
  auto* bytes = const_cast<VoxelGrid&>(grid).linkData();
  return (std::atomic_ref<std::uint8_t>(bytes[v]).load(std::memory_order_relaxed) >> a) & 1u;
}
void disconnect(VoxelGrid& grid, std::size_t v, int a) {
  std::atomic_ref<std::uint8_t>(grid.linkData()[v])
      .fetch_and(static_cast<std::uint8_t>(~(1u << a)), std::memory_order_relaxed);
}
void orState(VoxelOctree& oct, std::size_t v, std::uint8_t bits) {
  std::atomic_ref<std::uint8_t>(oct.state[v]).fetch_or(bits, std::memory_order_relaxed);
}

struct CubeBox {
  Index3 o;
  int level;
  [[nodiscard]] int size() const { return 1 << level; }
};

// Calls fn(p) for every voxel of face f (0..5: axis f/2, side f%2) of the cube.
template <class Fn>
void forEachVoxelOfFace(const CubeBox& c, int f, Fn&& fn) {
  const int s = c.size(), ax = f / 2, u = (ax + 1) % 3, w = (ax + 2) % 3;
  for (int j = 0; j <= s; ++j)
    for (int i = 0; i <= s; ++i) {
      Index3 p = c.o;
      p[ax] += (f & 1) * s;
      p[u] += i;
      p[w] += j;
      fn(p);
    }
}

// Calls fn(p, a) for every link of face f of the cube; with `borderOnly`, only the links on
// the face's four edges.
template <class Fn>
void forEachLinkOfFace(const CubeBox& c, int f, bool borderOnly, Fn&& fn) {
  const int s = c.size(), ax = f / 2;
  for (int k = 1; k <= 2; ++k) {
    const int a = (ax + k) % 3, other = (ax + 3 - k) % 3;
    for (int j = 0; j <= s; j += (borderOnly ? s : 1))
      for (int i = 0; i < s; ++i) {
        Index3 p = c.o;
        p[ax] += (f & 1) * s;
        p[a] += i;
        p[other] += j;
        fn(p, a);
      }
  }
}

// Calls fn(p, a) for every link on the cube's faces (links on edges come twice).
template <class Fn>
void forEachFaceLink(const CubeBox& c, Fn&& fn) {
  for (int f = 0; f < 6; ++f) forEachLinkOfFace(c, f, false, fn);
}

// Whether link (p, a) lies on the boundary (a face) of cube c.
bool linkOnBoundary(const CubeBox& c, const Index3& p, int a) {
  const int s = c.size();
  bool face = false;
  for (int f = 0; f < 3; ++f) {
    if (p[f] < c.o[f] || p[f] > c.o[f] + s) return false;
    if (f == a) {
      if (p[f] + 1 > c.o[f] + s) return false;
    } else {
      face = face || p[f] == c.o[f] || p[f] == c.o[f] + s;
    }
  }
  return face;
}

// Result of splitting one affected cube.
struct SplitResult {
  std::vector<CubeBox> leaves;  // remaining sub-cubes, in depth-first order
  std::vector<LinkCut> cuts;
  std::size_t tested = 0, positioned = 0;
};

struct CutLink {
  Index3 p;
  int a;
};

// Tests link (p, a) against the blade; a crossed link is disconnected and recorded.
void testBetween(const Index3& p, int a, VoxelGrid& grid, const SubdivisionHooks& hooks,
                 SplitResult& out, std::vector<CutLink>& cuts) {
  const std::size_t v = grid.index(p);
  if (!linkConnected(grid, v, a)) return;
  ++out.tested;
  if (const auto hit = hooks.testLink(v, a)) {
    disconnect(grid, v, a);
    out.cuts.push_back({VoxelGrid::linkId(v, a), *hit});
    cuts.push_back({p, a});
  }
}

// Sub-steps (5-1)-(5-6) on one cube; `boundaryCuts` are the disconnected links on its faces.
//
// The voxels and links between the sub-cubes lie on the three mid-planes. They are taken in
// two stages: first the three centre lines where the mid-planes meet; then each of the 12
// quarter faces the centre lines cut the mid-planes into (a face of a sub-cube), but only if
// a link on its border is cut. As for the faces of the affected cubes, a blade that crosses a
// quarter face crosses its border, so the quarters it misses hold no cut.
void splitCube(const CubeBox& cube, const std::vector<CutLink>& boundaryCuts, VoxelOctree& oct,
               VoxelGrid& grid, const SubdivisionHooks& hooks, SplitResult& out) {
  const int s = cube.size(), h = s / 2;
  std::vector<CutLink> cuts = boundaryCuts;
  std::vector<std::uint32_t> voxels;
  auto at = [&](int x, int y, int z) {
    return static_cast<std::uint32_t>(grid.index(cube.o.x + x, cube.o.y + y, cube.o.z + z));
  };
  // (5-1), (5-2) on the centre lines (their ends lie on the faces).
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k <= s; ++k) {
      if (a > 0 && k == h) continue;  // the centre voxel once
      Index3 d{h, h, h};
      d[a] = k;
      voxels.push_back(at(d.x, d.y, d.z));
    }
  hooks.updatePositions(voxels);
  out.positioned += voxels.size();
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < s; ++k) {
      Index3 p{cube.o.x + h, cube.o.y + h, cube.o.z + h};
      p[a] = cube.o[a] + k;
      testBetween(p, a, grid, hooks, out, cuts);
    }
  // (5-1), (5-2) on the quarter faces whose border holds a cut.
  for (int f = 0; f < 3; ++f) {
    const int u = (f + 1) % 3, w = (f + 2) % 3;
    for (int q = 0; q < 4; ++q) {
      const int u0 = (q & 1) * h, w0 = (q >> 1) * h;
      auto point = [&](int i, int j) {
        Index3 p = cube.o;
        p[f] += h;
        p[u] += u0 + i;
        p[w] += w0 + j;
        return p;
      };
      bool crossed = false;
      for (int i = 0; i < h && !crossed; ++i)
        crossed = !linkConnected(grid, grid.index(point(i, 0)), u) ||
                  !linkConnected(grid, grid.index(point(i, h)), u) ||
                  !linkConnected(grid, grid.index(point(0, i)), w) ||
                  !linkConnected(grid, grid.index(point(h, i)), w);
      if (!crossed) continue;
      // Its voxels off the centre lines (those on the cube's faces included: a face without a
      // crossing was not positioned), then its inner links.
      voxels.clear();
      for (int j = 0; j <= h; ++j)
        for (int i = 0; i <= h; ++i) {
          if (u0 + i == h || w0 + j == h) continue;
          voxels.push_back(static_cast<std::uint32_t>(grid.index(point(i, j))));
        }
      hooks.updatePositions(voxels);
      out.positioned += voxels.size();
      for (int j = 1; j < h; ++j)
        for (int i = 0; i < h; ++i) {
          testBetween(point(i, j), u, grid, hooks, out, cuts);
          testBetween(point(j, i), w, grid, hooks, out, cuts);
        }
    }
  }
  // (5-3) a level-1 cube opens up completely.
  if (cube.level == 1) {
    for (int z = 0; z <= s; ++z)
      for (int y = 0; y <= s; ++y)
        for (int x = 0; x <= s; ++x) {
          const int d[3] = {x, y, z};
          std::uint8_t bits = kActiveVoxel;
          for (int a = 0; a < 3; ++a)
            if (d[a] < s) bits = static_cast<std::uint8_t>(bits | (1u << a));
          orState(oct, grid.index(cube.o.x + x, cube.o.y + y, cube.o.z + z), bits);
        }
    return;
  }
  // (5-4) eight sub-cubes; (5-5) split those with a disconnected link on their boundary: the
  // cube had none inside before this frame, so they are among `cuts`; (5-6).
  std::vector<CutLink> sub;
  for (int k = 0; k < 8; ++k) {
    const CubeBox child{{cube.o.x + (k & 1) * h, cube.o.y + ((k >> 1) & 1) * h, cube.o.z + (k >> 2) * h},
                        cube.level - 1};
    sub.clear();
    for (const CutLink& c : cuts)
      if (linkOnBoundary(child, c.p, c.a)) sub.push_back(c);
    if (sub.empty())
      out.leaves.push_back(child);
    else
      splitCube(child, sub, oct, grid, hooks, out);
  }
}

}  // namespace

SubdivisionStats subdivideCutCubes(VoxelOctree& oct, VoxelGrid& grid, std::vector<LinkCut>& cuts,
                                   const SubdivisionHooks& hooks, bool threaded) {
  SubdivisionStats stats;
  const Index3 d = grid.dims();
  std::vector<std::uint64_t> pending;
  for (const LinkCut& c : cuts) pending.push_back(c.link);
  std::vector<std::uint8_t> affected(oct.cubes.size(), 0);
  while (!pending.empty()) {
    // (1) cubes around the newly cut links.
    affected.assign(oct.cubes.size(), 0);
    parallelFor(0, pending.size(), 256, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const std::size_t v = static_cast<std::size_t>(pending[i] / 3);
        const int a = static_cast<int>(pending[i] % 3);
        const Index3 c = grid.coord(v);
        const int u = (a + 1) % 3, w = (a + 2) % 3;
        for (int k = 0; k < 4; ++k) {
          Index3 cell = c;
          cell[u] -= k & 1;
          cell[w] -= k >> 1;
          if (cell[u] < 0 || cell[w] < 0 || cell[u] + 1 >= d[u] || cell[w] + 1 >= d[w]) continue;
          const std::int32_t cube = oct.cellCube[grid.index(cell)];
          if (cube >= 0) std::atomic_ref<std::uint8_t>(affected[static_cast<std::size_t>(cube)]).store(1, std::memory_order_relaxed);
        }
      }
    }, threaded);
    std::vector<std::uint32_t> list;
    for (std::size_t c = 0; c < affected.size(); ++c)
      if (affected[c]) list.push_back(static_cast<std::uint32_t>(c));
    if (list.empty()) break;
    ++stats.rounds;
    stats.affectedCubes += list.size();

    // (2) the boundaries of the affected cubes. A blade that crosses a face crosses links on
    // its border (a cube's frame, or lines of a split cube's mid-planes, all tested already),
    // so only faces with a cut on their border hold work: their voxels and links.
    // (3) positions of their inactive voxels (active ones were positioned for the main test);
    // a voxel on a face shared by two cubes is positioned by both, to the same value.
    std::vector<std::vector<std::uint64_t>> faceLinks(list.size());
    std::vector<std::size_t> positioned(list.size(), 0);
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      std::vector<std::uint32_t> voxels;
      for (std::size_t i = b; i < e; ++i) {
        const OctreeCube& oc = oct.cubes[list[i]];
        const CubeBox cube{oc.origin, oc.level};
        voxels.clear();
        for (int f = 0; f < 6; ++f) {
          bool crossed = false;
          forEachLinkOfFace(cube, f, true, [&](const Index3& p, int a) {
            crossed = crossed || !linkConnected(grid, grid.index(p), a);
          });
          if (!crossed) continue;
          forEachVoxelOfFace(cube, f, [&](const Index3& p) {
            const std::size_t v = grid.index(p);
            if (!oct.voxelActive(v)) voxels.push_back(static_cast<std::uint32_t>(v));
          });
          forEachLinkOfFace(cube, f, false, [&](const Index3& p, int a) {
            const std::size_t v = grid.index(p);
            if (!oct.linkActive(v, a) && linkConnected(grid, v, a)) faceLinks[i].push_back(VoxelGrid::linkId(v, a));
          });
        }
        if (!voxels.empty()) hooks.updatePositions(voxels);
        positioned[i] = voxels.size();
      }
    }, threaded);

    // (4) those links against the blade (a link on a shared face may be tested twice).
    std::vector<std::vector<LinkCut>> found(list.size());
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i)
        for (std::uint64_t link : faceLinks[i])
          if (const auto h = hooks.testLink(static_cast<std::size_t>(link / 3), static_cast<int>(link % 3)))
            found[i].push_back({link, *h});
    }, threaded);
    std::vector<LinkCut> roundCuts;
    for (std::size_t i = 0; i < list.size(); ++i) {
      stats.testedLinks += faceLinks[i].size();
      stats.positionedVoxels += positioned[i];
      roundCuts.insert(roundCuts.end(), found[i].begin(), found[i].end());
    }
    std::sort(roundCuts.begin(), roundCuts.end(), [](const LinkCut& x, const LinkCut& y) { return x.link < y.link; });
    roundCuts.erase(std::unique(roundCuts.begin(), roundCuts.end(),
                                [](const LinkCut& x, const LinkCut& y) { return x.link == y.link; }),
                    roundCuts.end());
    for (const LinkCut& lc : roundCuts) grid.setConnected(static_cast<std::size_t>(lc.link / 3), static_cast<int>(lc.link % 3), false);

    // (5) split every affected cube, in parallel: their insides are disjoint.
    std::vector<SplitResult> results(list.size());
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const OctreeCube& oc = oct.cubes[list[i]];
        const CubeBox cube{oc.origin, oc.level};
        std::vector<CutLink> boundaryCuts;
        forEachFaceLink(cube, [&](const Index3& p, int a) {
          if (!linkConnected(grid, grid.index(p), a)) boundaryCuts.push_back({p, a});
        });
        splitCube(cube, boundaryCuts, oct, grid, hooks, results[i]);
      }
    }, threaded);

    // Store the sub-cubes: the first takes the split cube's slot, the others are appended.
    for (std::size_t i = 0; i < list.size(); ++i) {
      SplitResult& r = results[i];
      stats.testedLinks += r.tested;
      stats.positionedVoxels += r.positioned;
      roundCuts.insert(roundCuts.end(), r.cuts.begin(), r.cuts.end());
      const std::uint32_t id = list[i];
      const OctreeCube old = oct.cubes[id];
      const int s = 1 << old.level;
      for (int z = 0; z < s; ++z)
        for (int y = 0; y < s; ++y)
          for (int x = 0; x < s; ++x) oct.cellCube[grid.index(old.origin.x + x, old.origin.y + y, old.origin.z + z)] = -1;
      if (r.leaves.empty()) {
        oct.cubes[id].deleted = true;
        continue;
      }
      for (std::size_t k = 0; k < r.leaves.size(); ++k) {
        const OctreeCube sub{r.leaves[k].o, static_cast<std::uint8_t>(r.leaves[k].level), false};
        std::uint32_t slot = id;
        if (k == 0) {
          oct.cubes[id] = sub;
        } else {
          slot = static_cast<std::uint32_t>(oct.cubes.size());
          oct.cubes.push_back(sub);
        }
        oct.newCubes.push_back(slot);
        const int ss = 1 << sub.level;
        for (int z = 0; z < ss; ++z)
          for (int y = 0; y < ss; ++y)
            for (int x = 0; x < ss; ++x)
              oct.cellCube[grid.index(sub.origin.x + x, sub.origin.y + y, sub.origin.z + z)] = static_cast<std::int32_t>(slot);
      }
    }
    // Hermite data of this round's cuts; they are next round's newly cut links (6).
    pending.clear();
    for (const LinkCut& lc : roundCuts) {
      grid.hermite().set(lc.link, lc.hermite);
      pending.push_back(lc.link);
    }
    stats.cutLinks += roundCuts.size();
    cuts.insert(cuts.end(), roundCuts.begin(), roundCuts.end());
  }
  return stats;
}

}  // namespace voxcut
