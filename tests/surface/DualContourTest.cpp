#include <gtest/gtest.h>

#include <random>

#include "RandomGrids.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/surface/DualCell.h"
#include "voxcut/surface/DualContour.h"
#include "voxcut/voxel/BuiltinModels.h"
#include "voxcut/voxel/Pieces.h"
#include "voxcut/voxel/PlaneCut.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

using test::randomCutGrid;

TEST(DualCell, PatchesAreConsistentAndCoverEveryIncidence) {
  // Exhaustive over occupancy; random connectivity of occupied edges.
  std::mt19937 rng(3);
  for (int occ = 1; occ < 256; ++occ)
    for (int trial = 0; trial < 16; ++trial) {
      DualCell cell;
      cell.occupied = static_cast<std::uint8_t>(occ);
      for (int e = 0; e < 12; ++e) {
        const bool both = ((occ >> edgeCorner(e, 0)) & 1) && ((occ >> edgeCorner(e, 1)) & 1);
        if (both && (rng() & 1))
          cell.connected = static_cast<std::uint16_t>(cell.connected | (1u << e));
      }
      std::array<std::int8_t, 24> patch;
      std::array<std::int8_t, 8> comp;
      // Across every face, a solid cell (so two-run faces whose runs meet in this cell count
      // as rings) or an empty one.
      DualCell solid;
      solid.occupied = 0xff;
      solid.connected = 0xfff;
      const int np =
          dualCellPatches(cell, patch, [&](int) { return trial % 2 ? solid : DualCell{}; });
      dualCellComponents(cell, comp);
      std::vector<int> size(np, 0);
      for (int s = 0; s < 24; ++s) {
        const int e = s / 2, corner = edgeCorner(e, s % 2);
        const bool incidence = !((cell.connected >> e) & 1) && ((occ >> corner) & 1);
        ASSERT_EQ(patch[s] >= 0, incidence);
        if (patch[s] >= 0) ++size[patch[s]];
      }
      // Each patch is a cycle through at least 3 incidences, all in one component, except the
      // tip of a crack: a cut edge seen from both of its ends, which stay connected around it.
      for (int p = 0; p < np; ++p) {
        if (size[p] == 2) {
          int first = -1;
          for (int s = 0; s < 24; ++s)
            if (patch[s] == p) {
              if (first < 0)
                first = s;
              else
                ASSERT_EQ(s / 2, first / 2);
            }
        } else {
          ASSERT_GE(size[p], 3);
        }
        int c = -1;
        for (int s = 0; s < 24; ++s)
          if (patch[s] == p) {
            const int cc = comp[edgeCorner(s / 2, s % 2)];
            if (c < 0) c = cc;
            ASSERT_EQ(c, cc);
          }
      }
      ASSERT_EQ(np > 0, cell.hasSurface());
    }
}

TEST(DualContour, SingleVoxelIsAClosedOctahedronLikeShell) {
  VoxelGrid g(Index3{3, 3, 3}, Vec3d::Zero(), 1.0);
  g.setMaterialNames({"a"});
  const std::size_t v = g.index(1, 1, 1);
  g.setMaterial(v, 1);
  for (std::size_t u = 0; u < g.voxelCount(); ++u)
    for (int a = 0; a < 3; ++a) {
      const Index3 c = g.coord(u);
      if (c[a] + 1 >= 3) continue;
      if (u == v || u + g.stride(a) == v)
        g.hermite().set(
            VoxelGrid::linkId(u, a),
            Hermite{0.5f, {a == 0 ? 1.f : 0.f, a == 1 ? 1.f : 0.f, a == 2 ? 1.f : 0.f}});
    }
  const SurfaceMesh m = dualContour(g);
  EXPECT_EQ(m.positions.size(), 8u);
  EXPECT_EQ(m.triangles.size(), 12u);
  const SurfaceTopology t = surfaceTopology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.manifold);
  EXPECT_EQ(t.pieces, 1);
  EXPECT_EQ(t.genusSum, 0);
  // Vertices are the corners of the cube [0.5, 1.5]^3 and normals point outward.
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(std::abs(m.positions[i][a] - 1.0), 0.5, 1e-12);
    EXPECT_GT(m.normals[i].dot(m.positions[i] - Vec3d(1, 1, 1)), 0.0);
    EXPECT_EQ(m.vertexVoxel[i], v);
  }
}

TEST(DualContour, RandomLinkStatesAlwaysGiveClosedManifoldSurfaces) {
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const double pOcc = 0.3 + 0.05 * (seed % 8);
    const double pConn = (seed % 4) / 3.0;
    const VoxelGrid g = randomCutGrid(12, pOcc, pConn, seed);
    const SurfaceMesh m = dualContour(g);
    const SurfaceTopology t = surfaceTopology(m);
    ASSERT_TRUE(t.closed) << "seed " << seed;
    ASSERT_TRUE(t.manifold) << "seed " << seed;
    // Every vertex stays inside its dual cell: within the grid's cell range.
    for (const Vec3d& p : m.positions)
      for (int a = 0; a < 3; ++a) {
        ASSERT_GE(p[a], -1e-9);
        ASSERT_LE(p[a], 11 + 1e-9);
      }
  }
}

TEST(DualContour, SphereIsOneGenusZeroPieceWithOutwardNormals) {
  VoxelizeParams p;
  p.resolution.resolution = 48;
  const VoxelGrid g = voxelize({{"s", makeSphere(0.05, 4)}}, p);
  const SurfaceMesh m = dualContour(g);
  const SurfaceTopology t = surfaceTopology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.manifold);
  EXPECT_EQ(t.pieces, 1);
  EXPECT_EQ(m.triangles.size(), 2 * m.positions.size() - 4);
  double maxErr = 0;
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    maxErr = std::max(maxErr, std::abs(m.positions[i].norm() - 0.05));
    EXPECT_GT(m.normals[i].dot(m.positions[i].normalized()), 0.8);
  }
  EXPECT_LT(maxErr, 0.1 * g.voxelSize());
  // Enclosed volume of the contour matches the sphere.
  double vol = 0;
  for (const auto& tr : m.triangles)
    vol += m.positions[tr[0]].dot(m.positions[tr[1]].cross(m.positions[tr[2]])) / 6.0;
  EXPECT_NEAR(vol / (4.0 / 3.0 * 3.14159265358979 * 0.05 * 0.05 * 0.05), 1.0, 0.01);
}

TEST(DualContour, BoxCornersAreSharp) {
  VoxelizeParams p;
  p.resolution.resolution = 27;  // 25 voxels across 0.1: faces half a voxel from centres
  const VoxelGrid g = voxelize({{"b", makeBox(Vec3d(0.1, 0.1, 0.1))}}, p);
  const SurfaceMesh m = dualContour(g);
  // The QEF puts corner vertices on the box corners.
  int corners = 0;
  for (const Vec3d& q : m.positions)
    if ((q.cwiseAbs() - Vec3d::Constant(0.05)).cwiseAbs().maxCoeff() < 1e-6) ++corners;
  EXPECT_EQ(corners, 8);
  for (const Vec3d& q : m.positions) EXPECT_NEAR(q.cwiseAbs().maxCoeff(), 0.05, 1e-6);
}

TEST(DualContour, PlaneCutsSeparatePiecesAndCracksStayClosed) {
  VoxelizeParams p;
  p.resolution.resolution = 40;
  VoxelGrid g = voxelize({{"s", makeSphere(0.05, 4)}}, p);
  VoxelGrid crack = g;
  EXPECT_GT(cutWithPlane(g, {Vec3d(0, 1, 0), 0.001}), 100u);
  EXPECT_EQ(findPieces(g).count, 2);
  SurfaceMesh m = dualContour(g);
  SurfaceTopology t = surfaceTopology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.manifold);
  EXPECT_EQ(t.pieces, 2);
  EXPECT_EQ(t.genusSum, 0);
  // The two cut faces are coincident sheets of opposite orientation: the volumes add up.
  double vol = 0;
  for (const auto& tr : m.triangles)
    vol += m.positions[tr[0]].dot(m.positions[tr[1]].cross(m.positions[tr[2]])) / 6.0;
  EXPECT_NEAR(vol / (4.0 / 3.0 * 3.14159265358979 * 0.05 * 0.05 * 0.05), 1.0, 0.02);

  // A crack: cut only the links of the half space x > 0 (the plane's links with x > 0).
  std::size_t cut = 0;
  for (std::size_t v = 0; v < crack.voxelCount(); ++v) {
    if (!crack.occupied(v) || crack.position(v).x() <= 0) continue;
    if (!crack.connected(v, 1)) continue;
    const double y0 = crack.position(v).y() - 0.001, y1 = y0 + crack.voxelSize();
    if ((y0 < 0) == (y1 < 0)) continue;
    crack.setConnected(v, 1, false);
    crack.hermite().set(VoxelGrid::linkId(v, 1),
                        Hermite{static_cast<float>(-y0 / crack.voxelSize()), {0, 1, 0}});
    ++cut;
  }
  ASSERT_GT(cut, 10u);
  EXPECT_EQ(findPieces(crack).count, 1);
  t = surfaceTopology(dualContour(crack));
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.manifold);
  EXPECT_EQ(t.pieces, 1);
}

TEST(DualContour, ResultDoesNotDependOnThreadCount) {
  const VoxelGrid g = randomCutGrid(20, 0.6, 0.7, 99);
  SurfaceMesh a, b;
  {
    ThreadLimit one(1);
    a = dualContour(g);
  }
  {
    ThreadLimit two(2);
    b = dualContour(g);
  }
  ASSERT_EQ(a.positions, b.positions);
  ASSERT_EQ(a.triangles, b.triangles);
  ASSERT_EQ(a.vertexVoxel, b.vertexVoxel);
  const SurfaceMesh s = dualContour(g, {.qefThreshold = 0.1, .threaded = false});
  ASSERT_EQ(a.positions, s.positions);
  ASSERT_EQ(a.triangles, s.triangles);
}

}  // namespace
}  // namespace voxcut
