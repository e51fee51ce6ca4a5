#include "voxcut/fem/ImplicitEulerParams.h"

namespace voxcut {

const char* preconditionerName(PreconditionerKind p) {
  switch (p) {
    case PreconditionerKind::Jacobi:
      return "jacobi";
    case PreconditionerKind::BlockJacobi:
      return "block_jacobi";
    case PreconditionerKind::SymmetricGaussSeidel:
      return "symmetric_gauss_seidel";
    case PreconditionerKind::IncompleteCholesky:
      return "incomplete_cholesky";
    case PreconditionerKind::TwoLevel:
      return "two_level";
    case PreconditionerKind::Cholesky:
      return "cholesky";
    case PreconditionerKind::Multigrid:
      return "multigrid";
    case PreconditionerKind::Automatic:
      return "auto";
  }
  return "unknown";
}

}  // namespace voxcut
