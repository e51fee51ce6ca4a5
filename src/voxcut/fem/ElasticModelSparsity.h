#pragma once
/// @file ElasticModelSparsity.h
/// Internal to fem/: the plan of the sparsity rows that ElasticModel::updateTopology copies
/// from the sparsity before a topology change (ElasticModel.cpp, ElasticModelSparsity.cpp).

#include <cstdint>
#include <vector>

#include "voxcut/fem/ElasticModel.h"
#include "voxcut/linalg/BlockSparsity.h"

namespace voxcut {

/// Which rows of the new sparsity are copies of old rows, and how to renumber them.
struct ElasticModel::SparsityReuse {
  const BlockSparsity* old = nullptr;
  std::vector<std::uint32_t> oldRow;     ///< per new row: the old row to copy, or kNotFree
  std::vector<std::uint32_t> newColumn;  ///< per old free index: the new one (kNotFree: gone)
  std::uint32_t oldMassBase = 0;         ///< 64 * old #elements
};

}  // namespace voxcut
