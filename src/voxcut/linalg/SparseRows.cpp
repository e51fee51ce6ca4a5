#include "voxcut/linalg/SparseRows.h"

namespace voxcut {

void transposeRows(const std::vector<std::uint32_t>& start, const std::vector<std::uint32_t>& index,
                   const std::vector<double>& weight, std::size_t columns,
                   std::vector<std::uint32_t>& tStart, std::vector<std::uint32_t>& tIndex,
                   std::vector<double>& tWeight) {
  tStart.assign(columns + 1, 0);
  for (std::uint32_t c : index) ++tStart[c + 1];
  for (std::size_t c = 0; c < columns; ++c) tStart[c + 1] += tStart[c];
  tIndex.resize(index.size());
  tWeight.resize(index.size());
  std::vector<std::uint32_t> next(tStart.begin(), tStart.end() - 1);
  for (std::size_t r = 0; r + 1 < start.size(); ++r)
    for (std::uint32_t k = start[r]; k < start[r + 1]; ++k) {
      const std::uint32_t at = next[index[k]]++;
      tIndex[at] = static_cast<std::uint32_t>(r);
      tWeight[at] = weight[k];
    }
}

}  // namespace voxcut
