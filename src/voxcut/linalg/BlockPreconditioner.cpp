#include "voxcut/linalg/BlockPreconditioner.h"

#include <Eigen/Cholesky>

#include "voxcut/core/Error.h"
#include "voxcut/linalg/BlockSparsity.h"

namespace voxcut {

IncompleteCholeskyPattern incompleteCholeskyPattern(const BlockSparsity& sp) {
  IncompleteCholeskyPattern out;
  const std::size_t rows = sp.diagonal.size();
  out.pairStart.reserve(sp.blockCount() + 1);
  for (std::size_t i = 0; i < rows; ++i) {
    for (std::uint32_t s = sp.rowStart[i]; s < sp.rowStart[i + 1]; ++s) {
      const std::uint32_t k = sp.column[s];
      if (k < i) {
        // Merge row i's and row k's lower parts over columns j < k.
        std::uint32_t a = sp.rowStart[i], b = sp.rowStart[k];
        const std::uint32_t aEnd = s, bEnd = sp.diagonal[k];
        while (a < aEnd && b < bEnd) {
          const std::uint32_t ja = sp.column[a], jb = sp.column[b];
          if (ja < jb) {
            ++a;
          } else if (jb < ja) {
            ++b;
          } else {
            out.pair.push_back(a++);
            out.pair.push_back(b++);
          }
        }
      }
      out.pairStart.push_back(static_cast<std::uint32_t>(out.pair.size() / 2));
    }
  }
  VOXCUT_ASSERT(out.pairStart.size() == sp.blockCount() + 1, "one pair range per block");
  return out;
}

namespace {

/// Smallest fraction of A_ii's diagonal a pivot may keep (see the file comment).
constexpr double kPivotFloor = 0.05;

}  // namespace

void factorIncompleteCholesky(const BlockSparsity& sp, const IncompleteCholeskyPattern& pattern,
                              const std::vector<Eigen::Matrix3d>& blocks,
                              IncompleteCholeskyFactor& factor) {
  VOXCUT_ASSERT(blocks.size() == sp.blockCount() && sp.mirror.size() == sp.blockCount() &&
                    pattern.pairStart.size() == sp.blockCount() + 1,
                "the blocks or the pattern do not match the sparsity");
  const std::size_t rows = sp.diagonal.size();
  factor.lower.resize(sp.blockCount());
  factor.scaled.resize(sp.blockCount());
  factor.pivotInverse.resize(rows);
  factor.replacedPivots = 0;
  for (std::size_t i = 0; i < rows; ++i) {
    const std::uint32_t diagonal = sp.diagonal[i];
    Eigen::Matrix3d pivot = blocks[diagonal];
    factor.lower[diagonal].setZero();  // unused; keeps every slot defined
    for (std::uint32_t s = sp.rowStart[i]; s < diagonal; ++s) {
      Eigen::Matrix3d f = blocks[s];
      for (std::uint32_t p = pattern.pairStart[s]; p < pattern.pairStart[s + 1]; ++p)
        f.noalias() -=
            factor.lower[pattern.pair[2 * p]] * factor.scaled[pattern.pair[2 * p + 1]].transpose();
      const Eigen::Matrix3d l = f * factor.pivotInverse[sp.column[s]];
      pivot.noalias() -= l * f.transpose();
      factor.lower[s] = l;
      factor.lower[sp.mirror[s]] = l.transpose();
      factor.scaled[s] = f;
    }
    // Symmetrise against round-off before the positive-definiteness check.
    pivot = 0.5 * (pivot + pivot.transpose()).eval();
    const Eigen::LLT<Eigen::Matrix3d> llt(pivot);
    const Eigen::Matrix3d& a = blocks[diagonal];
    // A pivot that lost most of A_ii to cancellation (or is not positive definite) would make
    // the next rows' factors grow without bound: use A_ii instead, which keeps M SPD.
    bool keep = llt.info() == Eigen::Success;
    for (int c = 0; c < 3 && keep; ++c) keep = pivot(c, c) > kPivotFloor * a(c, c);
    if (!keep) {
      // Drop the row to its diagonal block: its couplings would carry the breakdown into
      // every later row that meets it.
      for (std::uint32_t s = sp.rowStart[i]; s < diagonal; ++s) {
        factor.lower[s].setZero();
        factor.lower[sp.mirror[s]].setZero();
        factor.scaled[s].setZero();
      }
      pivot = a;
      ++factor.replacedPivots;
    }
    factor.pivotInverse[i] = pivot.inverse();
  }
}

void applyIncompleteCholesky(const BlockSparsity& sp, const IncompleteCholeskyFactor& factor,
                             const std::vector<Vec3d>& r, std::vector<Vec3d>& z) {
  const std::size_t rows = sp.diagonal.size();
  z.resize(rows);
  const Eigen::Matrix3d* l = factor.lower.data();
  const std::uint32_t* column = sp.column.data();
  // Forward: y_i = r_i - sum_{k<i} L_ik y_k, kept as z_i = D_i^-1 y_i.
  std::vector<Vec3d>& y = z;
  for (std::size_t i = 0; i < rows; ++i)
    y[i] = r[i] - blockRowProduct(l, column, y.data(), sp.rowStart[i], sp.diagonal[i]);
  // D^-1 then backward: z_i = (D^-1 y)_i - sum_{k>i} L_ki^T z_k, L_ki^T stored at (i, k).
  for (std::size_t i = rows; i-- > 0;)
    z[i] = factor.pivotInverse[i] * y[i] -
           blockRowProduct(l, column, z.data(), sp.diagonal[i] + 1, sp.rowStart[i + 1]);
}

void applySymmetricGaussSeidel(const BlockSparsity& sp, const std::vector<Eigen::Matrix3d>& blocks,
                               const std::vector<Eigen::Matrix3d>& diagonalInverse,
                               const std::vector<Vec3d>& r, std::vector<Vec3d>& z) {
  const std::size_t rows = sp.diagonal.size();
  z.resize(rows);
  const Eigen::Matrix3d* a = blocks.data();
  const std::uint32_t* column = sp.column.data();
  for (std::size_t i = 0; i < rows; ++i)
    z[i] = diagonalInverse[i] *
           (r[i] - blockRowProduct(a, column, z.data(), sp.rowStart[i], sp.diagonal[i]));
  for (std::size_t i = rows; i-- > 0;)
    z[i] -= diagonalInverse[i] *
            blockRowProduct(a, column, z.data(), sp.diagonal[i] + 1, sp.rowStart[i + 1]);
}

}  // namespace voxcut
