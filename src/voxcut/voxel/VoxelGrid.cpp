#include "voxcut/voxel/VoxelGrid.h"

#include <cmath>
#include <sstream>

namespace voxcut {

VoxelGrid::VoxelGrid(const Index3& dims, const Vec3d& origin, double voxelSize,
                     std::size_t maxVoxels)
    : dims_(dims), origin_(origin), voxelSize_(voxelSize) {
  if (!(voxelSize > 0.0) || !std::isfinite(voxelSize))
    throw InputError("voxel size must be a positive finite number");
  double total = 1.0;
  for (int a = 0; a < 3; ++a) {
    if (dims[a] < 1) throw InputError("grid dimensions must be positive");
    total *= dims[a];
  }
  if (total > static_cast<double>(maxVoxels)) {
    std::ostringstream os;
    os << "grid of " << dims.x << "x" << dims.y << "x" << dims.z << " voxels ("
       << static_cast<double>(total) << ") exceeds the limit of " << maxVoxels
       << " voxels; lower the resolution or raise the voxel size";
    throw InputError(os.str());
  }
  material_.assign(static_cast<std::size_t>(total), 0);
  links_.assign(static_cast<std::size_t>(total), 0);
}

}  // namespace voxcut
