#include <gtest/gtest.h>

#include <random>

#include "voxcut/core/Parallel.h"
#include "voxcut/cutting/CutStep.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/sim/SingleFrameCut.h"
#include "voxcut/surface/DualContour.h"
#include "voxcut/topology/CutTopology.h"
#include "voxcut/topology/PrescribedDeformation.h"
#include "voxcut/voxel/Pieces.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

VoxelGrid model(const std::string& name, int resolution) {
  VoxelizeParams p;
  p.resolution.resolution = resolution;
  return voxelize(loadModel(name).materials, p);
}

CutBody body(const VoxelGrid& g, bool octree, Deformation d) {
  CutBodyParams p;
  p.useOctree = octree;
  CutBody b = makeCutBody(g, p);
  applyDeformation(b.deformation, d);
  return b;
}

// A blade longer than the model's diagonal, sweeping right through it along a random
// direction, turning a little on the way (a non-planar bilinear patch).
BladeMotion randomCrossingBlade(const CutBody& b, std::mt19937& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::AlignedBox3d box;
  for (std::size_t v = 0; v < b.grid.voxelCount(); ++v)
    if (b.grid.occupied(v)) box.extend(b.deformation.voxelPosition(v));
  const double diag = box.diagonal().norm();
  const Vec3d c = box.center() + 0.15 * Vec3d(U(rng), U(rng), U(rng)).cwiseProduct(box.sizes());
  const Vec3d dir = Vec3d(U(rng), U(rng), U(rng)).normalized();
  Vec3d move = Vec3d(U(rng), U(rng), U(rng));
  move = (move - move.dot(dir) * dir).normalized();
  const Vec3d dir2 = (dir + 0.2 * Vec3d(U(rng), U(rng), U(rng))).normalized();
  BladeMotion m;
  m.from = {c - move * diag - dir * diag, c - move * diag + dir * diag};
  m.to = {c + move * diag - dir2 * diag, c + move * diag + dir2 * diag};
  return m;
}

TEST(CutStep, OctreeCutsEqualTheBaselineForEveryModelAndDeformation) {
  std::mt19937 rng(5);
  const std::pair<const char*, int> models[] = {{"bunny", 64}, {"liver", 64}, {"starfish", 100}};
  for (const auto& [name, res] : models) {
    const VoxelGrid g = model(name, res);
    for (Deformation d :
         {Deformation::None, Deformation::Rigid, Deformation::Bend, Deformation::Twist}) {
      const CutBody withOctree = body(g, true, d);
      const CutBody baseline = body(g, false, d);
      std::vector<BladeMotion> blades{defaultBladeMotion(withOctree)};
      for (int k = 0; k < 3; ++k) blades.push_back(randomCrossingBlade(withOctree, rng));
      for (std::size_t k = 0; k < blades.size(); ++k) {
        SingleFrameParams sp;
        sp.contour = false;
        const SingleFrameResult o = runSingleFrameCut(withOctree, blades[k], sp);
        const SingleFrameResult b = runSingleFrameCut(baseline, blades[k], sp);
        ASSERT_GT(b.step.cuts.size(), 50u) << name << " blade " << k;
        ASSERT_EQ(o.step.cuts.size(), b.step.cuts.size())
            << name << " " << deformationName(d) << " blade " << k;
        ASSERT_EQ(o.cutHash, b.cutHash) << name << " " << deformationName(d) << " blade " << k;
        EXPECT_LT(o.activeVoxelsBefore, b.activeVoxelsBefore);
        // The grids agree link for link afterwards.
        for (std::size_t v = 0; v < g.voxelCount(); ++v)
          for (int a = 0; a < 3; ++a)
            ASSERT_EQ(o.body.grid.connected(v, a), b.body.grid.connected(v, a));
      }
    }
  }
}

// A blade shorter than the model, moved from a random point to another: its edge and the
// paths of its tips start, end or run inside the model, through octree cubes whose border the
// sweep may not cross at all. Those cubes are split anyway and their traces seeded where the
// boundary crosses them (subdivideCutCubes' SweepBoundary), so the octree still cuts exactly
// what the baseline cuts.
TEST(CutStep, BladeEndingInsideTheModelCutsEqualTheBaseline) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const std::pair<const char*, int> models[] = {{"bunny", 64}, {"liver", 64}, {"starfish", 100}};
  std::size_t reached = 0;
  for (const auto& [name, res] : models) {
    const VoxelGrid g = model(name, res);
    for (Deformation d : {Deformation::None, Deformation::Twist}) {
      const CutBody withOctree = body(g, true, d);
      const CutBody baseline = body(g, false, d);
      Eigen::AlignedBox3d box;
      for (std::size_t v = 0; v < g.voxelCount(); ++v)
        if (g.occupied(v)) box.extend(withOctree.deformation.voxelPosition(v));
      const auto inside = [&] {
        return Vec3d(box.center() + 0.35 * Vec3d(U(rng), U(rng), U(rng)).cwiseProduct(box.sizes()));
      };
      for (int k = 0; k < 4; ++k) {
        const double half = 0.25 * box.sizes().minCoeff() * (1.0 + 0.5 * U(rng));
        const Vec3d c0 = inside(), c1 = inside();
        const Vec3d d0 = Vec3d(U(rng), U(rng), U(rng)).normalized();
        const Vec3d d1 = (d0 + 0.3 * Vec3d(U(rng), U(rng), U(rng))).normalized();
        BladeMotion m;
        m.from = {c0 - half * d0, c0 + half * d0};
        m.to = {c1 - half * d1, c1 + half * d1};
        SingleFrameParams sp;
        sp.contour = false;
        const SingleFrameResult o = runSingleFrameCut(withOctree, m, sp);
        const SingleFrameResult b = runSingleFrameCut(baseline, m, sp);
        ASSERT_EQ(o.step.cuts.size(), b.step.cuts.size())
            << name << " " << deformationName(d) << " blade " << k;
        ASSERT_EQ(o.cutHash, b.cutHash) << name << " " << deformationName(d) << " blade " << k;
        reached += o.step.subdivision.boundaryCubes;
      }
    }
  }
  EXPECT_GT(reached, 0u);  // the case arose
}

// A blade with one tip inside the model and the other 9e5 m away: the sweep's edges inside the
// model are sampled for the subdivision as densely as a short blade's (only their part inside
// the elements' box is), so the octree still cuts exactly what the baseline cuts.
TEST(CutStep, BladeFarLongerThanTheModelCutsEqualTheBaseline) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const VoxelGrid g = model("bunny", 64);
  const CutBody withOctree = body(g, true, Deformation::None);
  const CutBody baseline = body(g, false, Deformation::None);
  Eigen::AlignedBox3d box;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    if (g.occupied(v)) box.extend(withOctree.deformation.voxelPosition(v));
  std::size_t reached = 0;
  int cutting = 0;
  for (int k = 0; k < 6; ++k) {
    const Vec3d c0 = box.center() + 0.3 * Vec3d(U(rng), U(rng), U(rng)).cwiseProduct(box.sizes());
    const Vec3d c1 = box.center() + 0.3 * Vec3d(U(rng), U(rng), U(rng)).cwiseProduct(box.sizes());
    const Vec3d d0 = Vec3d(U(rng), U(rng), U(rng)).normalized();
    const Vec3d d1 = (d0 + 0.3 * Vec3d(U(rng), U(rng), U(rng))).normalized();
    BladeMotion m;
    m.from = {c0, c0 + 9e5 * d0};
    m.to = {c1, c1 + 9e5 * d1};
    SingleFrameParams sp;
    sp.contour = false;
    const SingleFrameResult o = runSingleFrameCut(withOctree, m, sp);
    const SingleFrameResult b = runSingleFrameCut(baseline, m, sp);
    ASSERT_EQ(o.step.cuts.size(), b.step.cuts.size()) << "blade " << k;
    ASSERT_EQ(o.cutHash, b.cutHash) << "blade " << k;
    cutting += !b.step.cuts.empty();
    reached += o.step.subdivision.boundaryCubes;
  }
  EXPECT_GE(cutting, 4);  // most blades reach the material (a tip may sit in a gap)
  EXPECT_GT(reached, 0u);
}

// A blade that crosses the model sideways but advances through it about a voxel per frame,
// as in a scene: after the first frames each sweep starts and ends inside the model, so its
// edges lie inside octree cubes (level-1 ones too). Frame after frame, the octree cuts what
// the baseline cuts.
TEST(CutStep, SlowBladeCutsEqualTheBaselineFrameByFrame) {
  for (const auto& [name, res] : {std::pair<const char*, int>{"bunny", 48}, {"liver", 48}}) {
    const VoxelGrid g = model(name, res);
    CutBody withOctree = body(g, true, Deformation::Bend);
    CutBody baseline = body(g, false, Deformation::Bend);
    const BladeMotion across = defaultBladeMotion(withOctree);
    // From outside to past the middle, tilted a little so that it is not aligned with the
    // grid.
    const Vec3d way = across.to.a - across.from.a;
    const int frames = static_cast<int>(0.6 * way.norm() / (1.3 * g.voxelSize()));
    const Vec3d step = 0.6 * way / frames;
    BladePose pose = across.from;
    pose.b += Vec3d(0.0, 0.3, 0.0) * g.voxelSize();
    std::size_t total = 0;
    // The octree's subdivision keeps its workspace from frame to frame, as a simulation does.
    SubdivisionWorkspace workspace;
    for (int frame = 0; frame < frames; ++frame) {
      BladePose next = pose;
      next.a += step;
      next.b += step + Vec3d(0.0, 0.05, 0.0) * g.voxelSize();
      const BladeSweep sweep = makeSweep(pose, next, static_cast<std::uint64_t>(frame));
      const CutStepResult o = cutStep(withOctree, sweep, workspace);
      const CutStepResult b = cutStep(baseline, sweep);
      ASSERT_EQ(o.cuts.size(), b.cuts.size()) << name << " frame " << frame;
      ASSERT_EQ(cutSetHash(o.cuts), cutSetHash(b.cuts)) << name << " frame " << frame;
      total += b.cuts.size();
      pose = next;
    }
    EXPECT_GT(total, 200u) << name;
    for (std::size_t v = 0; v < g.voxelCount(); ++v)
      for (int a = 0; a < 3; ++a)
        ASSERT_EQ(withOctree.grid.connected(v, a), baseline.grid.connected(v, a));
  }
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

// A short blade reaches few elements, and few voxels of them. It must cut exactly the
// connected links that a test of every link of the grid finds crossed, without the octree and with
// it (the whole sweep lies inside the model: with the octree, found from the cubes its boundary
// reaches into).
TEST(CutStep, ShortSweepCutsExactlyTheCrossedLinks) {
  const VoxelGrid g = model("bunny", 101);
  for (const bool octree : {false, true}) {
    CutBody b = body(g, octree, Deformation::Twist);
    Eigen::AlignedBox3d box;
    for (std::size_t v = 0; v < g.voxelCount(); ++v)
      if (g.occupied(v)) box.extend(b.deformation.voxelPosition(v));
    const Vec3d c = box.center(), s = box.sizes();
    const double h = g.voxelSize();
    // A blade a tenth of the model wide, tilted, moving 2 voxels through its middle.
    const Vec3d half(0.05 * s.x(), 0.01 * s.y(), 0.015 * s.z());
    const Vec3d move(0.3 * h, 0.4 * h, 2.0 * h);
    const BladeSweep sweep = makeSweep({c - half, c + half}, {c - half + move, c + half + move}, 7);
    const std::vector<std::uint64_t> expected = crossedLinks(b, sweep);
    const CutStepResult r = cutStep(b, sweep);
    ASSERT_GT(r.markedElements, 0u);
    ASSERT_LT(4 * r.markedElements, b.deformation.elementCount())
        << "the blade should reach few elements";
    ASSERT_GT(expected.size(), 20u);
    EXPECT_EQ(linksOf(r), expected) << (octree ? "octree" : "baseline");
    if (octree) {
      EXPECT_GT(r.subdivision.boundaryCubes, 0u);
    }
  }
}

TEST(CutStep, CutSetDoesNotDependOnThreadCount) {
  const VoxelGrid g = model("bunny", 64);
  const CutBody b = body(g, true, Deformation::Twist);
  const BladeMotion m = defaultBladeMotion(b);
  SingleFrameParams sp;
  sp.contour = false;
  std::uint64_t hashes[3];
  for (int t = 1; t <= 3; ++t) {
    ThreadLimit limit(t);
    const SingleFrameResult r = runSingleFrameCut(b, m, sp);
    hashes[t - 1] = r.cutHash;
    if (t > 1) {
      EXPECT_EQ(r.body.activity.state, runSingleFrameCut(b, m, sp).body.activity.state);
    }
  }
  EXPECT_EQ(hashes[0], hashes[1]);
  EXPECT_EQ(hashes[0], hashes[2]);
}

TEST(CutStep, CutThroughTheMiddleLeavesTwoClosedPieces) {
  for (const auto& [name, res] :
       std::vector<std::pair<std::string, int>>{{"bunny", 101}, {"liver", 80}, {"starfish", 120}}) {
    const VoxelGrid g = model(name, res);
    const CutBody b = body(g, true, Deformation::None);
    const SingleFrameResult r = runSingleFrameCut(b, defaultBladeMotion(b), {});
    EXPECT_EQ(r.pieces, 2) << name;
    EXPECT_TRUE(r.topology.closed) << name;
    EXPECT_TRUE(r.topology.manifold) << name;
    EXPECT_EQ(r.topology.pieces, 2) << name;
  }
}

// The culling keeps every crossed link when links are stretched to several voxels (it enlarges
// the sweep's box by the longest link), follows topology edits (renumbered element copies),
// and tests a thin layer of links around the sweep, not every link of the large elements the
// sweep passes through.
TEST(CutStep, CullingFollowsTheSweepUnderStretchAndTopologyEdits) {
  const VoxelGrid g = model("bunny", 64);
  CutBodyParams p;
  p.useOctree = false;
  p.deformation.startLevel = 4;
  p.deformation.maxLevel = 4;
  CutBody b = makeCutBody(g, p);
  const Vec3d c = b.deformation.restVoxelBounds().center();
  const double h = g.voxelSize();
  // A blade across the middle, tilted, moving six voxels along z and half a voxel up.
  const auto shortSweep = [&](const Vec3d& at, std::uint64_t id) {
    const Vec3d half(0.3 * b.deformation.restVoxelBounds().sizes().x(), 0.02 * h, 0.4 * h);
    const Vec3d move(0.1 * h, 0.5 * h, 6.0 * h);
    return makeSweep({at - half, at + half}, {at - half + move, at + half + move}, id);
  };
  const BladeSweep first = shortSweep(c, 3);
  CutBody copy = b;
  const CutStepResult plain = cutStep(copy, first);
  const std::vector<std::uint64_t> expected = crossedLinks(b, first);
  ASSERT_GT(expected.size(), 50u);
  EXPECT_EQ(linksOf(plain), expected);
  // Elements of 16 voxels: whole-element culling tests every link of the elements the sweep
  // passes through, at least 16 layers of 3 links per crossing; the enlarged box around this
  // sweep is about 4 voxels thick.
  EXPECT_LT(plain.testedLinks, 20 * expected.size());

  // Stretched threefold along y about the centre: links along y span three voxels.
  for (Vec3d& x : b.deformation.positions()) x.y() = c.y() + 3.0 * (x.y() - c.y());
  b.deformation.updateHangingNodes();
  const Vec3d at(c.x(), c.y() + 0.1 * h, c.z());
  const BladeSweep stretched = shortSweep(at, 4);
  const std::vector<std::uint64_t> crossed = crossedLinks(b, stretched);
  ASSERT_GT(crossed.size(), 50u);
  const CutStepResult r = cutStep(b, stretched);
  EXPECT_EQ(linksOf(r), crossed);

  // A topology edit: element copies per voxel part on both sides of the cut.
  const TopologyChange change = updateCutTopology(b.deformation, b.grid, linksOf(r));
  ASSERT_TRUE(change.changed);
  const BladeSweep later = shortSweep(Vec3d(c.x(), c.y() - 6.0 * h, c.z()), 5);
  const std::vector<std::uint64_t> again = crossedLinks(b, later);
  ASSERT_GT(again.size(), 50u);
  EXPECT_EQ(linksOf(cutStep(b, later)), again);
}

// The deferred updates left pending and run later (beside other work, in a world's frame)
// leave the same octree as a step that runs them itself; a second step runs the first's
// pending updates before its own subdivision and cuts the same links.
TEST(CutStep, DeferredUpdatesLeftPendingGiveTheSameOctree) {
  const VoxelGrid g = model("bunny", 64);
  const CutBody start = body(g, true, Deformation::Bend);
  const BladeMotion across = defaultBladeMotion(start);
  const BladePose mid{0.5 * (across.from.a + across.to.a), 0.5 * (across.from.b + across.to.b)};
  const std::vector<BladeSweep> first{makeSweep(across.from, mid, 0)};
  const std::vector<BladeSweep> second{makeSweep(mid, across.to, 1)};
  CutBody now = start, later = start;
  SubdivisionWorkspace w1, w2;
  const CutStepResult a1 = cutStep(now, first, w1);
  const CutStepResult a2 = cutStep(now, second, w1);
  const CutStepResult b1 = cutStepLeavingUpdates(later, first, w2);
  ASSERT_GT(b1.cuts.size(), 50u);
  EXPECT_TRUE(later.updatesPending);
  EXPECT_EQ(b1.deferredMs, 0.0);
  const CutStepResult b2 = cutStepLeavingUpdates(later, second, w2);
  EXPECT_GT(b2.deferredMs, 0.0);  // the first step's, run before this one's subdivision
  EXPECT_GT(runDeferredUpdates(later), 0.0);
  EXPECT_FALSE(later.updatesPending);
  EXPECT_EQ(runDeferredUpdates(later), 0.0);
  EXPECT_EQ(linksOf(a1), linksOf(b1));
  EXPECT_EQ(linksOf(a2), linksOf(b2));
  EXPECT_EQ(now.activity.state, later.activity.state);
  EXPECT_EQ(now.activity.cellCube, later.activity.cellCube);
  EXPECT_EQ(now.activity.activeVoxels, later.activity.activeVoxels);
  EXPECT_EQ(now.activity.activeNext, later.activity.activeNext);
  ASSERT_EQ(now.activity.cubes.size(), later.activity.cubes.size());
  for (std::size_t c = 0; c < now.activity.cubes.size(); ++c) {
    EXPECT_EQ(now.activity.cubes[c].origin, later.activity.cubes[c].origin);
    EXPECT_EQ(now.activity.cubes[c].level, later.activity.cubes[c].level);
  }
}

TEST(CutStep, HermiteDataIsInTheRestFrame) {
  // A rigid rotation: the normal pulled back to the rest frame is the rest-frame blade normal.
  const VoxelGrid g = model("sphere:0.05", 40);
  CutBody b = body(g, false, Deformation::Rigid);
  const Vec3d centre = b.deformation.restVoxelBounds().center();
  // Blade in the rest frame: the plane y = centre.y, moved into the deformed frame.
  auto toWorld = [&](const Vec3d& p) {
    return deformedPoint(b.deformation, Deformation::Rigid, 1.0, p);
  };
  const double r = 0.2;
  BladeMotion m;
  m.from = {toWorld(centre + Vec3d(-r, 0, -r)), toWorld(centre + Vec3d(r, 0, -r))};
  m.to = {toWorld(centre + Vec3d(-r, 0, r)), toWorld(centre + Vec3d(r, 0, r))};
  const SingleFrameResult res = runSingleFrameCut(b, m, {});
  ASSERT_GT(res.step.cuts.size(), 100u);
  for (const LinkCut& c : res.step.cuts) {
    EXPECT_EQ(c.link % 3, 1u);  // only y links cross the plane y = const
    EXPECT_NEAR(c.hermite.n[1], 1.0f, 1e-5f);
    const std::size_t v = static_cast<std::size_t>(c.link / 3);
    const double y = g.position(v).y() + c.hermite.t * g.voxelSize();
    EXPECT_NEAR(y, centre.y(), 1.01e-3 * g.voxelSize());  // t is clamped to [1e-3, 1 - 1e-3]
  }
  EXPECT_EQ(res.pieces, 2);
}

}  // namespace
}  // namespace voxcut
