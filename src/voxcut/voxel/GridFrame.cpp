#include "voxcut/voxel/GridFrame.h"

#include <cmath>
#include <sstream>

#include "voxcut/core/Error.h"

namespace voxcut {

GridFrame gridFrameFor(const std::array<Vec3d, 2>& bounds, const Resolution& res,
                       std::size_t maxVoxels) {
  const Vec3d lo = bounds[0], hi = bounds[1];
  if (!lo.allFinite() || !hi.allFinite() || (hi - lo).minCoeff() < 0)
    throw InputError("model has no finite extent");
  const Vec3d ext = hi - lo;
  const double longest = ext.maxCoeff();
  if (!(longest > 0)) throw InputError("model has zero extent");

  double h = res.voxelSize;
  if (h != 0.0) {
    if (!(h > 0) || !std::isfinite(h)) throw InputError("voxel size must be a positive number");
  } else {
    if (res.resolution < 3) {
      std::ostringstream os;
      os << "resolution " << res.resolution
         << " is too small: it counts voxels along the longest side including one empty voxel "
            "of padding on each end, so it must be at least 3";
      throw InputError(os.str());
    }
    h = longest / (res.resolution - 2);
  }
  GridFrame f;
  f.voxelSize = h;
  double total = 1.0;
  for (int a = 0; a < 3; ++a) {
    // The grid is centred on the model, so its voxel centres sit at integer offsets from the
    // centre when n is odd and at half-integer offsets when n is even. Take the parity whose
    // count of centres inside the extent is nearest ext/h (ties: the larger), then one voxel
    // of padding on each side: flat faces are then not all rounded outward.
    const double m = ext[a] / h;
    const double oddCount = 2.0 * std::ceil(m / 2.0 - 1e-9) - 1.0;
    const double evenCount = 2.0 * std::ceil((m - 1.0) / 2.0 - 1e-9);
    const double inside =
        std::abs(oddCount - m) < std::abs(evenCount - m) ||
                (std::abs(oddCount - m) == std::abs(evenCount - m) && oddCount > evenCount)
            ? oddCount
            : evenCount;
    const double n = std::max(inside, 0.0) + 2.0;
    total *= n;
    if (n > 2e9 || total > static_cast<double>(maxVoxels)) {
      std::ostringstream os;
      os << "voxel size " << h << " m would need more than " << maxVoxels
         << " voxels; lower the resolution or raise the voxel size";
      throw InputError(os.str());
    }
    f.dims[a] = static_cast<int>(n);
    f.origin[a] = 0.5 * (lo[a] + hi[a]) - 0.5 * (n - 1) * h;
  }
  return f;
}

}  // namespace voxcut
