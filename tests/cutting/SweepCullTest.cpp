// The culling bounds the length of links per element (cutting/SweepCull.h): an element
// stretched far out of shape costs work only where a sweep passes near it, and the links it
// stretches across its neighbours are all still found.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "voxcut/core/Parallel.h"
#include "voxcut/cutting/CutStep.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

VoxelGrid model(const std::string& name, int resolution) {
  VoxelizeParams p;
  p.resolution.resolution = resolution;
  return voxelize(loadModel(name).materials, p);
}

// The connected links of the grid that `sweep` crosses, by brute force over every link.
std::vector<std::uint64_t> crossedLinks(const CutBody& b, const BladeSweep& sweep) {
  const VoxelGrid& g = b.grid;
  std::vector<std::uint64_t> out;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a) {
      if (!g.occupied(v) || !g.hasLink(v, a) || !g.connected(v, a)) continue;
      const std::size_t w = v + g.stride(a);
      if (intersectSegment(sweep, b.deformation.voxelPosition(v), b.deformation.voxelPosition(w), v,
                           w))
        out.push_back(VoxelGrid::linkId(v, a));
    }
  return out;
}

std::vector<std::uint64_t> linksOf(const CutStepResult& r) {
  std::vector<std::uint64_t> out;
  for (const LinkCut& lc : r.cuts) out.push_back(lc.link);
  return out;
}

// The bounding box of the occupied voxels' current positions.
Eigen::AlignedBox3d voxelBox(const CutBody& b) {
  Eigen::AlignedBox3d box;
  for (std::size_t v = 0; v < b.grid.voxelCount(); ++v)
    if (b.grid.occupied(v)) box.extend(b.deformation.voxelPosition(v));
  return box;
}

// The height (rest y, metres) of the boundary between elements nearest to `y`: the bottom face
// of a start-level element, which every element lies wholly above or below.
double elementSeam(const CutBody& b, double y) {
  const DeformationOctree& d = b.deformation;
  int top = 0;
  for (std::uint32_t e = 0; e < d.elementCount(); ++e) top = std::max(top, d.element(e).level);
  double best = std::numeric_limits<double>::quiet_NaN();
  for (std::uint32_t e = 0; e < d.elementCount(); ++e) {
    if (d.element(e).level != top) continue;
    const double seam = d.positions()[d.element(e).nodes[0]].y();
    if (!(std::abs(seam - y) >= std::abs(best - y))) best = seam;
  }
  return best;
}

// The body with everything above height `seam` stretched `factor`-fold upwards: voxel steps
// along y in the elements above it are `factor` voxels long; below it nothing moves.
CutBody stretchedAbove(CutBody b, double seam, double factor) {
  for (Vec3d& x : b.deformation.positions())
    if (x.y() > seam) x.y() = seam + factor * (x.y() - seam);
  b.deformation.updateHangingNodes();
  return b;
}

// A blade across the middle of `box` along x (60 % of its width), level but for a tilt of a
// tenth of a voxel, at height y, moving `move` voxels along z from the middle.
BladeSweep levelSweep(const Eigen::AlignedBox3d& box, double y, double h, double move,
                      std::uint64_t frame) {
  const Vec3d c(box.center().x(), y, box.center().z());
  const Vec3d half(0.3 * box.sizes().x(), 0.05 * h, 0.0);
  const Vec3d m(0.2 * h, 0.0, move * h);
  return makeSweep({c - half, c + half}, {c - half + m, c + half + m}, frame);
}

TEST(SweepCull, AStretchedRegionCostsNothingWhereTheBladeIsNot) {
  const VoxelGrid g = model("bunny", 64);
  const double h = g.voxelSize();
  for (const bool octree : {false, true}) {
    CutBodyParams p;
    p.useOctree = octree;
    const CutBody plain = makeCutBody(g, p);
    const Eigen::AlignedBox3d box = voxelBox(plain);
    // The upper part stretched tenfold (its links up to ten voxels long); the blades pass
    // through and beside the lower part, more than ten voxels from it.
    const double seam = elementSeam(plain, box.min().y() + 0.65 * box.sizes().y());
    const double low = box.min().y() + 0.25 * box.sizes().y();
    ASSERT_GT(seam - low, 15.0 * h);
    const CutBody stretched = stretchedAbove(plain, seam, 10.0);

    // Through the lower part: the same links as without the stretch, for the same work.
    const BladeSweep through = levelSweep(box, low, h, 2.0, 3);
    CutBody a = plain, b = stretched;
    const CutStepResult r0 = cutStep(a, through), r1 = cutStep(b, through);
    const std::vector<std::uint64_t> expected = crossedLinks(plain, through);
    ASSERT_GT(expected.size(), 20u);
    EXPECT_EQ(linksOf(r0), expected);
    EXPECT_EQ(linksOf(r1), expected);
    EXPECT_GT(r0.positionedVoxels, 0u);
    EXPECT_LE(r1.positionedVoxels, 2 * r0.positionedVoxels) << (octree ? "octree" : "baseline");
    EXPECT_LE(r1.testedLinks, 2 * r0.testedLinks) << (octree ? "octree" : "baseline");

    // Beside the lower part, three voxels clear of it: nothing cut, nothing tested, with and
    // without the stretch.
    const Vec3d at(box.min().x() - 3.0 * h, low, box.center().z());
    const Vec3d half(0.0, 0.1 * box.sizes().y(), 0.0), move(-0.5 * h, 0.0, 3.0 * h);
    const BladeSweep beside = makeSweep({at - half, at + half}, {at - half + move, at + half + move}, 5);
    CutBody c = plain, d = stretched;
    const CutStepResult e0 = cutStep(c, beside), e1 = cutStep(d, beside);
    EXPECT_TRUE(e0.cuts.empty());
    EXPECT_TRUE(e1.cuts.empty());
    EXPECT_LE(e1.positionedVoxels, 2 * e0.positionedVoxels) << (octree ? "octree" : "baseline");
    EXPECT_LE(e1.testedLinks, 2 * e0.testedLinks) << (octree ? "octree" : "baseline");
  }
}

// Links from an unstretched element into a stretched one are ten times longer than those of
// the lower element: the blade crosses them far from their low end, beyond the lower element's
// reach, and they are found from their high end.
TEST(SweepCull, LinksStretchedAcrossAnElementSeamAreAllFound) {
  const VoxelGrid g = model("bunny", 64);
  const double h = g.voxelSize();
  for (const bool octree : {false, true}) {
    CutBodyParams p;
    p.useOctree = octree;
    const CutBody plain = makeCutBody(g, p);
    const Eigen::AlignedBox3d box = voxelBox(plain);
    const double seam = elementSeam(plain, box.center().y());
    const CutBody stretched = stretchedAbove(plain, seam, 10.0);
    // The links across the seam run from half a voxel below it to five voxels above it.
    const BladeSweep sweep = levelSweep(box, seam + 4.0 * h, h, 3.0, 7);
    const std::vector<std::uint64_t> expected = crossedLinks(stretched, sweep);
    ASSERT_GT(expected.size(), 20u);
    std::uint64_t hashes[2];
    for (int threads : {1, 2}) {
      ThreadLimit limit(threads);
      CutBody b = stretched;
      const CutStepResult r = cutStep(b, sweep);
      EXPECT_EQ(linksOf(r), expected) << (octree ? "octree" : "baseline") << ", " << threads;
      hashes[threads - 1] = cutSetHash(r.cuts);
    }
    EXPECT_EQ(hashes[0], hashes[1]);
  }
}

}  // namespace
}  // namespace voxcut
