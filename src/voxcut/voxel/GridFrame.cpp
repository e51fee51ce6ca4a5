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
    // Voxel centres cover the extent with half a voxel or more to spare on each side.
    const double n = std::ceil(ext[a] / h * (1.0 - 1e-12)) + 2.0;
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
