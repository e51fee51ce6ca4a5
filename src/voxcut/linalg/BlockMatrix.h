#pragma once
/// @file BlockMatrix.h
/// Symmetric sparse matrices of 3x3 blocks (docs/algorithms.md, "Multigrid"): compressed rows
/// with both triangles stored, each row's columns ascending. One block row is one node's three
/// unknowns. The implicit step's reduced matrix (fem/ImplicitEuler.h) and every coarse level
/// of the multigrid (Multigrid.h) are such matrices.
///
/// Thread-safety: plain data; const access may run concurrently.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

/// Read-only view of a block matrix held elsewhere: `rows` block rows, row i's blocks in slots
/// [rowStart[i], rowStart[i + 1]) with their columns in `column` (ascending), the slot of (i, i)
/// in diagonal[i]; blocks are column-major 3x3.
struct BlockMatrixView {
  std::size_t rows = 0;
  const std::uint32_t* rowStart = nullptr;
  const std::uint32_t* column = nullptr;
  const std::uint32_t* diagonal = nullptr;
  const Eigen::Matrix3d* blocks = nullptr;
};

/// A block matrix that owns its arrays.
struct BlockMatrix {
  std::vector<std::uint32_t> rowStart{0};
  std::vector<std::uint32_t> column;
  std::vector<std::uint32_t> diagonal;
  std::vector<Eigen::Matrix3d> blocks;

  [[nodiscard]] std::size_t rows() const { return rowStart.size() - 1; }
  [[nodiscard]] BlockMatrixView view() const {
    return {rows(), rowStart.data(), column.data(), diagonal.data(), blocks.data()};
  }
};

/// sum over slots [begin, end) of blocks[slot] * x[column[slot]] (3x3 column-major blocks): one
/// row's share of a block product, written out because the solvers spend most of their time
/// here.
inline Vec3d blockRowProduct(const Eigen::Matrix3d* blocks, const std::uint32_t* column,
                             const Vec3d* x, std::uint32_t begin, std::uint32_t end) {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0;
  for (std::uint32_t slot = begin; slot < end; ++slot) {
    const double* a = blocks[slot].data();
    const double* v = x[column[slot]].data();
    s0 += a[0] * v[0] + a[3] * v[1] + a[6] * v[2];
    s1 += a[1] * v[0] + a[4] * v[1] + a[7] * v[2];
    s2 += a[2] * v[0] + a[5] * v[1] + a[8] * v[2];
  }
  return Vec3d(s0, s1, s2);
}

/// Row i of A x.
inline Vec3d blockRowProduct(const BlockMatrixView& a, const Vec3d* x, std::size_t i) {
  return blockRowProduct(a.blocks, a.column, x, a.rowStart[i], a.rowStart[i + 1]);
}

}  // namespace voxcut
