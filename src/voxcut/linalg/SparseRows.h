#pragma once
/// @file SparseRows.h
/// Compressed rows of (index, weight) pairs, as the implicit step's prolongation
/// (fem/ElasticModel.h) and the multigrid's interpolations (Multigrid.h) store them, and their
/// transpose.

#include <cstdint>
#include <vector>

namespace voxcut {

/// Compressed rows of (index, weight) pairs; row r holds entries [start[r], start[r + 1]).
struct WeightedRows {
  std::vector<std::uint32_t> start{0};
  std::vector<std::uint32_t> index;
  std::vector<double> weight;

  [[nodiscard]] std::size_t rows() const { return start.size() - 1; }
};

/// The transpose of the compressed rows (start, index, weight) of a matrix with `columns`
/// columns: row c of the result lists, in ascending order, the rows with an entry in column c,
/// each with its weight (a counting sort, linear time).
void transposeRows(const std::vector<std::uint32_t>& start, const std::vector<std::uint32_t>& index,
                   const std::vector<double>& weight, std::size_t columns,
                   std::vector<std::uint32_t>& tStart, std::vector<std::uint32_t>& tIndex,
                   std::vector<double>& tWeight);

}  // namespace voxcut
