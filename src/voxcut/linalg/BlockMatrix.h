#pragma once
/// @file BlockMatrix.h
/// Symmetric sparse matrices of 3x3 blocks (docs/algorithms.md, "Multigrid"): compressed rows
/// with both triangles stored, each row's columns ascending. One block row is one node's three
/// unknowns. The implicit step's reduced matrix (fem/ImplicitEuler.h) and every coarse level
/// of the multigrid (Multigrid.h) are such matrices.
///
/// Thread-safety: plain data; const access may run concurrently.

#include <Eigen/Core>
#include <concepts>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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

/// The scalar types a block may hold: double, or float for copies that only need to be read
/// fast (the multigrid's smoothers, Multigrid.h).
template <class Scalar>
concept BlockScalar = std::same_as<Scalar, double> || std::same_as<Scalar, float>;

/// sum over slots [begin, end) of blocks[slot] * x[column[slot]] (3x3 column-major blocks),
/// summed in double whatever the blocks hold: one row's share of a block product, written out
/// because the solvers spend most of their time here. With float blocks, each block's nine
/// entries are widened two at a time (SSE2), so reading half the bytes does not cost more
/// instructions than the double product. The order of the sums is fixed per row.
template <BlockScalar Scalar>
inline Vec3d blockRowProduct(const Eigen::Matrix<Scalar, 3, 3>* blocks, const std::uint32_t* column,
                             const Vec3d* x, std::uint32_t begin, std::uint32_t end) {
#if defined(__SSE2__)
  if constexpr (std::same_as<Scalar, float>) {
    // Entries a0..a8 column-major: row 0 = (a0, a3, a6), row 1 = (a1, a4, a7), row 2 = (a2,
    // a5, a8). Pairs (a0, a1) and (a6, a7) add to rows (0, 1); (a4, a5) times v1 to rows (1,
    // 2); (a2, a3) times (v0, v1) to rows (2, 0); a8 v2 to row 2.
    __m128d s01 = _mm_setzero_pd(), s12 = _mm_setzero_pd(), s20 = _mm_setzero_pd();
    double s2 = 0.0;
    for (std::uint32_t slot = begin; slot < end; ++slot) {
      const float* a = blocks[slot].data();
      const double* v = x[column[slot]].data();
      const __m128 lo = _mm_loadu_ps(a), hi = _mm_loadu_ps(a + 4);
      const __m128d v01 = _mm_loadu_pd(v), v12 = _mm_loadu_pd(v + 1);
      const __m128d a01 = _mm_cvtps_pd(lo), a23 = _mm_cvtps_pd(_mm_movehl_ps(lo, lo));
      const __m128d a45 = _mm_cvtps_pd(hi), a67 = _mm_cvtps_pd(_mm_movehl_ps(hi, hi));
      s01 = _mm_add_pd(s01, _mm_add_pd(_mm_mul_pd(a01, _mm_unpacklo_pd(v01, v01)),
                                       _mm_mul_pd(a67, _mm_unpackhi_pd(v12, v12))));
      s12 = _mm_add_pd(s12, _mm_mul_pd(a45, _mm_unpacklo_pd(v12, v12)));
      s20 = _mm_add_pd(s20, _mm_mul_pd(a23, v01));
      s2 += static_cast<double>(a[8]) * v[2];
    }
    alignas(16) double p01[2], p12[2], p20[2];
    _mm_store_pd(p01, s01);
    _mm_store_pd(p12, s12);
    _mm_store_pd(p20, s20);
    return Vec3d(p01[0] + p20[1], p01[1] + p12[0], p12[1] + p20[0] + s2);
  }
#endif
  double s0 = 0.0, s1 = 0.0, s2 = 0.0;
  for (std::uint32_t slot = begin; slot < end; ++slot) {
    const Scalar* a = blocks[slot].data();
    const double* v = x[column[slot]].data();
    s0 += static_cast<double>(a[0]) * v[0] + static_cast<double>(a[3]) * v[1] +
          static_cast<double>(a[6]) * v[2];
    s1 += static_cast<double>(a[1]) * v[0] + static_cast<double>(a[4]) * v[1] +
          static_cast<double>(a[7]) * v[2];
    s2 += static_cast<double>(a[2]) * v[0] + static_cast<double>(a[5]) * v[1] +
          static_cast<double>(a[8]) * v[2];
  }
  return Vec3d(s0, s1, s2);
}

/// Row i of A x.
inline Vec3d blockRowProduct(const BlockMatrixView& a, const Vec3d* x, std::size_t i) {
  return blockRowProduct(a.blocks, a.column, x, a.rowStart[i], a.rowStart[i + 1]);
}

}  // namespace voxcut
