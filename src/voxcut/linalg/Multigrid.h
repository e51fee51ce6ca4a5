#pragma once
/// @file Multigrid.h
/// Geometric multigrid V-cycle for symmetric positive definite block matrices whose rows are
/// nodes on an integer grid (docs/algorithms.md, "Multigrid"): the preconditioner of the
/// implicit step's conjugate gradients (fem/ImplicitEuler.h).
///
/// Hierarchy. Level 0 is the given matrix. Each coarser level is made from the one below by
/// trilinear interpolation from the corners of cubic cells of edge S (in grid units): a row at
/// grid point x takes, from the corners of the cell around it, the trilinear weights of x
/// there; a row on a cell's face, edge or corner only from the corners of that face, edge or
/// corner (a row on a corner is copied). S is the smallest power of two, twice the previous
/// level's or more, whose coarse level has at most `maxCoarseRatio` of the rows: an adaptive
/// octree whose nodes mostly sit on multiples of 8 first coarsens with S = 16, and regions
/// refined around a cut join the cells of their surroundings.
///
/// Cuts. The rows inside one closed cell split into the parts the matrix connects there (rows
/// coupled by a block): each part is a copy of the cell with corners of its own. Two cell
/// copies share a corner where a row of both has a weight on it, so every row interpolates from
/// one set of coarse rows whichever cell it is looked at from; pieces cut apart, and lobes that
/// pass through one cell, keep separate coarse rows. Coarse rows nothing interpolates from are
/// left out. The coarse matrices are Galerkin products A_c = P^T A P, so a coarse element
/// is the composite of the fine ones it holds, contact springs included: whatever the fine
/// matrix holds reaches every level.
///
/// Smoother. Symmetric block Gauss-Seidel, one forward sweep before the coarse correction and
/// one backward sweep after, so the V-cycle is symmetric positive definite (also with coarse
/// matrices of an earlier step's fine matrix, which is how ImplicitEuler reuses them). A row
/// whose diagonal block is far weaker than its neighbours' (a node of a composite element that
/// holds few voxels, far from them: its stiffness reaches it through tiny interpolation
/// weights) is relaxed together with the weak rows it is coupled to, as one group solved
/// exactly (dense Cholesky; a larger connected set is cut into groups grown breadth first):
/// modes that span several such rows are invisible to single-row relaxation and to the
/// interpolated coarse levels alike, and without the groups the iterations grow with the
/// body's surface (docs/performance.md, "Deformation solver at scale"). Groups are coloured so
/// that groups of one colour share no block; sweeps run colour by colour, each colour's groups
/// in parallel. Each level keeps a single-precision copy of its matrix renumbered colour by
/// colour, so the forward sweep from zero reads only the blocks before a row's group and the
/// residual after it only those after (sums stay in double; the cycle is symmetric to the
/// single-precision rounding). The coarsest level is factorised (block Cholesky,
/// BlockCholesky.h).
///
/// Determinism: the sweeps run rows in order; products, restrictions and prolongations are
/// parallel with fixed per-row sums, so results do not depend on the thread count.
///
/// Thread-safety: one call at a time per object (it owns scratch vectors).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/linalg/BlockCholesky.h"
#include "voxcut/linalg/BlockMatrix.h"
#include "voxcut/linalg/BlockSparsity.h"
#include "voxcut/linalg/LinearPreconditioner.h"

namespace voxcut {

/// Settings of the hierarchy.
struct MultigridParams {
  /// The coarsest level (factorised) is the first with at most coarsestRows rows whose
  /// factor has at most maxCoarsestFill blocks below the diagonal per block of the fine
  /// matrix: its two triangular solves then cost about as much as one or two fine products.
  /// Levels of a hundred or two rows (cells of 64 voxels on the bunny) no longer carry the
  /// body's shape; factorising the level above them saves iterations (docs/performance.md,
  /// "Deformation solver at scale").
  std::size_t coarsestRows = 2000;
  double maxCoarsestFill = 0.75;
  /// A cell size is accepted when its coarse level has at most this fraction of the rows.
  double maxCoarseRatio = 0.6;
  /// A row is weak when the trace of its diagonal block is below this fraction of the largest
  /// trace among the rows it is coupled to.
  double weakRatio = 0.01;
  /// Largest group of weak rows relaxed together (bigger connected sets are split in row
  /// order).
  std::size_t maxGroupRows = 8;
  int maxLevels = 16;
};

/// One level's row-to-coarse-row interpolation, by rows, and its transpose.
struct Interpolation {
  std::vector<std::uint32_t> start{0};  ///< per fine row + 1
  std::vector<std::uint32_t> index;     ///< coarse row
  std::vector<double> weight;
  std::vector<std::uint32_t> tStart{0};  ///< per coarse row + 1: the transpose
  std::vector<std::uint32_t> tIndex;     ///< fine row, ascending
  std::vector<double> tWeight;
};

/// The coarse rows of one coarsening step: the interpolation from them and their grid points.
struct Coarsening {
  Interpolation interpolation;
  std::vector<Index3> coords;  ///< per coarse row
};

/// One coarsening step (file comment) of the rows of pattern `a` (its blocks unused) at
/// non-negative grid points `coords` with cells of edge `cellSize` (a power of two).
/// Deterministic: coarse rows are numbered in the order the fine rows first reach them.
[[nodiscard]] Coarsening coarsenRows(const BlockMatrixView& a, const std::vector<Index3>& coords,
                                     int cellSize);

/// The V-cycle preconditioner. Through the LinearPreconditioner interface, setOperator is
/// setup() (the hierarchy must have been built for the matrix's pattern) and apply(r, z) one
/// V-cycle with the matrix of the last setup() or updateFine().
class Multigrid final : public LinearPreconditioner {
 public:
  Multigrid();
  Multigrid(const Multigrid& other);
  Multigrid& operator=(const Multigrid& other);
  Multigrid(Multigrid&&) noexcept;
  Multigrid& operator=(Multigrid&&) noexcept;
  ~Multigrid();

  /// Builds the hierarchy's structure (interpolations, coarse patterns) for fine matrices of
  /// `fine`'s pattern whose rows sit at grid points `coords` (non-negative). Invalidates the
  /// coarse matrices (setup() must follow).
  void build(const BlockMatrixView& fine, const std::vector<Index3>& coords,
             const MultigridParams& params, bool threaded);

  /// Computes every coarse matrix from `fine` (its pattern that of build()), the weak groups
  /// and the smoothers' factors of every level, and factorises the coarsest. False (and the
  /// hierarchy unusable until the next successful setup) when a factor is not positive
  /// definite.
  bool setup(const BlockMatrixView& fine, bool threaded);
  /// Only level 0's smoother factors, for a new fine matrix of the same pattern: the coarse
  /// levels stay those of the last setup(). False as for setup().
  bool updateFine(const BlockMatrixView& fine, bool threaded);

  /// z = M^-1 r (one V-cycle) with the fine matrix `fine` (the one of the last setup() or
  /// updateFine()). `z` is resized and must not alias r.
  void apply(const BlockMatrixView& fine, const std::vector<Vec3d>& r, std::vector<Vec3d>& z,
             bool threaded);

  /// setup(a, threaded): the coarse levels and smoothers for `a`, which apply() then borrows.
  [[nodiscard]] bool setOperator(const BlockMatrixView& a, bool threaded) override {
    return setup(a, threaded);
  }
  /// One V-cycle with the matrix of the last setup() or updateFine().
  void apply(const std::vector<Vec3d>& r, std::vector<Vec3d>& z) override {
    apply(operator_, r, z, threaded_);
  }

  [[nodiscard]] bool built() const { return !levels_.empty(); }
  [[nodiscard]] bool valid() const { return valid_; }
  /// Levels, the fine one included.
  [[nodiscard]] std::size_t levelCount() const { return levels_.size(); }
  /// Rows of each level, fine first.
  [[nodiscard]] std::vector<std::size_t> rowsPerLevel() const;
  /// Rows relaxed in groups (weak rows) on each level, at the last setup.
  [[nodiscard]] std::vector<std::size_t> groupedRowsPerLevel() const;
  /// Blocks each level's smoother sweeps over (its single-precision copy), fine first; the
  /// coarsest level's is empty when it is factorised.
  [[nodiscard]] std::vector<std::size_t> smootherBlocksPerLevel() const;
  /// Blocks of the coarsest level's factor below the diagonal (0 when none).
  [[nodiscard]] std::size_t coarsestFactorBlocks() const { return coarsest_.offDiagonalBlocks(); }

 private:
  struct Level;
  struct Smoother;
  bool factorSmoother(const BlockMatrixView& a, Smoother& s, bool threaded) const;
  void copyBlocks(const BlockMatrixView& a, Smoother& s, bool threaded) const;
  void arrangeInterpolation(std::size_t level);
  /// Analyses `a` as the coarsest level; whether its factor is small enough against a fine
  /// matrix of `fineBlocks` blocks (MultigridParams::maxCoarsestFill).
  bool analyseCoarsest(const BlockMatrixView& a, std::size_t fineBlocks);
  bool factorCoarsest(const BlockMatrixView& a, bool threaded);
  void groupRows(const BlockMatrixView& a, Smoother& s) const;
  /// The smoother's copy of `a`'s pattern by positions, with its split points around groups.
  static void copyPattern(const BlockMatrixView& a, Smoother& s);
  void galerkin(std::size_t level, bool threaded);
  void cycle(std::size_t level, bool threaded);

  MultigridParams params_;
  std::vector<std::unique_ptr<Level>> levels_;
  /// The coarsest level's factor, its pattern (analysed once per hierarchy) and, for a
  /// hierarchy of one level, a copy of the fine blocks it was made from.
  BlockCholesky coarsest_;
  BlockSparsity coarsestPattern_;
  std::vector<Eigen::Matrix3d> coarsestBlocks_;
  bool analysed_ = false;
  bool valid_ = false;
  const BlockMatrixView* fine_ = nullptr;  ///< level 0's matrix during setup() and apply()
  /// The fine matrix of the last setup() or updateFine() (borrowed; a copy has none) and
  /// their `threaded`, for apply(r, z).
  BlockMatrixView operator_;
  bool threaded_ = true;
};

}  // namespace voxcut
