#include "voxcut/io/SceneBodies.h"

#include <string>

#include "voxcut/core/Error.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/io/StrictJson.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {

std::vector<VoxelGrid> voxelizeSceneBodies(const Scene& scene, bool threaded,
                                           const ProgressCallback& progress) {
  std::vector<VoxelGrid> grids;
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const Model model = loadBodyModel(scene, i);
    VoxelizeParams vp;
    vp.resolution.resolution = scene.bodies[i].resolution.value_or(model.defaultResolution);
    vp.threaded = threaded;
    vp.progress = progress;
    // Paths may hold control characters; detail::oneLine keeps each message one line.
    const std::string body = detail::oneLine(scene.source + ": bodies[" + std::to_string(i) + "]");
    try {
      grids.push_back(voxelize(model.materials, vp));
    } catch (const InputError& e) {
      throw InputError(body + ": " + e.what());
    }
    requireVoxels(grids.back(), body + " (model '" + detail::oneLine(scene.bodies[i].model) + "')");
  }
  return grids;
}

}  // namespace voxcut
