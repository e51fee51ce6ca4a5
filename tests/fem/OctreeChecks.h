#pragma once
// Invariant checks of a deformation octree, shared by the fem tests.

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <vector>

#include "voxcut/fem/DeformationOctree.h"
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

/// Every structural invariant the brief lists, plus rest-position reproduction.
inline void expectOctreeInvariants(const VoxelGrid& grid, const DeformationOctree& oc,
                                   int startLevel) {
  const auto& els = oc.elements();
  const double scale = std::max(1.0, oc.restVoxelBounds().diagonal().norm() + oc.origin().norm());
  // Voxels: each occupied voxel owned by exactly one element that covers it.
  std::vector<std::uint8_t> cover(grid.voxelCount(), 0);
  std::vector<std::size_t> occupiedIn(els.size(), 0);
  for (std::size_t e = 0; e < els.size(); ++e) {
    const Index3 f = els[e].firstVoxel();
    const int s = els[e].size();
    for (int z = f.z; z < std::min(f.z + s, grid.dims().z); ++z)
      for (int y = f.y; y < std::min(f.y + s, grid.dims().y); ++y)
        for (int x = f.x; x < std::min(f.x + s, grid.dims().x); ++x) {
          const std::size_t v = grid.index(x, y, z);
          ASSERT_EQ(cover[v], 0) << "elements overlap at voxel " << v;
          cover[v] = 1;
          if (grid.occupied(v)) {
            ++occupiedIn[e];
            ASSERT_EQ(oc.owner(v), e);
          }
        }
    // Elements above the start level are full.
    if (els[e].level > startLevel) {
      ASSERT_LE(f.x + s, grid.dims().x);
      ASSERT_LE(f.y + s, grid.dims().y);
      ASSERT_LE(f.z + s, grid.dims().z);
      ASSERT_EQ(occupiedIn[e], static_cast<std::size_t>(s) * s * s)
          << "element " << e << " not full";
    }
    ASSERT_GT(occupiedIn[e], 0u) << "element " << e << " holds no voxel";
    ASSERT_GE(els[e].level, startLevel);
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
    ASSERT_LE((oc.voxelPosition(v) - grid.position(v)).norm(), 1e-12 * scale) << "voxel " << v;
  }
  EXPECT_EQ(occupied, oc.occupiedVoxelCount());
  // Nodes: 8 distinct corners at the right node-grid points, unique coordinates.
  std::map<std::array<int, 3>, std::uint32_t> byCoord;
  for (std::uint32_t n = 0; n < oc.nodeCount(); ++n) {
    const Index3 c = oc.nodeCoord(n);
    ASSERT_TRUE(byCoord.emplace(std::array<int, 3>{c.x, c.y, c.z}, n).second) << "duplicate node";
    ASSERT_LE((oc.restPositions()[n] - oc.nodeGridPosition(c)).norm(), 1e-12 * scale);
  }
  for (const auto& e : els) {
    const Index3 f = e.firstVoxel();
    for (int c = 0; c < 8; ++c) {
      const Index3 want{f.x + (c & 1) * e.size(), f.y + ((c >> 1) & 1) * e.size(),
                        f.z + ((c >> 2) & 1) * e.size()};
      ASSERT_EQ(oc.nodeCoord(e.nodes[static_cast<std::size_t>(c)]), want);
    }
  }
  // 2:1 rule over vertex adjacency (brute force).
  for (std::size_t a = 0; a < els.size(); ++a)
    for (std::size_t b = a + 1; b < els.size(); ++b)
      if (touches(els[a], els[b])) {
        ASSERT_LE(std::abs(els[a].level - els[b].level), 1) << "elements " << a << ", " << b;
      }
  // Hanging nodes: exactly the nodes on an element's boundary that are not its corners.
  std::vector<int> expectedHanging(oc.nodeCount(), 0);
  for (const auto& e : els)
    for (std::uint32_t n = 0; n < oc.nodeCount(); ++n) {
      const int k = boundaryKind(e, oc.nodeCoord(n));
      ASSERT_NE(k, 0) << "node inside an element";
      if (k == 1 || k == 2) expectedHanging[n] = 1;
    }
  std::vector<int> position(oc.nodeCount(), -1);
  for (std::size_t i = 0; i < oc.hangingNodes().size(); ++i) {
    const HangingNode& h = oc.hangingNodes()[i];
    position[h.node] = static_cast<int>(i);
    ASSERT_TRUE(h.masterCount == 2 || h.masterCount == 4);
    Index3 sum{0, 0, 0};
    Vec3d rest = Vec3d::Zero();
    for (int m = 0; m < h.masterCount; ++m) {
      const Index3 c = oc.nodeCoord(h.masters[static_cast<std::size_t>(m)]);
      sum = {sum.x + c.x, sum.y + c.y, sum.z + c.z};
      rest += oc.restPositions()[h.masters[static_cast<std::size_t>(m)]];
      // Masters hanging on a coarser element are resolved earlier.
      if (oc.isHanging(h.masters[static_cast<std::size_t>(m)])) {
        ASSERT_LT(position[h.masters[static_cast<std::size_t>(m)]], static_cast<int>(i)) << "order";
      }
    }
    const Index3 c = oc.nodeCoord(h.node);
    ASSERT_EQ((Index3{sum.x / h.masterCount, sum.y / h.masterCount, sum.z / h.masterCount}), c);
    ASSERT_EQ(sum.x % h.masterCount + sum.y % h.masterCount + sum.z % h.masterCount, 0);
    ASSERT_LE((rest / h.masterCount - oc.restPositions()[h.node]).norm(), 1e-12 * scale);
  }
  std::size_t expectedCount = 0;
  for (std::uint32_t n = 0; n < oc.nodeCount(); ++n) {
    expectedCount += expectedHanging[n];
    ASSERT_EQ(oc.isHanging(n), expectedHanging[n] == 1) << "node " << n;
  }
  EXPECT_EQ(oc.hangingNodeCount(), expectedCount);
}

/// Every element whose boundary holds a hanging node interpolates that node's position there
/// (positions are continuous across fine/coarse faces). Brute force over elements x nodes.
inline void expectConforming(const DeformationOctree& oc, double tol) {
  for (std::uint32_t e = 0; e < oc.elementCount(); ++e) {
    const OctreeElement& el = oc.element(e);
    for (const HangingNode& h : oc.hangingNodes()) {
      const Index3 p = oc.nodeCoord(h.node);
      const int k = boundaryKind(el, p);
      if (k != 1 && k != 2) continue;
      const Index3 f = el.firstVoxel();
      const Vec3d t = Vec3d(p.x - f.x, p.y - f.y, p.z - f.z) / el.size();
      ASSERT_LE((oc.pointInElement(e, t) - oc.positions()[h.node]).norm(), tol)
          << "element " << e << " node " << h.node;
    }
  }
}

}  // namespace voxcut::test
