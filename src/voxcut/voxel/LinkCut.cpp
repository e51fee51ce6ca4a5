#include "voxcut/voxel/LinkCut.h"

#include <cstddef>

namespace voxcut {

void storeHermite(HermiteMap& hermite, LinkCut* first, LinkCut* last) {
  for (LinkCut* c = first; c != last; ++c) {
    if (last - c > static_cast<std::ptrdiff_t>(HermiteMap::kPrefetchAhead))
      hermite.prefetch(c[HermiteMap::kPrefetchAhead].link);
    c->previous = hermite.exchange(c->link, c->hermite);
  }
}

}  // namespace voxcut
