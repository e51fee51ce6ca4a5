#pragma once
/// @file BlockSparsity.h
/// The pattern of a symmetric 3x3-block sparse matrix that is assembled anew each step, with
/// the plan of that assembly: the implicit step's reduced system (fem/ElasticModel.h builds
/// it, fem/ImplicitEuler.h assembles and solves on it) and what the preconditioners on it
/// (BlockPreconditioner.h, BlockCholesky.h, TwoLevelPreconditioner.h) read. The blocks
/// themselves are held apart, one 3x3 per slot, in the slots' order.
///
/// Thread-safety: plain data; const access may run concurrently.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "voxcut/linalg/BlockMatrix.h"

namespace voxcut {

/// A symmetric 3x3-block sparsity (both triangles stored) and, per block, the sources summed
/// into it each step, in a fixed order (deterministic assembly).
struct BlockSparsity {
  std::vector<std::uint32_t> rowStart{0};  ///< #rows + 1 offsets into column
  std::vector<std::uint32_t> column;       ///< column of each block, ascending per row
  std::vector<std::uint32_t> diagonal;     ///< slot of block (i, i), #rows
  /// Per block on or above the diagonal (the assembly mirrors the others, which have none),
  /// sources [sourceStart[s], sourceStart[s + 1]), each an id with a weight. What an id names
  /// is the assembler's (fem/ElasticModel.h: an element's corner block or a node's mass).
  std::vector<std::uint32_t> sourceStart{0};
  std::vector<std::uint32_t> source;
  std::vector<double> sourceWeight;
  std::vector<std::uint32_t> mirror;  ///< per slot (i, k), the slot (k, i)

  [[nodiscard]] std::size_t blockCount() const { return column.size(); }
  /// The matrix with this pattern and `blocks` (one per slot), as a view borrowing both.
  [[nodiscard]] BlockMatrixView view(const std::vector<Eigen::Matrix3d>& blocks) const {
    return {diagonal.size(), rowStart.data(), column.data(), diagonal.data(), blocks.data()};
  }
};

/// Per block slot (i, k) of `sparsity`, the slot (k, i) (the pattern is symmetric): what
/// BlockSparsity::mirror holds.
[[nodiscard]] std::vector<std::uint32_t> blockMirrors(const BlockSparsity& sparsity);

}  // namespace voxcut
