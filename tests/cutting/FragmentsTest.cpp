#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "voxcut/cutting/Fragments.h"
#include "voxcut/voxel/Pieces.h"

namespace voxcut {
namespace {

/// A full n^3 grid, every link connected.
VoxelGrid fullGrid(int n) {
  VoxelGrid g({n, n, n}, Vec3d::Zero(), 0.01);
  for (std::size_t v = 0; v < g.voxelCount(); ++v) g.setMaterial(v, 1);
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a) g.setConnected(v, a, g.hasLink(v, a));
  return g;
}

Hermite hermite(float t) {
  Hermite h;
  h.t = t;
  h.n[0] = 1.f;
  return h;
}

/// Cuts every link between the box [lo, hi] (voxel coordinates, inclusive) and the rest, as
/// one frame's cuts sorted by link id.
std::vector<LinkCut> isolateBox(VoxelGrid& g, const Index3& lo, const Index3& hi) {
  auto inside = [&](const Index3& c) {
    return c.x >= lo.x && c.x <= hi.x && c.y >= lo.y && c.y <= hi.y && c.z >= lo.z && c.z <= hi.z;
  };
  std::vector<LinkCut> cuts;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a) {
      if (!g.hasLink(v, a)) continue;
      const Index3 c = g.coord(v);
      Index3 d = c;
      d[a] += 1;
      if (inside(c) == inside(d)) continue;
      LinkCut lc{VoxelGrid::linkId(v, a), hermite(0.5f), std::nullopt};
      if (const Hermite* old = g.hermite().find(lc.link)) lc.previous = *old;
      g.setConnected(v, a, false);
      g.hermite().set(lc.link, lc.hermite);
      cuts.push_back(lc);
    }
  return cuts;
}

TEST(Fragments, ASingleVoxelCutLooseIsReattachedByItsLowestLink) {
  VoxelGrid g = fullGrid(8);
  // The lowest of the six links around (4, 4, 4) is the -z one; give it interface data first.
  const std::uint64_t lowest = VoxelGrid::linkId(g.index(4, 4, 3), 2);
  g.hermite().set(lowest, hermite(0.25f));
  std::vector<LinkCut> cuts = isolateBox(g, {4, 4, 4}, {4, 4, 4});
  ASSERT_EQ(cuts.size(), 6u);
  ASSERT_EQ(findPieces(g).count, 2);
  const std::vector<std::uint64_t> healed = healSmallFragments(g, cuts, 8);
  ASSERT_EQ(healed, std::vector<std::uint64_t>{lowest});
  EXPECT_EQ(cuts.size(), 5u);
  EXPECT_TRUE(
      std::none_of(cuts.begin(), cuts.end(), [&](const LinkCut& c) { return c.link == lowest; }));
  EXPECT_EQ(findPieces(g).count, 1);
  EXPECT_TRUE(g.connected(static_cast<std::size_t>(lowest / 3), 2));
  // The interface data it had before the cut is back; the other cuts keep theirs.
  const Hermite* restored = g.hermite().find(lowest);
  ASSERT_NE(restored, nullptr);
  EXPECT_EQ(restored->t, 0.25f);
  for (const LinkCut& c : cuts) ASSERT_NE(g.hermite().find(c.link), nullptr);
}

TEST(Fragments, ALinkWithoutDataBeforeTheCutLosesItsHermiteData) {
  VoxelGrid g = fullGrid(6);
  std::vector<LinkCut> cuts = isolateBox(g, {2, 2, 2}, {2, 2, 2});
  const std::vector<std::uint64_t> healed = healSmallFragments(g, cuts, 2);
  ASSERT_EQ(healed.size(), 1u);
  EXPECT_EQ(g.hermite().find(healed[0]), nullptr);
}

TEST(Fragments, TheThresholdIsStrict) {
  // A 2x2x2 fragment has 8 voxels: kept at a threshold of 8, reattached at 9.
  for (std::size_t threshold : {8u, 9u}) {
    VoxelGrid g = fullGrid(8);
    std::vector<LinkCut> cuts = isolateBox(g, {2, 3, 4}, {3, 4, 5});
    const std::size_t before = cuts.size();
    const std::vector<std::uint64_t> healed = healSmallFragments(g, cuts, threshold);
    EXPECT_EQ(healed.size(), threshold == 8 ? 0u : 1u);
    EXPECT_EQ(cuts.size(), before - healed.size());
    EXPECT_EQ(findPieces(g).count, threshold == 8 ? 2 : 1);
  }
}

TEST(Fragments, LargePiecesAndOldFragmentsAreLeftAlone) {
  VoxelGrid g = fullGrid(8);
  // A fragment cut loose in an earlier frame: its cuts are not this frame's.
  (void)isolateBox(g, {6, 6, 6}, {6, 6, 6});
  // This frame: a plane through the middle, two halves of 256 voxels.
  std::vector<LinkCut> cuts = isolateBox(g, {0, 0, 0}, {7, 7, 3});
  const std::size_t before = cuts.size();
  EXPECT_TRUE(healSmallFragments(g, cuts, 8).empty());
  EXPECT_EQ(cuts.size(), before);
  EXPECT_EQ(findPieces(g).count, 3);
  // A threshold of 0 or 1 keeps every cut.
  VoxelGrid h = fullGrid(5);
  std::vector<LinkCut> single = isolateBox(h, {1, 1, 1}, {1, 1, 1});
  EXPECT_TRUE(healSmallFragments(h, single, 1).empty());
  EXPECT_EQ(findPieces(h).count, 2);
}

TEST(Fragments, NeighbouringFragmentsAreAllReattached) {
  // Two single voxels side by side, each cut loose from everything (the link between them
  // too): both end up attached to the body.
  VoxelGrid g = fullGrid(8);
  std::vector<LinkCut> cuts = isolateBox(g, {3, 3, 3}, {4, 3, 3});
  const std::size_t v = g.index(3, 3, 3);
  LinkCut between{VoxelGrid::linkId(v, 0), hermite(0.5f), std::nullopt};
  g.setConnected(v, 0, false);
  g.hermite().set(between.link, between.hermite);
  cuts.push_back(between);
  std::sort(cuts.begin(), cuts.end(),
            [](const LinkCut& x, const LinkCut& y) { return x.link < y.link; });
  const std::vector<std::uint64_t> healed = healSmallFragments(g, cuts, 8);
  EXPECT_EQ(findPieces(g).count, 1);
  EXPECT_LE(healed.size(), 2u);
  EXPECT_TRUE(std::is_sorted(healed.begin(), healed.end()));
}

}  // namespace
}  // namespace voxcut
