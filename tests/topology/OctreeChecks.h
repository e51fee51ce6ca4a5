#pragma once
// Invariant checks of a deformation octree, and a blade's cuts frame by frame, shared by the
// fem tests.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut::test {

/// Closed node-grid box of an element: [first, first + size] per axis.
inline bool touches(const OctreeElement& a, const OctreeElement& b) {
  const Index3 fa = a.firstVoxel(), fb = b.firstVoxel();
  for (int k = 0; k < 3; ++k)
    if (fa[k] > fb[k] + b.size() || fb[k] > fa[k] + a.size()) return false;
  return true;
}

/// Node-grid point p relative to element e: -1 outside its closed box, 0 interior,
/// 1 on a face (interior of it), 2 on an edge (interior of it), 3 a corner.
inline int boundaryKind(const OctreeElement& e, const Index3& p) {
  const Index3 f = e.firstVoxel();
  int onBoundary = 0;
  for (int k = 0; k < 3; ++k) {
    if (p[k] < f[k] || p[k] > f[k] + e.size()) return -1;
    onBoundary += (p[k] == f[k] || p[k] == f[k] + e.size());
  }
  return onBoundary;
}

/// Every structural invariant of the layout, plus rest-position reproduction. Elements above
/// startLevel must be full; no element is finer than minLevel (startLevel when negative).
/// With atRest, voxel positions must equal their rest centres.
/// Copies: element copies of one cube own disjoint voxels, each copy's voxels form one
/// connected part (connected links inside the cube) and copies of one cube are not linked
/// to each other inside it; cubes of different leaves do not overlap.
inline void expectOctreeInvariants(const VoxelGrid& grid, const DeformationOctree& oc,
                                   int startLevel, int minLevel = -1, bool atRest = true) {
  if (minLevel < 0)
    minLevel =
        initialFinestLevel(startLevel, -1, std::max({grid.dims().x, grid.dims().y, grid.dims().z}));
  const auto& els = oc.elements();
  const double scale = std::max(1.0, oc.restVoxelBounds().diagonal().norm() + oc.origin().norm());
  // Cubes and their copies.
  std::map<std::array<int, 4>, std::vector<std::uint32_t>> cubes;
  for (std::uint32_t e = 0; e < els.size(); ++e) {
    cubes[{els[e].level, els[e].coord.x, els[e].coord.y, els[e].coord.z}].push_back(e);
    ASSERT_GE(els[e].level, minLevel);
  }
  for (const auto& [key, copies] : cubes) {
    ASSERT_EQ(oc.cubeCopies(key[0], {key[1], key[2], key[3]}), copies) << "cube index";
  }
  std::vector<std::uint8_t> cover(grid.voxelCount(), 0);
  std::vector<std::size_t> occupiedIn(els.size(), 0);
  for (const auto& [key, copies] : cubes) {
    const OctreeElement& el = els[copies.front()];
    const Index3 f = el.firstVoxel();
    const int s = el.size();
    std::size_t occupiedInCube = 0;
    for (int z = f.z; z < std::min(f.z + s, grid.dims().z); ++z)
      for (int y = f.y; y < std::min(f.y + s, grid.dims().y); ++y)
        for (int x = f.x; x < std::min(f.x + s, grid.dims().x); ++x) {
          const std::size_t v = grid.index(x, y, z);
          ASSERT_EQ(cover[v], 0) << "elements overlap at voxel " << v;
          cover[v] = 1;
          if (!grid.occupied(v)) continue;
          ++occupiedInCube;
          const std::uint32_t o = oc.owner(v);
          ASSERT_TRUE(std::find(copies.begin(), copies.end(), o) != copies.end())
              << "voxel " << v << " owned by an element not covering it";
          ++occupiedIn[o];
          // Copies of one cube are not linked inside it.
          for (int a = 0; a < 3; ++a) {
            const Index3 c{x, y, z};
            if (c[a] + 1 >= std::min(f[a] + s, grid.dims()[a]) || !grid.connected(v, a)) continue;
            const std::size_t w = v + grid.stride(a);
            if (grid.occupied(w)) {
              ASSERT_EQ(oc.owner(w), o) << "linked voxels in two copies";
            }
          }
        }
    if (el.level > startLevel) {
      ASSERT_LE(f.x + s, grid.dims().x);
      ASSERT_LE(f.y + s, grid.dims().y);
      ASSERT_LE(f.z + s, grid.dims().z);
      ASSERT_EQ(occupiedInCube, static_cast<std::size_t>(s) * s * s) << "element not full";
    }
    // Each copy's voxels form one connected part.
    for (std::uint32_t e : copies) {
      ASSERT_GT(occupiedIn[e], 0u) << "element " << e << " holds no voxel";
      std::vector<std::size_t> stack, seen;
      for (int z = f.z; z < std::min(f.z + s, grid.dims().z) && stack.empty(); ++z)
        for (int y = f.y; y < std::min(f.y + s, grid.dims().y) && stack.empty(); ++y)
          for (int x = f.x; x < std::min(f.x + s, grid.dims().x) && stack.empty(); ++x)
            if (grid.occupied(grid.index(x, y, z)) && oc.owner(grid.index(x, y, z)) == e)
              stack.push_back(grid.index(x, y, z));
      std::set<std::size_t> visited(stack.begin(), stack.end());
      while (!stack.empty()) {
        const std::size_t v = stack.back();
        stack.pop_back();
        const Index3 c = grid.coord(v);
        for (int a = 0; a < 3; ++a)
          for (int dir : {-1, 1}) {
            Index3 n = c;
            n[a] += dir;
            if (n[a] < f[a] || n[a] >= std::min(f[a] + s, grid.dims()[a])) continue;
            const std::size_t w = grid.index(n);
            const bool linked = dir > 0 ? grid.connected(v, a) : grid.connected(w, a);
            if (!linked || !grid.occupied(w) || oc.owner(w) != e) continue;
            if (visited.insert(w).second) stack.push_back(w);
          }
      }
      ASSERT_EQ(visited.size(), occupiedIn[e]) << "element " << e << " is not one connected part";
    }
  }
  std::size_t occupied = 0;
  for (std::size_t v = 0; v < grid.voxelCount(); ++v) {
    if (!grid.occupied(v)) {
      ASSERT_EQ(oc.owner(v), kNoElement);
      continue;
    }
    ++occupied;
    ASSERT_EQ(cover[v], 1) << "occupied voxel " << v << " not covered";
    const Vec3d t = oc.localCoordinates(v);
    const auto w = oc.weights(v);
    double sum = 0;
    for (double wi : w) {
      ASSERT_GE(wi, 0.0);
      ASSERT_LE(wi, 1.0);
      sum += wi;
    }
    ASSERT_NEAR(sum, 1.0, 1e-15);
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(t[k] > 0 && t[k] < 1);
    if (atRest) {
      ASSERT_LE((oc.voxelPosition(v) - grid.position(v)).norm(), 1e-12 * scale) << "voxel " << v;
    }
  }
  EXPECT_EQ(occupied, oc.occupiedVoxelCount());
  // Nodes: 8 distinct corners at the right node-grid points; every node used.
  std::vector<int> used(oc.nodeCount(), 0);
  for (std::uint32_t n = 0; n < oc.nodeCount(); ++n)
    ASSERT_LE((oc.restPositions()[n] - oc.nodeGridPosition(oc.nodeCoord(n))).norm(), 1e-12 * scale);
  for (const auto& e : els) {
    const Index3 f = e.firstVoxel();
    for (int c = 0; c < 8; ++c) {
      const Index3 want{f.x + (c & 1) * e.size(), f.y + ((c >> 1) & 1) * e.size(),
                        f.z + ((c >> 2) & 1) * e.size()};
      ASSERT_EQ(oc.nodeCoord(e.nodes[static_cast<std::size_t>(c)]), want);
      used[e.nodes[static_cast<std::size_t>(c)]] = 1;
    }
  }
  for (std::uint32_t n = 0; n < oc.nodeCount(); ++n)
    ASSERT_EQ(used[n], 1) << "node " << n << " unused";
  // 2:1 rule over vertex adjacency (brute force over cubes).
  std::vector<std::uint32_t> reps;
  for (const auto& kv : cubes) reps.push_back(kv.second.front());
  for (std::size_t a = 0; a < reps.size(); ++a)
    for (std::size_t b = a + 1; b < reps.size(); ++b)
      if (touches(els[reps[a]], els[reps[b]])) {
        ASSERT_LE(std::abs(els[reps[a]].level - els[reps[b]].level), 1)
            << "elements " << reps[a] << ", " << reps[b];
      }
  // No node inside a cube; a node on a cube's edge or face interior belongs to no copy of it.
  std::set<std::array<int, 3>> nodePoints;
  for (std::uint32_t n = 0; n < oc.nodeCount(); ++n)
    nodePoints.insert({oc.nodeCoord(n).x, oc.nodeCoord(n).y, oc.nodeCoord(n).z});
  for (std::uint32_t r : reps)
    for (const auto& p : nodePoints)
      ASSERT_NE(boundaryKind(els[r], {p[0], p[1], p[2]}), 0) << "node inside an element";
  // Hanging nodes: at the edge midpoint or face centre of their coarse element copy, the mean
  // of its corners there, masters resolved before dependants.
  std::vector<int> position(oc.nodeCount(), -1);
  std::size_t flagged = 0;
  for (std::uint32_t n = 0; n < oc.nodeCount(); ++n) flagged += oc.isHanging(n);
  EXPECT_EQ(flagged, oc.hangingNodeCount());
  for (std::size_t i = 0; i < oc.hangingNodes().size(); ++i) {
    const HangingNode& h = oc.hangingNodes()[i];
    ASSERT_TRUE(oc.isHanging(h.node));
    ASSERT_EQ(position[h.node], -1) << "node hangs twice";
    position[h.node] = static_cast<int>(i);
    ASSERT_TRUE(h.masterCount == 2 || h.masterCount == 4);
    ASSERT_LT(h.element, oc.elementCount());
    const OctreeElement& ce = oc.element(h.element);
    ASSERT_EQ(ce.level, h.coarseLevel);
    const int kind = boundaryKind(ce, oc.nodeCoord(h.node));
    ASSERT_TRUE(kind == 1 || kind == 2);
    ASSERT_EQ(h.masterCount, kind == 1 ? 4 : 2);
    Index3 sum{0, 0, 0};
    Vec3d rest = Vec3d::Zero();
    for (int m = 0; m < h.masterCount; ++m) {
      const std::uint32_t mn = h.masters[static_cast<std::size_t>(m)];
      ASSERT_TRUE(std::find(ce.nodes.begin(), ce.nodes.end(), mn) != ce.nodes.end());
      const Index3 c = oc.nodeCoord(mn);
      sum = {sum.x + c.x, sum.y + c.y, sum.z + c.z};
      rest += oc.restPositions()[mn];
      if (oc.isHanging(mn)) {
        ASSERT_GE(position[mn], 0) << "order";
        ASSERT_LT(position[mn], static_cast<int>(i)) << "order";
      }
    }
    const Index3 c = oc.nodeCoord(h.node);
    ASSERT_EQ((Index3{sum.x / h.masterCount, sum.y / h.masterCount, sum.z / h.masterCount}), c);
    ASSERT_EQ(sum.x % h.masterCount + sum.y % h.masterCount + sum.z % h.masterCount, 0);
    ASSERT_LE((rest / h.masterCount - oc.restPositions()[h.node]).norm(), 1e-12 * scale);
  }
}

/// Every hanging node lies where its coarse element copy's trilinear map puts that point
/// (positions are continuous across fine/coarse faces).
inline void expectConforming(const DeformationOctree& oc, double tol) {
  for (const HangingNode& h : oc.hangingNodes()) {
    const OctreeElement& el = oc.element(h.element);
    const Index3 p = oc.nodeCoord(h.node), f = el.firstVoxel();
    const Vec3d t = Vec3d(p.x - f.x, p.y - f.y, p.z - f.z) / el.size();
    ASSERT_LE((oc.pointInElement(h.element, t) - oc.positions()[h.node]).norm(), tol)
        << "element " << h.element << " node " << h.node;
  }
}

/// For every connected link v-w whose voxels lie in different element copies, the 4 corners
/// of the face between v's and w's cubes, interpolated in v's copy and in w's copy, agree to
/// `tol` (metres): no gap opens where no link was cut.
inline void expectNoGap(const VoxelGrid& grid, const DeformationOctree& oc, double tol) {
  auto at = [&](std::uint32_t e, const Index3& p) {
    const OctreeElement& el = oc.element(e);
    const Index3 f = el.firstVoxel();
    return oc.pointInElement(e, Vec3d(p.x - f.x, p.y - f.y, p.z - f.z) / el.size());
  };
  for (std::size_t v = 0; v < grid.voxelCount(); ++v) {
    if (!grid.occupied(v)) continue;
    const Index3 c = grid.coord(v);
    for (int a = 0; a < 3; ++a) {
      if (!grid.hasLink(v, a) || !grid.connected(v, a)) continue;
      const std::size_t w = v + grid.stride(a);
      if (!grid.occupied(w) || oc.owner(v) == oc.owner(w)) continue;
      const int u = (a + 1) % 3, s = (a + 2) % 3;
      for (int k = 0; k < 4; ++k) {
        Index3 p = c;
        p[a] += 1;
        p[u] += k & 1;
        p[s] += k >> 1;
        ASSERT_LE((at(oc.owner(v), p) - at(oc.owner(w), p)).norm(), tol)
            << "gap at link " << v << " axis " << a;
      }
    }
  }
}

/// Number of components of the elements joined by shared node ids.
inline int nodeConnectedComponents(const DeformationOctree& oc) {
  std::vector<std::uint32_t> parent(oc.nodeCount());
  for (std::uint32_t n = 0; n < parent.size(); ++n) parent[n] = n;
  auto find = [&](std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const OctreeElement& e : oc.elements())
    for (std::uint32_t n : e.nodes) parent[find(n)] = find(e.nodes[0]);
  std::set<std::uint32_t> roots;
  for (const OctreeElement& e : oc.elements()) roots.insert(find(e.nodes[0]));
  return static_cast<int>(roots.size());
}

/// The connected y-links crossed in each of `frames` frames by a horizontal blade at height y
/// (voxel units) spanning x in [x0, x1) and sweeping z from z0 down to z1, like
/// scenes/bunny-ear.json: frame f takes the links whose lower voxel has z in (z(f+1), z(f)].
inline std::vector<std::vector<std::uint64_t>> bladeFrames(const VoxelGrid& g, int y, int x0,
                                                           int x1, double z0, double z1,
                                                           int frames) {
  std::vector<std::vector<std::uint64_t>> out(static_cast<std::size_t>(frames));
  for (int z = 0; z < g.dims().z; ++z)
    for (int x = x0; x < x1; ++x) {
      const std::size_t v = g.index(x, y, z);
      if (!g.connected(v, 1)) continue;
      const double f = (z0 - z) / (z0 - z1) * frames;
      if (f >= 0 && f < frames) out[static_cast<std::size_t>(f)].push_back(VoxelGrid::linkId(v, 1));
    }
  return out;
}

}  // namespace voxcut::test
