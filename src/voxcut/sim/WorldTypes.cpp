#include "voxcut/sim/WorldTypes.h"

namespace voxcut {

const char* solverChoiceName(SolverChoice c) {
  switch (c) {
    case SolverChoice::Automatic: return "auto";
    case SolverChoice::Cholesky: return "cholesky";
    case SolverChoice::Multigrid: return "multigrid";
    case SolverChoice::Jacobi: return "jacobi";
    case SolverChoice::BlockJacobi: return "block_jacobi";
    case SolverChoice::SymmetricGaussSeidel: return "symmetric_gauss_seidel";
    case SolverChoice::IncompleteCholesky: return "incomplete_cholesky";
    case SolverChoice::TwoLevel: return "two_level";
  }
  return "?";
}

}  // namespace voxcut
