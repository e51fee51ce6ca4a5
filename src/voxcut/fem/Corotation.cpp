#include "voxcut/fem/Corotation.h"

#include <array>

#include "voxcut/fem/HexElement.h"

namespace voxcut {

Corotation corotation(const DeformationOctree& octree, std::uint32_t e,
                      const std::array<Vec3d, 8>& gradientMean) {
  const OctreeElement& el = octree.element(e);
  std::array<Vec3d, 8> x, rest;
  for (std::size_t c = 0; c < 8; ++c) {
    x[c] = octree.positions()[el.nodes[c]];
    rest[c] = octree.restPositions()[el.nodes[c]];
  }
  Corotation out;
  out.rotation = polarRotation(
      materialDeformationGradient(x, rest, gradientMean, octree.voxelSize() * el.size()));
  out.displacement = corotatedDisplacement(out.rotation, x, rest);
  return out;
}

}  // namespace voxcut
