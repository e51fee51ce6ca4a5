#include "voxcut/voxel/HermiteMap.h"

#include <algorithm>

namespace voxcut {

std::vector<std::uint64_t> HermiteMap::sortedLinks() const {
  std::vector<std::uint64_t> out;
  out.reserve(map_.size());
  map_.forEach([&](std::uint64_t k, const Hermite&) { out.push_back(k); });
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace voxcut
