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
  [[nodiscard]] bool onFace(const Index3& p, int f) const { return p[f] == o[f] || p[f] == o[f] + size(); }
  [[nodiscard]] bool strictlyInside(const Index3& p, int f) const { return p[f] > o[f] && p[f] < o[f] + size(); }
};

// Calls fn(p) for every voxel of the cube.
template <class Fn>
void forEachVoxel(const CubeBox& c, Fn&& fn) {
  const int s = c.size();
  for (int z = 0; z <= s; ++z)
    for (int y = 0; y <= s; ++y)
      for (int x = 0; x <= s; ++x) fn(Index3{c.o.x + x, c.o.y + y, c.o.z + z});
}

// Calls fn(p, a) for every link of the cube (both ends in the cube).
template <class Fn>
void forEachLink(const CubeBox& c, Fn&& fn) {
  forEachVoxel(c, [&](const Index3& p) {
    for (int a = 0; a < 3; ++a)
      if (p[a] < c.o[a] + c.size()) fn(p, a);
  });
}

bool linkOnFace(const CubeBox& c, const Index3& p, int a) {
  for (int f = 0; f < 3; ++f)
    if (f != a && c.onFace(p, f)) return true;
  return false;
}
bool voxelOnFace(const CubeBox& c, const Index3& p) {
  return c.onFace(p, 0) || c.onFace(p, 1) || c.onFace(p, 2);
}
// A link between sub-cubes: in a mid-plane of the cube and on none of its faces.
bool linkOnMidPlane(const CubeBox& c, const Index3& p, int a) {
  const int h = c.size() / 2;
  bool mid = false;
  for (int f = 0; f < 3; ++f) {
    if (f == a) continue;
    if (!c.strictlyInside(p, f)) return false;
    mid = mid || p[f] == c.o[f] + h;
  }
  return mid;
}
bool voxelOnMidPlane(const CubeBox& c, const Index3& p) {
  const int h = c.size() / 2;
  bool mid = false;
  for (int f = 0; f < 3; ++f) {
    if (!c.strictlyInside(p, f)) return false;
    mid = mid || p[f] == c.o[f] + h;
  }
  return mid;
}

// Result of splitting one affected cube.
struct SplitResult {
  std::vector<CubeBox> leaves;  // remaining sub-cubes, in depth-first order
  std::vector<LinkCut> cuts;
  std::size_t tested = 0, positioned = 0;
};

// Sub-steps (5-1)-(5-6) on one cube.
void splitCube(const CubeBox& cube, VoxelOctree& oct, VoxelGrid& grid, const SubdivisionHooks& hooks,
               SplitResult& out) {
  // (5-1) voxels between the sub-cubes.
  std::vector<std::uint32_t> voxels;
  forEachVoxel(cube, [&](const Index3& p) {
    if (voxelOnMidPlane(cube, p)) voxels.push_back(static_cast<std::uint32_t>(grid.index(p)));
  });
  if (!voxels.empty()) hooks.updatePositions(voxels);
  out.positioned += voxels.size();
  // (5-2) links between the sub-cubes.
  forEachLink(cube, [&](const Index3& p, int a) {
    if (!linkOnMidPlane(cube, p, a)) return;
    const std::size_t v = grid.index(p);
    if (!linkConnected(grid, v, a)) return;
    ++out.tested;
    if (const auto h = hooks.testLink(v, a)) {
      disconnect(grid, v, a);
      out.cuts.push_back({VoxelGrid::linkId(v, a), *h});
    }
  });
  // (5-3) a level-1 cube opens up completely.
  if (cube.level == 1) {
    forEachVoxel(cube, [&](const Index3& p) {
      std::uint8_t bits = kActiveVoxel;
      for (int a = 0; a < 3; ++a)
        if (p[a] < cube.o[a] + cube.size()) bits = static_cast<std::uint8_t>(bits | (1u << a));
      orState(oct, grid.index(p), bits);
    });
    return;
  }
  // (5-4) eight sub-cubes; (5-5) split those with a disconnected link on their boundary; (5-6).
  const int h = cube.size() / 2;
  for (int k = 0; k < 8; ++k) {
    const CubeBox sub{{cube.o.x + (k & 1) * h, cube.o.y + ((k >> 1) & 1) * h, cube.o.z + (k >> 2) * h},
                      cube.level - 1};
    bool cut = false;
    forEachLink(sub, [&](const Index3& p, int a) {
      if (!cut && linkOnFace(sub, p, a) && !linkConnected(grid, grid.index(p), a)) cut = true;
    });
    if (cut)
      splitCube(sub, oct, grid, hooks, out);
    else
      out.leaves.push_back(sub);
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

    // (2) voxels and links on the boundaries of the affected cubes.
    std::vector<std::vector<std::uint32_t>> faceVoxels(list.size());
    std::vector<std::vector<std::uint64_t>> faceLinks(list.size());
    parallelFor(0, list.size(), 4, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const OctreeCube& oc = oct.cubes[list[i]];
        const CubeBox cube{oc.origin, oc.level};
        forEachVoxel(cube, [&](const Index3& p) {
          if (voxelOnFace(cube, p)) faceVoxels[i].push_back(static_cast<std::uint32_t>(grid.index(p)));
        });
        forEachLink(cube, [&](const Index3& p, int a) {
          if (linkOnFace(cube, p, a)) faceLinks[i].push_back(VoxelGrid::linkId(grid.index(p), a));
        });
      }
    }, threaded);
    std::vector<std::uint32_t> voxels;
    std::vector<std::uint64_t> links;
    for (auto& f : faceVoxels) voxels.insert(voxels.end(), f.begin(), f.end());
    for (auto& f : faceLinks) links.insert(links.end(), f.begin(), f.end());
    std::sort(voxels.begin(), voxels.end());
    voxels.erase(std::unique(voxels.begin(), voxels.end()), voxels.end());
    std::sort(links.begin(), links.end());
    links.erase(std::unique(links.begin(), links.end()), links.end());

    // (3) positions of the inactive ones (active voxels were positioned for the main test).
    std::vector<std::uint32_t> inactive;
    for (std::uint32_t v : voxels)
      if (!oct.voxelActive(v)) inactive.push_back(v);
    constexpr std::size_t kChunk = 1024;
    parallelFor(0, (inactive.size() + kChunk - 1) / kChunk, 1, [&](std::size_t c0, std::size_t c1) {
      for (std::size_t c = c0; c < c1; ++c) {
        const std::vector<std::uint32_t> part(inactive.begin() + static_cast<long>(c * kChunk),
                                              inactive.begin() + static_cast<long>(std::min(inactive.size(), (c + 1) * kChunk)));
        hooks.updatePositions(part);
      }
    }, threaded);
    stats.positionedVoxels += inactive.size();

    // (4) connected inactive boundary links against the blade.
    std::vector<std::vector<LinkCut>> found((links.size() + kChunk - 1) / kChunk);
    std::vector<std::size_t> tested(found.size(), 0);
    parallelFor(0, found.size(), 1, [&](std::size_t c0, std::size_t c1) {
      for (std::size_t c = c0; c < c1; ++c)
        for (std::size_t i = c * kChunk; i < std::min(links.size(), (c + 1) * kChunk); ++i) {
          const std::size_t v = static_cast<std::size_t>(links[i] / 3);
          const int a = static_cast<int>(links[i] % 3);
          if (oct.linkActive(v, a) || !grid.connected(v, a)) continue;
          ++tested[c];
          if (const auto h = hooks.testLink(v, a)) found[c].push_back({links[i], *h});
        }
    }, threaded);
    std::vector<LinkCut> roundCuts;
    for (std::size_t c = 0; c < found.size(); ++c) {
      stats.testedLinks += tested[c];
      roundCuts.insert(roundCuts.end(), found[c].begin(), found[c].end());
    }
    for (const LinkCut& lc : roundCuts) grid.setConnected(static_cast<std::size_t>(lc.link / 3), static_cast<int>(lc.link % 3), false);

    // (5) split every affected cube, in parallel: their insides are disjoint.
    std::vector<SplitResult> results(list.size());
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const OctreeCube& oc = oct.cubes[list[i]];
        splitCube({oc.origin, oc.level}, oct, grid, hooks, results[i]);
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
