#pragma once
/// @file SparseRows.h
/// Compressed rows of (index, weight) pairs, as the implicit step's prolongation
/// (fem/ElasticModel.h) and the multigrid's interpolations (Multigrid.h) store them, and their
/// transpose.

#include <cstdint>
#include <vector>

namespace voxcut {

/// The transpose of the compressed rows (start, index, weight) of a matrix with `columns`
/// columns: row c of the result lists, in ascending order, the rows with an entry in column c,
/// each with its weight (a counting sort, linear time).
void transposeRows(const std::vector<std::uint32_t>& start, const std::vector<std::uint32_t>& index,
                   const std::vector<double>& weight, std::size_t columns,
                   std::vector<std::uint32_t>& tStart, std::vector<std::uint32_t>& tIndex,
                   std::vector<double>& tWeight);

}  // namespace voxcut
