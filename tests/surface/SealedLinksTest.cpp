// Cuts that disconnect links inside material without letting it come apart: a slit of one or a
// few links, slivers between close blade passes, passes crossing earlier cuts, strokes stopping
// inside. Their two sheets would share every vertex and enclose nothing; the surface must stay
// closed and 2-manifold, equal to a rebuild, and every piece of it must enclose material.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "CanonicalMesh.h"
#include "RandomGrids.h"
#include "SurfaceComponents.h"
#include "voxcut/cutting/CutStep.h"
#include "voxcut/cutting/Fragments.h"
#include "voxcut/surface/ContouredSurface.h"
#include "voxcut/surface/DualContour.h"
#include "voxcut/voxel/BuiltinModels.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

using test::canonical;
using test::randomHermite;
using test::surfaceComponents;

// A cube of material [2, n-3]^3 in an n^3 grid of unit voxels, connected inside; its boundary
// links carry the cube's faces as Hermite data.
VoxelGrid solidBlock(int n) {
  VoxelGrid g(Index3{n, n, n}, Vec3d::Zero(), 1.0);
  g.setMaterialNames({"a"});
  auto inside = [&](const Index3& c) {
    return c.x >= 2 && c.y >= 2 && c.z >= 2 && c.x <= n - 3 && c.y <= n - 3 && c.z <= n - 3;
  };
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    if (inside(g.coord(v))) g.setMaterial(v, 1);
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a) {
      if (!g.hasLink(v, a)) continue;
      const bool o0 = g.occupied(v), o1 = g.occupied(v + g.stride(a));
      g.setConnected(v, a, o0 && o1);
      if (o0 != o1) {
        Hermite h;
        h.n[a] = 1.0f;
        g.hermite().set(VoxelGrid::linkId(v, a), h);
      }
    }
  return g;
}

// Disconnects `links` with random cut data.
void cut(VoxelGrid& g, const std::vector<std::uint64_t>& links, std::mt19937& rng) {
  for (const std::uint64_t id : links) {
    g.setConnected(static_cast<std::size_t>(id / 3), static_cast<int>(id % 3), false);
    g.hermite().set(id, randomHermite(static_cast<int>(id % 3), rng));
  }
}

// Closed, 2-manifold, equal to a full rebuild, and every component encloses material: no
// component of (nearly) zero or negative volume, none whose vertices all coincide.
void expectSoundSurface(const ContouredSurface& s, const VoxelGrid& g, const std::string& what) {
  const SurfaceMesh m = s.mesh();
  const SurfaceTopology t = surfaceTopology(m);
  ASSERT_TRUE(t.closed) << what;
  ASSERT_TRUE(t.manifold) << what;
  ASSERT_TRUE(canonical(m) == canonical(dualContour(g))) << what;
  int degenerate = 0, flat = 0;
  for (const test::SurfaceComponent& c : surfaceComponents(m, g.voxelSize())) {
    if (c.extent < 1e-9) ++degenerate;
    if (c.volume < 1e-3) ++flat;
  }
  EXPECT_EQ(degenerate, 0) << what << ": components whose vertices all coincide";
  EXPECT_EQ(flat, 0) << what << ": components enclosing no material";
}

std::uint64_t link(const VoxelGrid& g, int x, int y, int z, int a) {
  return VoxelGrid::linkId(g.index(x, y, z), a);
}

// Slits of one and a few links inside a block, alone and beside each other: none lets the
// material come apart, so none may add surface; the block's surface stays what it was.
TEST(SealedLinks, SlitsInsideMaterialAddNoSurface) {
  std::mt19937 rng(1);
  VoxelGrid g = solidBlock(16);
  ContouredSurface s = ContouredSurface::build(g);
  const test::Canonical uncut = canonical(s.mesh());
  const std::vector<std::vector<std::uint64_t>> slits = {
      {link(g, 5, 5, 5, 0)},                                                // one link
      {link(g, 9, 5, 5, 1), link(g, 9, 6, 5, 1), link(g, 9, 7, 5, 1)},      // a row, end to end
      {link(g, 5, 9, 5, 2), link(g, 6, 9, 5, 2), link(g, 7, 9, 5, 2)},      // a row, side by side
      {link(g, 5, 5, 9, 0), link(g, 5, 6, 9, 0), link(g, 5, 5, 10, 0)},     // an L in a plane
      {link(g, 10, 5, 9, 0), link(g, 11, 5, 9, 2), link(g, 11, 5, 10, 0)},  // a staircase
  };
  for (std::size_t k = 0; k < slits.size(); ++k) {
    cut(g, slits[k], rng);
    (void)s.update(g, slits[k]);
    expectSoundSurface(s, g, "slit " + std::to_string(k));
    if (HasFatalFailure()) return;
    EXPECT_TRUE(canonical(s.mesh()) == uncut) << "slit " << k;
  }
}

// Slits whose two sides part at some dual cell (a 2x2 square: its middle; three links from
// one voxel: that voxel's corner) have a vertex of their own on each side there, in different
// voxels, so they can open: they keep their surface, flat in the rest frame. Closing a link
// seals what is left of them.
TEST(SealedLinks, SlitsThatCanOpenKeepTheirSurface) {
  std::mt19937 rng(2);
  VoxelGrid g = solidBlock(16);
  ContouredSurface s = ContouredSurface::build(g);
  const test::Canonical uncut = canonical(s.mesh());
  const std::vector<std::vector<std::uint64_t>> slits = {
      {link(g, 6, 6, 6, 0), link(g, 6, 7, 6, 0), link(g, 6, 6, 7, 0), link(g, 6, 7, 7, 0)},
      {link(g, 9, 9, 9, 0), link(g, 9, 9, 9, 1), link(g, 9, 9, 9, 2)}};
  for (std::size_t k = 0; k < slits.size(); ++k) {
    cut(g, slits[k], rng);
    (void)s.update(g, slits[k]);
    const SurfaceMesh m = s.mesh();
    const SurfaceTopology t = surfaceTopology(m);
    ASSERT_TRUE(t.closed && t.manifold) << "slit " << k;
    ASSERT_TRUE(canonical(m) == canonical(dualContour(g))) << "slit " << k;
    ASSERT_EQ(t.pieces, static_cast<int>(k) + 2);
    // Where the sides part, a vertex on each side at one point, embedded in different voxels.
    int pairs = 0;
    for (std::size_t i = 0; i < m.positions.size(); ++i)
      for (std::size_t j = i + 1; j < m.positions.size(); ++j)
        if ((m.positions[i] - m.positions[j]).norm() < 1e-12 &&
            m.vertexVoxel[i] != m.vertexVoxel[j])
          ++pairs;
    EXPECT_EQ(pairs, static_cast<int>(k) + 1) << "slit " << k;
    for (const test::SurfaceComponent& c : surfaceComponents(m, g.voxelSize()))
      EXPECT_GT(c.extent, 0.5) << "slit " << k;
  }
  for (std::size_t k = 0; k < slits.size(); ++k) {
    const std::uint64_t id = slits[k].back();
    g.setConnected(static_cast<std::size_t>(id / 3), static_cast<int>(id % 3), true);
    g.hermite().erase(id);
    (void)s.update(g, {id});
    ASSERT_TRUE(canonical(s.mesh()) == canonical(dualContour(g))) << "slit " << k;
  }
  expectSoundSurface(s, g, "slits less one link each");
  EXPECT_TRUE(canonical(s.mesh()) == uncut);
}

// A blade stroke over `frames` frames from pose `from` to pose `to`, as a world cuts: each
// frame's links, small fragments healed, then the surface updated.
void stroke(CutBody& body, ContouredSurface& s, const BladePose& from, const BladePose& to,
            int frames, std::uint64_t& frame) {
  BladePose prev = from;
  for (int f = 1; f <= frames; ++f) {
    const double t = static_cast<double>(f) / frames;
    const BladePose next{from.a + t * (to.a - from.a), from.b + t * (to.b - from.b)};
    CutStepResult r = cutStep(body, makeSweep(prev, next, frame++), false);
    (void)healSmallFragments(body.grid, r.cuts, 8);
    std::vector<std::uint64_t> links;
    for (const LinkCut& c : r.cuts) links.push_back(c.link);
    (void)s.update(body.grid, links);
    prev = next;
  }
}

// Many strokes close together and crossing each other on a box and a sphere: parallel passes
// a fraction of a voxel apart, passes across them, strokes stopping inside, shallow dips.
TEST(SealedLinks, SliverCutsLeaveEveryComponentEnclosingMaterial) {
  VoxelizeParams vp;
  vp.resolution.resolution = 26;
  const std::vector<VoxelGrid> models = {voxelize({{"b", makeBox(Vec3d(0.1, 0.08, 0.09))}}, vp),
                                         voxelize({{"s", makeSphere(0.05, 4)}}, vp)};
  for (std::size_t mi = 0; mi < models.size(); ++mi) {
    CutBodyParams cp;
    cp.useOctree = false;
    CutBody body = makeCutBody(models[mi], cp, false);
    ContouredSurface s = ContouredSurface::build(body.grid);
    const VoxelGrid& g = body.grid;
    const double h = g.voxelSize();
    Eigen::AlignedBox3d box;
    for (std::size_t v = 0; v < g.voxelCount(); ++v)
      if (g.occupied(v)) box.extend(g.position(v));
    const Vec3d lo = box.min(), hi = box.max(), size = hi - lo;
    std::mt19937_64 rng(77 + mi);
    auto uniform = [&](double a, double b) {
      return a + (b - a) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
    };
    std::uint64_t frame = 0;
    for (int k = 0; k < 36; ++k) {
      // Blades from above, leaning a little; every third across the others; passes in groups
      // of three, a fraction of a voxel apart.
      const bool across = k % 3 == 2;
      const int along = across ? 0 : 2, side = across ? 2 : 0;
      const double offset = lo[side] + uniform(0.2, 0.8) * size[side] + (k % 3) * 0.37 * h;
      const double depth = hi.y() - uniform(0.05, 0.8) * size.y();
      const double start = lo[along] + uniform(-0.2, 0.5) * size[along];
      const double length = uniform(0.1, 0.9) * size[along];
      Vec3d a0 = Vec3d::Zero();
      a0[side] = offset;
      a0[along] = start;
      a0.y() = depth;
      Vec3d lean = Vec3d::UnitY();
      lean[side] += uniform(-0.3, 0.3);
      lean[along] += uniform(-0.3, 0.3);
      const Vec3d b0 = a0 + lean.normalized() * size.y();
      Vec3d move = Vec3d::Zero();
      move[along] = length;
      move.y() = uniform(-0.1, 0.1) * size.y();
      stroke(body, s, {a0, b0}, {a0 + move, b0 + move}, 4, frame);
      const std::string what = "model " + std::to_string(mi) + " stroke " + std::to_string(k);
      if (k % 6 == 5) {
        expectSoundSurface(s, g, what);
        if (HasFatalFailure()) return;
      }
    }
  }
}

}  // namespace
}  // namespace voxcut
