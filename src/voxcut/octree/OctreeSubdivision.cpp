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

// Calls fn(p) for every voxel on the cube's faces (voxels on edges come more than once).
template <class Fn>
void forEachFaceVoxel(const CubeBox& c, Fn&& fn) {
  const int s = c.size();
  for (int f = 0; f < 3; ++f) {
    const int u = (f + 1) % 3, w = (f + 2) % 3;
    for (int side = 0; side <= s; side += s)
      for (int j = 0; j <= s; ++j)
        for (int i = 0; i <= s; ++i) {
          Index3 p = c.o;
          p[f] += side;
          p[u] += i;
          p[w] += j;
          fn(p);
        }
  }
}

// Calls fn(p, a) for every link on the cube's faces (links on edges come twice).
template <class Fn>
void forEachFaceLink(const CubeBox& c, Fn&& fn) {
  const int s = c.size();
  for (int f = 0; f < 3; ++f)
    for (int side = 0; side <= s; side += s)
      for (int k = 1; k <= 2; ++k) {
        const int a = (f + k) % 3, other = (f + 3 - k) % 3;
        for (int j = 0; j <= s; ++j)
          for (int i = 0; i < s; ++i) {
            Index3 p = c.o;
            p[f] += side;
            p[a] += i;
            p[other] += j;
            fn(p, a);
          }
      }
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

// Sub-steps (5-1)-(5-6) on one cube; `boundaryCuts` are the disconnected links on its faces.
void splitCube(const CubeBox& cube, const std::vector<CutLink>& boundaryCuts, VoxelOctree& oct,
               VoxelGrid& grid, const SubdivisionHooks& hooks, SplitResult& out) {
  const int s = cube.size(), h = s / 2;
  // (5-1) voxels between the sub-cubes: on a mid-plane, off the faces.
  std::vector<std::uint32_t> voxels;
  for (int z = 1; z < s; ++z)
    for (int y = 1; y < s; ++y)
      for (int x = 1; x < s; ++x)
        if (x == h || y == h || z == h)
          voxels.push_back(static_cast<std::uint32_t>(grid.index(cube.o.x + x, cube.o.y + y, cube.o.z + z)));
  if (!voxels.empty()) hooks.updatePositions(voxels);
  out.positioned += voxels.size();
  // (5-2) links between the sub-cubes: in a mid-plane, off the faces.
  std::vector<CutLink> cuts = boundaryCuts;
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    for (int j = 1; j < s; ++j)
      for (int i = 1; i < s; ++i) {
        if (i != h && j != h) continue;
        for (int k = 0; k < s; ++k) {
          Index3 p = cube.o;
          p[a] += k;
          p[u] += i;
          p[w] += j;
          const std::size_t v = grid.index(p);
          if (!linkConnected(grid, v, a)) continue;
          ++out.tested;
          if (const auto hit = hooks.testLink(v, a)) {
            disconnect(grid, v, a);
            out.cuts.push_back({VoxelGrid::linkId(v, a), *hit});
            cuts.push_back({p, a});
          }
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

    // (2) mark the voxels and links on the boundaries of the affected cubes; a flag per voxel
    // and per link makes each one belong to exactly one cube's list, whichever task sets it
    // first (the results do not depend on which: they are sorted by link in the end).
    if (oct.mark.size() != grid.voxelCount()) oct.mark.assign(grid.voxelCount(), 0);
    std::vector<std::vector<std::uint32_t>> faceVoxels(list.size());
    std::vector<std::vector<std::uint64_t>> faceLinks(list.size());
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const OctreeCube& oc = oct.cubes[list[i]];
        const CubeBox cube{oc.origin, oc.level};
        forEachFaceVoxel(cube, [&](const Index3& p) {
          const std::size_t v = grid.index(p);
          if (!(std::atomic_ref<std::uint8_t>(oct.mark[v]).fetch_or(kActiveVoxel, std::memory_order_relaxed) & kActiveVoxel))
            faceVoxels[i].push_back(static_cast<std::uint32_t>(v));
        });
        forEachFaceLink(cube, [&](const Index3& p, int a) {
          const std::size_t v = grid.index(p);
          const auto bit = static_cast<std::uint8_t>(1u << a);
          if (!(std::atomic_ref<std::uint8_t>(oct.mark[v]).fetch_or(bit, std::memory_order_relaxed) & bit))
            faceLinks[i].push_back(VoxelGrid::linkId(v, a));
        });
      }
    }, threaded);

    // (3) positions of the inactive ones (active voxels were positioned for the main test).
    std::vector<std::size_t> positioned(list.size(), 0);
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        std::vector<std::uint32_t> inactive;
        for (std::uint32_t v : faceVoxels[i])
          if (!oct.voxelActive(v)) inactive.push_back(v);
        if (!inactive.empty()) hooks.updatePositions(inactive);
        positioned[i] = inactive.size();
      }
    }, threaded);

    // (4) connected inactive boundary links against the blade.
    std::vector<std::vector<LinkCut>> found(list.size());
    std::vector<std::size_t> tested(list.size(), 0);
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i)
        for (std::uint64_t link : faceLinks[i]) {
          const std::size_t v = static_cast<std::size_t>(link / 3);
          const int a = static_cast<int>(link % 3);
          if (oct.linkActive(v, a) || !grid.connected(v, a)) continue;
          ++tested[i];
          if (const auto h = hooks.testLink(v, a)) found[i].push_back({link, *h});
        }
    }, threaded);
    std::vector<LinkCut> roundCuts;
    for (std::size_t i = 0; i < list.size(); ++i) {
      stats.testedLinks += tested[i];
      stats.positionedVoxels += positioned[i];
      roundCuts.insert(roundCuts.end(), found[i].begin(), found[i].end());
    }
    for (const LinkCut& lc : roundCuts) grid.setConnected(static_cast<std::size_t>(lc.link / 3), static_cast<int>(lc.link % 3), false);
    // Clear the marks for the next round.
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        for (std::uint32_t v : faceVoxels[i]) std::atomic_ref<std::uint8_t>(oct.mark[v]).store(0, std::memory_order_relaxed);
        for (std::uint64_t link : faceLinks[i])
          std::atomic_ref<std::uint8_t>(oct.mark[static_cast<std::size_t>(link / 3)]).store(0, std::memory_order_relaxed);
      }
    }, threaded);

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
