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

struct CutLink {
  Index3 p;
  int a;
};

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

// One task's work and findings.
struct Worker {
  VoxelOctree& oct;
  VoxelGrid& grid;
  const SubdivisionHooks& hooks;
  std::vector<LinkCut> cuts;          // links this task cut
  std::vector<CutLink> found;         // the same, as positions, for the sub-cube test
  std::vector<std::uint32_t> voxels;  // scratch
  std::size_t tested = 0, positioned = 0;

  // Positions the listed voxels, except those positioned for the main test (active at the
  // start of the frame: voxels opened since carry kOpenedVoxel instead).
  void position() {
    voxels.erase(std::remove_if(voxels.begin(), voxels.end(),
                                [&](std::uint32_t v) {
                                  return std::atomic_ref<std::uint8_t>(oct.state[v]).load(std::memory_order_relaxed) &
                                         kActiveVoxel;
                                }),
                 voxels.end());
    if (voxels.empty()) return;
    hooks.updatePositions(voxels);
    positioned += voxels.size();
    voxels.clear();
  }

  // Tests link (p, a); a crossed link is disconnected at once and recorded.
  void test(const Index3& p, int a) {
    const std::size_t v = grid.index(p);
    ++tested;  // counted before the state check, so the count does not depend on scheduling
    if (!linkConnected(grid, v, a)) return;
    if (const auto hit = hooks.testLink(v, a)) {
      disconnect(grid, v, a);
      cuts.push_back({VoxelGrid::linkId(v, a), *hit, std::nullopt});
      found.push_back({p, a});
    }
  }

  // The links inside the square of side m (a power of two) at `o` in the plane normal to f,
  // spanned by axes u = (f+1)%3 and w = (f+2)%3, whose border links are decided already.
  // A blade that crosses the square crosses its border, so a square with no cut on its
  // border holds none inside. Otherwise: its two centre lines are positioned and tested, and
  // each quarter follows. The work grows with the length of the blade's trace, not the area.
  void resolveSquare(const Index3& o, int f, int m) {
    if (m < 2) return;
    const int u = (f + 1) % 3, w = (f + 2) % 3;
    auto point = [&](int i, int j) {
      Index3 p = o;
      p[u] += i;
      p[w] += j;
      return p;
    };
    bool crossed = false;
    for (int i = 0; i < m && !crossed; ++i)
      crossed = !linkConnected(grid, grid.index(point(i, 0)), u) ||
                !linkConnected(grid, grid.index(point(i, m)), u) ||
                !linkConnected(grid, grid.index(point(0, i)), w) ||
                !linkConnected(grid, grid.index(point(m, i)), w);
    if (!crossed) return;
    const int h = m / 2;
    // Positions of the cross (its ends on the border too: a border without cuts on that side
    // may not have been positioned; positioning twice gives the same value).
    for (int k = 0; k <= m; ++k) {
      voxels.push_back(static_cast<std::uint32_t>(grid.index(point(h, k))));
      if (k != h) voxels.push_back(static_cast<std::uint32_t>(grid.index(point(k, h))));
    }
    position();
    for (int k = 0; k < m; ++k) {
      test(point(h, k), w);
      test(point(k, h), u);
    }
    for (int q = 0; q < 4; ++q) resolveSquare(point((q & 1) * h, (q >> 1) * h), f, h);
  }

  // Sub-steps (5-1)-(5-6) on one cube; `cutsOnBoundary` lists the cut links on its faces.
  void split(const CubeBox& cube, const std::vector<CutLink>& cutsOnBoundary, std::vector<CubeBox>& leaves) {
    const int s = cube.size(), h = s / 2;
    const std::size_t before = found.size();
    // (5-1), (5-2) between the sub-cubes: the three centre lines where the mid-planes meet,
    // then the 12 quarter faces they divide the mid-planes into.
    for (int a = 0; a < 3; ++a)
      for (int k = 0; k <= s; ++k) {
        if (a > 0 && k == h) continue;  // the centre voxel once
        Index3 p{cube.o.x + h, cube.o.y + h, cube.o.z + h};
        p[a] = cube.o[a] + k;
        voxels.push_back(static_cast<std::uint32_t>(grid.index(p)));
      }
    position();
    for (int a = 0; a < 3; ++a)
      for (int k = 0; k < s; ++k) {
        Index3 p{cube.o.x + h, cube.o.y + h, cube.o.z + h};
        p[a] = cube.o[a] + k;
        test(p, a);
      }
    for (int f = 0; f < 3; ++f) {
      const int u = (f + 1) % 3, w = (f + 2) % 3;
      for (int q = 0; q < 4; ++q) {
        Index3 o = cube.o;
        o[f] += h;
        o[u] += (q & 1) * h;
        o[w] += (q >> 1) * h;
        resolveSquare(o, f, h);
      }
    }
    // (5-3) a level-1 cube opens up completely.
    if (cube.level == 1) {
      for (int z = 0; z <= s; ++z)
        for (int y = 0; y <= s; ++y)
          for (int x = 0; x <= s; ++x) {
            const int d[3] = {x, y, z};
            std::uint8_t bits = kOpenedVoxel;
            for (int a = 0; a < 3; ++a)
              if (d[a] < s) bits = static_cast<std::uint8_t>(bits | (1u << a));
            orState(oct, grid.index(cube.o.x + x, cube.o.y + y, cube.o.z + z), bits);
          }
      return;
    }
    // (5-4) eight sub-cubes; (5-5) split those with a cut link on their boundary (the cube had
    // none inside before this frame, so they are on its faces or found just now); (5-6).
    std::vector<CutLink> all = cutsOnBoundary;
    all.insert(all.end(), found.begin() + static_cast<long>(before), found.end());
    std::vector<CutLink> sub;
    for (int k = 0; k < 8; ++k) {
      const CubeBox child{{cube.o.x + (k & 1) * h, cube.o.y + ((k >> 1) & 1) * h, cube.o.z + (k >> 2) * h},
                          cube.level - 1};
      sub.clear();
      for (const CutLink& c : all)
        if (linkOnBoundary(child, c.p, c.a)) sub.push_back(c);
      if (sub.empty())
        leaves.push_back(child);
      else
        split(child, sub, leaves);
    }
  }
};

}  // namespace

SubdivisionStats subdivideCutCubes(VoxelOctree& oct, VoxelGrid& grid, std::vector<LinkCut>& cuts,
                                   const SubdivisionHooks& hooks, bool threaded) {
  SubdivisionStats stats;
  const Index3 d = grid.dims();
  std::vector<std::uint64_t> pending;
  for (const LinkCut& c : cuts) pending.push_back(c.link);
  std::vector<std::uint8_t> affected;
  // The cubes (level >= 1) around link (v, a), through the 4 unit cells it borders.
  auto cubesAround = [&](std::uint64_t link, auto&& fn) {
    const std::size_t v = static_cast<std::size_t>(link / 3);
    forEachCellAroundLink(d, grid.coord(v), static_cast<int>(link % 3), [&](const Index3& cell) {
      const std::int32_t cube = oct.cellCube[grid.index(cell)];
      if (cube >= 0) fn(static_cast<std::size_t>(cube));
    });
  };
  while (!pending.empty()) {
    // (1) mark the cubes around the newly cut links (raising a raised flag is harmless).
    affected.assign(oct.cubes.size(), 0);
    parallelFor(0, pending.size(), 256, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i)
        cubesAround(pending[i], [&](std::size_t cube) {
          std::atomic_ref<std::uint8_t>(affected[cube]).store(1, std::memory_order_relaxed);
        });
    }, threaded);
    std::vector<std::uint32_t> list;
    std::vector<std::int32_t> slot(oct.cubes.size(), -1);
    for (std::size_t c = 0; c < affected.size(); ++c)
      if (affected[c]) {
        slot[c] = static_cast<std::int32_t>(list.size());
        list.push_back(static_cast<std::uint32_t>(c));
      }
    if (list.empty()) break;
    ++stats.rounds;
    stats.affectedCubes += list.size();

    // (2)-(4) the faces of the affected cubes: their voxels are positioned and their links
    // tested, square by square where the blade's trace runs (a face shared by two affected
    // cubes is resolved by both, with the same results). A face's border is the cube's frame,
    // or lines of the mid-planes of the cube it was split from: decided already.
    std::vector<Worker> faceWork;
    faceWork.reserve(list.size());
    for (std::size_t i = 0; i < list.size(); ++i) faceWork.push_back(Worker{oct, grid, hooks, {}, {}, {}, 0, 0});
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const OctreeCube& oc = oct.cubes[list[i]];
        const int s = 1 << oc.level;
        for (int f = 0; f < 6; ++f) {
          Index3 o = oc.origin;
          o[f / 2] += (f & 1) * s;
          // A face shared whole with another affected cube of the same size is resolved once,
          // by the cube listed first.
          Index3 across = oc.origin;
          across[f / 2] += (f & 1) ? s : -1;
          if (across[f / 2] >= 0 && across[f / 2] + 1 < d[f / 2]) {
            const std::int32_t other = oct.cellCube[grid.index(across)];
            if (other >= 0 && slot[static_cast<std::size_t>(other)] >= 0 &&
                slot[static_cast<std::size_t>(other)] < static_cast<std::int32_t>(i) &&
                oct.cubes[static_cast<std::size_t>(other)].level == oc.level)
              continue;
          }
          faceWork[i].resolveSquare(o, f / 2, s);
        }
      }
    }, threaded);
    std::vector<LinkCut> roundCuts;
    for (Worker& w : faceWork) {
      stats.testedLinks += w.tested;
      stats.positionedVoxels += w.positioned;
      roundCuts.insert(roundCuts.end(), w.cuts.begin(), w.cuts.end());
    }
    std::sort(roundCuts.begin(), roundCuts.end(), [](const LinkCut& x, const LinkCut& y) { return x.link < y.link; });
    roundCuts.erase(std::unique(roundCuts.begin(), roundCuts.end(),
                                [](const LinkCut& x, const LinkCut& y) { return x.link == y.link; }),
                    roundCuts.end());

    // The cut links on each affected cube's boundary: this frame's cuts so far (a surviving
    // cube had none before), gathered through the cubes around each.
    std::vector<std::vector<CutLink>> onBoundary(list.size());
    auto collect = [&](std::uint64_t link) {
      const std::size_t v = static_cast<std::size_t>(link / 3);
      const int a = static_cast<int>(link % 3);
      const Index3 p = grid.coord(v);
      std::size_t seen[4];
      int n = 0;
      cubesAround(link, [&](std::size_t cube) {
        if (slot[cube] < 0 || std::find(seen, seen + n, cube) != seen + n) return;
        seen[n++] = cube;
        const OctreeCube& oc = oct.cubes[cube];
        if (linkOnBoundary({oc.origin, oc.level}, p, a)) onBoundary[static_cast<std::size_t>(slot[cube])].push_back({p, a});
      });
    };
    for (const LinkCut& c : cuts) collect(c.link);
    for (const LinkCut& c : roundCuts) collect(c.link);

    // (5) split every affected cube, in parallel: their insides are disjoint.
    std::vector<Worker> splitWork;
    splitWork.reserve(list.size());
    for (std::size_t i = 0; i < list.size(); ++i) splitWork.push_back(Worker{oct, grid, hooks, {}, {}, {}, 0, 0});
    std::vector<std::vector<CubeBox>> leaves(list.size());
    parallelFor(0, list.size(), 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const OctreeCube& oc = oct.cubes[list[i]];
        splitWork[i].split({oc.origin, oc.level}, onBoundary[i], leaves[i]);
      }
    }, threaded);

    // Store the sub-cubes: the first takes the split cube's slot, the others are appended.
    for (std::size_t i = 0; i < list.size(); ++i) {
      stats.testedLinks += splitWork[i].tested;
      stats.positionedVoxels += splitWork[i].positioned;
      roundCuts.insert(roundCuts.end(), splitWork[i].cuts.begin(), splitWork[i].cuts.end());
      const std::uint32_t id = list[i];
      const OctreeCube old = oct.cubes[id];
      const int s = 1 << old.level;
      for (int z = 0; z < s; ++z)
        for (int y = 0; y < s; ++y)
          for (int x = 0; x < s; ++x) oct.cellCube[grid.index(old.origin.x + x, old.origin.y + y, old.origin.z + z)] = -1;
      if (leaves[i].empty()) {
        oct.cubes[id].deleted = true;
        continue;
      }
      for (std::size_t k = 0; k < leaves[i].size(); ++k) {
        const OctreeCube sub{leaves[i][k].o, static_cast<std::uint8_t>(leaves[i][k].level), false};
        std::uint32_t at = id;
        if (k == 0) {
          oct.cubes[id] = sub;
        } else {
          at = static_cast<std::uint32_t>(oct.cubes.size());
          oct.cubes.push_back(sub);
        }
        oct.newCubes.push_back(at);
        const int ss = 1 << sub.level;
        for (int z = 0; z < ss; ++z)
          for (int y = 0; y < ss; ++y)
            for (int x = 0; x < ss; ++x)
              oct.cellCube[grid.index(sub.origin.x + x, sub.origin.y + y, sub.origin.z + z)] = static_cast<std::int32_t>(at);
      }
    }
    // Hermite data of this round's cuts; they are next round's newly cut links (6).
    pending.clear();
    for (LinkCut& lc : roundCuts) {
      if (const Hermite* old = grid.hermite().find(lc.link)) lc.previous = *old;
      grid.hermite().set(lc.link, lc.hermite);
      pending.push_back(lc.link);
    }
    stats.cutLinks += roundCuts.size();
    cuts.insert(cuts.end(), roundCuts.begin(), roundCuts.end());
  }
  return stats;
}

}  // namespace voxcut
