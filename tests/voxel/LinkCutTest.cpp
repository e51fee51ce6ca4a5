#include <gtest/gtest.h>

#include <vector>

#include "voxcut/voxel/LinkCut.h"

namespace voxcut {
namespace {

TEST(LinkCut, StoreHermiteSetsDataAndKeepsWhatItReplaced) {
  HermiteMap table;
  table.set(7, Hermite{0.25f, {1, 0, 0}});
  // More cuts than the prefetch distance, so the loop fetches ahead.
  std::vector<LinkCut> cuts;
  for (std::uint64_t link = 0; link < 3 * HermiteMap::kPrefetchAhead; ++link)
    cuts.push_back(
        {link, Hermite{0.5f + 0.001f * static_cast<float>(link), {0, 1, 0}}, std::nullopt});
  storeHermite(table, cuts.data(), cuts.data() + cuts.size());
  EXPECT_EQ(table.size(), cuts.size());
  for (const LinkCut& c : cuts) {
    const Hermite* h = table.find(c.link);
    ASSERT_NE(h, nullptr);
    EXPECT_EQ(h->t, c.hermite.t);
    EXPECT_EQ(c.previous.has_value(), c.link == 7);
  }
  EXPECT_EQ(cuts[7].previous->t, 0.25f);
  EXPECT_EQ(cuts[7].previous->n[0], 1.0f);
}

}  // namespace
}  // namespace voxcut
