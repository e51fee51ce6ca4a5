#pragma once
/// @file SubdivisionWorker.h
/// Internal to octree/OctreeSubdivision.cpp, which alone includes it: the worker that traces
/// the blade over the affected cubes' faces and splits the cubes (sub-steps (2)-(5) on one
/// cube), and the memory it keeps from one run to the next (SubdivisionWorkspace). Not part of
/// the public API.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "voxcut/core/Error.h"
#include "voxcut/octree/OctreeSubdivision.h"

namespace voxcut {
namespace subdivision_detail {

// Link bits are shared by neighbouring cubes' tasks (one byte holds a voxel's three links), so
// in this phase every access goes through VoxelGrid's atomic connectedShared/disconnectShared.
// Calls fn(cube) for the cube (level >= 1) over each of the unit cells that link (voxel, a)
// borders, where one is stored.
template <class Fn>
void forEachCubeAroundLink(const VoxelOctree& oct, const VoxelGrid& grid, const Index3& voxel,
                           int a, Fn&& fn) {
  forEachCellAroundLink(grid.dims(), voxel, a, [&](const Index3& cell) {
    const std::int32_t cube = oct.cellCube[grid.index(cell)];
    if (cube >= 0) fn(static_cast<std::size_t>(cube));
  });
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

}  // namespace subdivision_detail

// The memory of a worker (below) that outlives a subdivision run: its vectors keep their
// capacity from one run (frame) to the next, so a frame does not grow them from nothing.
struct SubdivisionWorkspace::WorkerMemory {
  // Findings, cleared at the start of each phase.
  std::vector<LinkCut> cuts;                       // links this worker cut this round
  std::vector<subdivision_detail::CutLink> found;  // the same, as positions, for the sub-cube test
  // The faces phase's cuts on faces not shared whole with a cube split in the same round that
  // border a cube outside the round: next round's newly cut links.
  std::vector<std::uint64_t> outward;
  std::vector<Index3> opened;  // level-1 cubes split (listed in octree.openedCubes)
  std::vector<subdivision_detail::CubeBox> leaves;       // sub-cubes kept, cube after cube
  std::vector<std::array<std::uint32_t, 3>> leafRanges;  // (cube slot, begin, end) in leaves
  // Scratch.
  std::vector<std::pair<int, int>> cells;       // traceSquare: cells to visit
  std::vector<std::uint8_t> visited, examined;  // traceSquare: per cell, per link
  // Per level: the cut links on each of the 8 sub-cubes' boundaries, and the boundary points
  // near the sub-cube being split (reused between calls).
  std::vector<std::array<std::vector<subdivision_detail::CutLink>, 8>> childCuts;
  std::vector<std::vector<Vec3d>> childPoints;
  std::vector<Vec3d> cubePoints;  // the boundary points near the cube a task resolves
  std::vector<subdivision_detail::CutLink> boundary;  // the cut links on a split cube's faces
};

namespace subdivision_detail {

using WorkerMemory = SubdivisionWorkspace::WorkerMemory;

// A thread's worker: its findings in the current phase, and scratch memory reused by every
// task it runs in one subdivision run (the position cache stays valid for the whole run:
// positions do not change during it). One task runs on a thread at a time, so a worker is
// never used by two at once; whatever the workers find is merged in an order-independent
// way (each cut is recorded by one task, counts are summed, leaves kept per cube).
struct Worker : WorkerMemory {
  VoxelOctree& oct;
  VoxelGrid& grid;
  const SubdivisionHooks& hooks;
  std::size_t tested = 0;
  bool recordOutward = false;
  // The round's slot of each cube, -1 if none (for the outward cuts).
  const std::vector<std::int32_t>* listed = nullptr;
  VoxelPositionCache positions;  // for the link test

  Worker(VoxelOctree& o, VoxelGrid& g, const SubdivisionHooks& h, WorkerMemory&& memory)
      : WorkerMemory(std::move(memory)), oct(o), grid(g), hooks(h) {
    cuts.clear();
    clearFindings();
  }

  // Per phase; the cuts are kept for the whole round (stored at its end).
  void clearFindings() {
    outward.clear();
    found.clear();
    tested = 0;
    opened.clear();
    leaves.clear();
    leafRanges.clear();
  }

  // The disconnected links on the faces of `cube`. A cube exists only where every link was
  // connected when it was made, and a cube with a cut on its boundary is split in the same
  // frame, so these are exactly this frame's cuts on its boundary. During the split phase
  // other tasks only cut links inside their own cubes, so these bits do not change.
  void gatherBoundaryCuts(const CubeBox& cube) {
    boundary.clear();
    const int s = cube.size();
    for (int a = 0; a < 3; ++a) {
      const int u = (a + 1) % 3, w = (a + 2) % 3;
      for (int j = 0; j <= s; ++j) {
        const bool rim = j == 0 || j == s;
        for (int i = 0; i <= s; i += (rim || i == s) ? 1 : s) {
          Index3 p = cube.o;
          p[u] += i;
          p[w] += j;
          std::size_t v = grid.index(p);
          const std::size_t step = grid.stride(a);
          for (int k = 0; k < s; ++k, v += step)
            if (!grid.connectedShared(v, a)) {
              Index3 q = p;
              q[a] += k;
              boundary.push_back({q, a});
            }
        }
      }
    }
  }

  // Tests link (v, a) at grid point p (computed on a hit) if it is still connected; it counts
  // as tested either way, so the count does not depend on scheduling. A crossed link is
  // disconnected at once and recorded by the task that disconnects it.
  template <class Point>
  void testLink(std::size_t v, int a, Point&& p) {
    ++tested;
    if (!grid.connectedShared(v, a)) return;
    const std::optional<Hermite> hit = hooks.testLink(v, a, positions);
    // Two tasks that resolve a face they share may both find one of its links crossed: only
    // the one that disconnects it (disconnectShared says so) records the cut.
    if (!hit || !grid.disconnectShared(v, a)) return;
    cuts.push_back({VoxelGrid::linkId(v, a), *hit, std::nullopt});
    const Index3 q = p();
    found.push_back({q, a});
    if (recordOutward && bordersUnlistedCube(q, a)) outward.push_back(VoxelGrid::linkId(v, a));
  }

  // Whether a cube outside this round's list borders link (q, a). The cubes of the list are
  // split this round around every cut on their faces, so their sub-cubes have none on theirs.
  [[nodiscard]] bool bordersUnlistedCube(const Index3& q, int a) const {
    bool unlisted = false;
    forEachCubeAroundLink(oct, grid, q, a,
                          [&](std::size_t cube) { unlisted = unlisted || (*listed)[cube] < 0; });
    return unlisted;
  }

  // The links inside the square of side m at `o` in the plane normal to f, spanned by axes
  // u = (f+1)%3 and w = (f+2)%3, whose border links are decided already. The blade crosses
  // the square along its trace, which enters through the border: the trace is followed from
  // every cut border link, unit cell by unit cell; a cell's links not yet examined are tested,
  // and the cells across its cut links come next. The work grows with the length of the trace
  // (a few tests per link it crosses, counting the centre-line links two mid-planes share),
  // not with the square's area. A square with no cut on its border holds none inside.
  //
  // Where the sweep's boundary (the blade's edge, the path of its tips) crosses the square, the
  // trace may end inside it without reaching the border: `points` (rest voxel coordinates of
  // the boundary, sampled densely) seed the trace too, at the cells around every point within
  // one voxel of the square's plane.
  void traceSquare(const Index3& o, int f, int m, const std::vector<Vec3d>* points = nullptr) {
    if (m < 2) return;  // no link inside
    const int u = (f + 1) % 3, w = (f + 2) % 3;
    const std::size_t base = grid.index(o), su = grid.stride(u), sw = grid.stride(w);
    const auto mz = static_cast<std::size_t>(m);
    // Point (i, j) of the square; u-link (i, j) runs from it along u (i < m, j <= m), w-link
    // (i, j) along w (i <= m, j < m).
    const auto voxelAt = [&](int i, int j) {
      return base + static_cast<std::size_t>(i) * su + static_cast<std::size_t>(j) * sw;
    };
    const auto pointAt = [&](int i, int j) {
      return [&o, u, w, i, j] {
        Index3 p = o;
        p[u] += i;
        p[w] += j;
        return p;
      };
    };
    cells.clear();
    forEachBorderCut(o, f, m, [&](int i, int j) { cells.push_back({i, j}); });
    if (points != nullptr)
      for (const Vec3d& q : *points) {
        if (std::abs(q[f] - o[f]) > 1.0) continue;
        const int ci = static_cast<int>(std::floor(q[u])) - o[u];
        const int cj = static_cast<int>(std::floor(q[w])) - o[w];
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di)
            if (ci + di >= 0 && ci + di < m && cj + dj >= 0 && cj + dj < m)
              cells.push_back({ci + di, cj + dj});
      }
    if (cells.empty()) return;
    if (m == 2) {
      // Two by two cells (a level-1 cube's face): the 4 inside links meet at the centre
      // point and are all tested once a border link is cut; following the trace would test
      // nearly as many, at a higher cost per link.
      testLink(voxelAt(0, 1), u, pointAt(0, 1));
      testLink(voxelAt(1, 1), u, pointAt(1, 1));
      testLink(voxelAt(1, 0), w, pointAt(1, 0));
      testLink(voxelAt(1, 1), w, pointAt(1, 1));
      return;
    }
    visited.assign(mz * mz, 0);
    examined.assign(2 * mz * (mz + 1), 0);  // u-links, then w-links
    // Examines the interior link (a u-link when `alongU`) and says whether it is cut.
    const auto cut = [&](bool alongU, int i, int j) {
      const std::size_t slot =
          alongU ? static_cast<std::size_t>(j) * mz + static_cast<std::size_t>(i)
                 : mz * (mz + 1) + static_cast<std::size_t>(i) * mz + static_cast<std::size_t>(j);
      const int axis = alongU ? u : w;
      const std::size_t v = voxelAt(i, j);
      if (!examined[slot]) {
        examined[slot] = 1;
        testLink(v, axis, pointAt(i, j));
      }
      return !grid.connectedShared(v, axis);
    };
    while (!cells.empty()) {
      const auto [i, j] = cells.back();
      cells.pop_back();
      std::uint8_t& seen = visited[static_cast<std::size_t>(j) * mz + static_cast<std::size_t>(i)];
      if (seen) continue;
      seen = 1;
      if (j > 0 && cut(true, i, j)) cells.push_back({i, j - 1});
      if (j + 1 < m && cut(true, i, j + 1)) cells.push_back({i, j + 1});
      if (i > 0 && cut(false, i, j)) cells.push_back({i - 1, j});
      if (i + 1 < m && cut(false, i + 1, j)) cells.push_back({i + 1, j});
    }
  }

  // Calls cell(i, j) for each cut link on the border of the square of side m at o in the plane
  // normal to f, spanned by u = (f+1)%3 and w = (f+2)%3, with the square's unit cell (i, j) that
  // the link borders.
  template <class Cell>
  void forEachBorderCut(const Index3& o, int f, int m, Cell&& cell) const {
    const int u = (f + 1) % 3, w = (f + 2) % 3;
    const std::size_t base = grid.index(o), su = grid.stride(u), sw = grid.stride(w);
    const auto voxelAt = [&](int i, int j) {
      return base + static_cast<std::size_t>(i) * su + static_cast<std::size_t>(j) * sw;
    };
    for (int i = 0; i < m; ++i) {
      if (!grid.connectedShared(voxelAt(i, 0), u)) cell(i, 0);
      if (!grid.connectedShared(voxelAt(i, m), u)) cell(i, m - 1);
      if (!grid.connectedShared(voxelAt(0, i), w)) cell(0, i);
      if (!grid.connectedShared(voxelAt(m, i), w)) cell(m - 1, i);
    }
  }

  // Whether a link on the border of the mid-plane across axis f of the level-1 cube at o is
  // cut: the 8 links of the cube's faces that lie in that plane (the cube's edges are not in
  // it).
  bool midPlaneBorderCut(const Index3& o, int f) const {
    Index3 q = o;
    ++q[f];
    bool cut = false;
    forEachBorderCut(q, f, 2, [&](int, int) { cut = true; });
    return cut;
  }

  // The sweep's boundary points (rest voxel coordinates) within `margin` of the box of side
  // `size` at `o`, from `from`.
  static void pointsNear(const std::vector<Vec3d>& from, const Index3& o, int size, double margin,
                         std::vector<Vec3d>& out) {
    out.clear();
    for (const Vec3d& q : from) {
      bool near = true;
      for (int k = 0; k < 3 && near; ++k)
        near = q[k] >= o[k] - margin && q[k] <= o[k] + size + margin;
      if (near) out.push_back(q);
    }
  }

  // Sub-steps (5-1)-(5-6) on one cube; `cutsOnBoundary` lists the cut links on its faces.
  //
  // `points`: the sweep's boundary points near the cube (empty for most cubes). A sub-cube
  // with such a point is split too, even with no cut on its faces; where that finds no cut at
  // all, the cube stays whole (kept as one leaf). Returns whether it stayed whole.
  // `cutOnBoundary`: whether a link on its faces is cut (for a top-level level-1 cube,
  // cutsOnBoundary is not gathered).
  bool split(const CubeBox& cube, const std::vector<CutLink>& cutsOnBoundary,
             const std::vector<Vec3d>& points, bool cutOnBoundary) {
    if (cube.level == 1) return splitLevelOne(cube, points, cutOnBoundary);
    const int s = cube.size(), h = s / 2;
    const std::size_t before = found.size(), leavesBefore = leaves.size();
    // (5-1), (5-2) between the sub-cubes: the links of the three mid-planes, the three centre
    // lines where they meet among them, followed along the blade's trace from the cube's faces
    // (a centre-line link is inside two mid-planes: the second sees it cut, or tests it again).
    for (int f = 0; f < 3; ++f) {
      Index3 o = cube.o;
      o[f] += h;
      traceSquare(o, f, s, points.empty() ? nullptr : &points);
    }
    // (5-4) eight sub-cubes; (5-5) split those with a cut link on their boundary (the cube had
    // none inside before this frame, so they are on its faces or found just now); (5-6).
    // Sized by the first (largest) cube; the recursion only goes down, so `sub` stays valid.
    auto& sub = distributeToChildren(cube, cutsOnBoundary, before);
    auto& near = childPoints[static_cast<std::size_t>(cube.level)];
    bool whole = !cutOnBoundary && found.size() == before;
    for (int k = 0; k < 8; ++k) {
      const CubeBox child{
          {cube.o.x + (k & 1) * h, cube.o.y + ((k >> 1) & 1) * h, cube.o.z + (k >> 2) * h},
          cube.level - 1};
      near.clear();
      if (!points.empty()) pointsNear(points, child.o, child.size(), 1.0, near);
      if (sub[static_cast<std::size_t>(k)].empty() && near.empty())
        leaves.push_back(child);
      else
        whole = split(child, sub[static_cast<std::size_t>(k)], near,
                      !sub[static_cast<std::size_t>(k)].empty()) &&
                whole;
    }
    if (whole) {
      // Only boundary points brought it here, and nothing in it is cut.
      leaves.resize(leavesBefore);
      leaves.push_back(cube);
    }
    return whole;
  }

  // (5-1)-(5-3) on a level-1 cube (see split); returns whether it stayed whole.
  bool splitLevelOne(const CubeBox& cube, const std::vector<Vec3d>& points, bool cutOnBoundary) {
    const std::size_t before = found.size();
    // (5-1), (5-2) between the 8 voxel cells of a level-1 cube lie only the 6 links at its
    // centre voxel, two along each axis a, inside the two mid-planes across the other axes.
    // The blade's trace through a cut one crosses both mid-planes' borders (their links on
    // the cube's faces, decided already), so a pair is tested only when both borders hold a
    // cut, which skips most pairs (a blade crossing a cube cuts the centre links of one or
    // two axes). Where the sweep's boundary comes near
    // (`points`), the blade's edge may end inside the cube and leave a mid-plane's border
    // uncut: all 6 are tested. (5-3) the cube opens up completely: recorded here
    // (VoxelOctree::openedCubes); its 27 voxels and 54 links, the frames of its level-0
    // sub-cubes, are activated with the other new frames in deferred update (b), since this
    // frame's cutting does not read them (the subdivision reads the link bits only).
    const Index3 c{cube.o.x + 1, cube.o.y + 1, cube.o.z + 1};
    const std::size_t centre = grid.index(c);
    bool crossed[3];  // per mid-plane (by its normal axis): a cut on its border
    for (int f = 0; f < 3; ++f) crossed[f] = !points.empty() || midPlaneBorderCut(cube.o, f);
    for (int a = 0; a < 3; ++a) {
      if (!crossed[(a + 1) % 3] || !crossed[(a + 2) % 3]) continue;
      testLink(centre - grid.stride(a), a, [&] {
        Index3 p = c;
        --p[a];
        return p;
      });
      testLink(centre, a, [&] { return c; });
    }
    if (!cutOnBoundary && found.size() == before) {
      leaves.push_back(cube);
      return true;
    }
    opened.push_back(cube.o);
    return false;
  }

  // The cut links on the boundary of each of the 8 sub-cubes of `cube` (level >= 2): those on
  // its faces, `cutsOnBoundary`, and those found since found[before] on its mid-planes.
  std::array<std::vector<CutLink>, 8>& distributeToChildren(
      const CubeBox& cube, const std::vector<CutLink>& cutsOnBoundary, std::size_t before) {
    const int h = cube.size() / 2;
    if (childCuts.size() < static_cast<std::size_t>(cube.level) + 1) {
      childCuts.resize(static_cast<std::size_t>(cube.level) + 1);
      childPoints.resize(static_cast<std::size_t>(cube.level) + 1);
    }
    auto& sub = childCuts[static_cast<std::size_t>(cube.level)];
    for (auto& list : sub) list.clear();
    const auto distribute = [&](const CutLink& c) {
      // A link lies on the boundary of every sub-cube whose box holds it: it lies on one of
      // the cube's faces or mid-planes. Along each axis f other than its own, a link on the
      // mid-plane belongs to both halves; along its own axis, to the half it spans.
      int lo[3], hi[3];
      for (int f = 0; f < 3; ++f) {
        const int rel = c.p[f] - cube.o[f];
        if (f == c.a) {
          lo[f] = hi[f] = rel >= h ? 1 : 0;
        } else {
          lo[f] = rel > h ? 1 : 0;
          hi[f] = rel >= h ? 1 : 0;
        }
      }
      for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y)
          for (int x = lo[0]; x <= hi[0]; ++x)
            sub[static_cast<std::size_t>(x | (y << 1) | (z << 2))].push_back(c);
    };
    for (const CutLink& c : cutsOnBoundary) distribute(c);
    for (std::size_t i = before; i < found.size(); ++i) distribute(found[i]);
    return sub;
  }
};

}  // namespace subdivision_detail
}  // namespace voxcut
