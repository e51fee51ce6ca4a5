#include "voxcut/io/SceneBodies.h"

#include <string>

#include "voxcut/core/Error.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/io/StrictJson.h"
#include "voxcut/sim/MemoryEstimate.h"
#include "voxcut/sim/ModelBuild.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

// The body's key path for messages; paths may hold control characters, and detail::oneLine
// keeps each message one line.
std::string bodyKey(const Scene& scene, std::size_t i) {
  return detail::oneLine(scene.source + ": bodies[" + std::to_string(i) + "]");
}

// Refuses the scene when the bodies' estimates add up to more than params.maxMemory.
void checkSceneMemory(const Scene& scene, const std::vector<Model>& models,
                      const std::vector<VoxelizeParams>& settings,
                      const SceneBodiesParams& params) {
  if (params.maxMemory == 0) return;
  MemoryEstimate total, largest;
  std::size_t largestBody = 0;
  for (std::size_t i = 0; i < models.size(); ++i) {
    MemoryEstimateParams mp;
    mp.resolution = settings[i].resolution;
    mp.maxVoxels = settings[i].maxVoxels;
    mp.cutting = true;
    mp.simulation = true;
    mp.allActive = !params.useOctree;
    // Automatic factors the bodies it can afford to: the estimate counts the factor.
    mp.factor = scene.solver.preconditioner == SolverChoice::Cholesky ||
                scene.solver.preconditioner == SolverChoice::Automatic;
    mp.elementLevel = scene.bodies[i].elementLevel;
    mp.surfaceLevel = scene.bodies[i].surfaceLevel;
    MemoryEstimate e;
    try {
      e = estimateModelMemory(models[i], mp);
    } catch (const InputError& err) {
      throw InputError(bodyKey(scene, i) + ": " + err.what());
    }
    total.bytes += e.bytes;
    if (i == 0 || e.bytes > largest.bytes) {
      largest = e;
      largestBody = i;
    }
  }
  MemoryEstimate named = largest;
  named.bytes = total.bytes;
  checkMemory(named, params.maxMemory,
              bodyKey(scene, largestBody) + (models.size() > 1 ? " with the other bodies" : ""));
}

}  // namespace

std::vector<VoxelGrid> voxelizeSceneBodies(const Scene& scene, const SceneBodiesParams& params) {
  std::vector<Model> models;
  std::vector<VoxelizeParams> settings;
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    models.push_back(loadBodyModel(scene, i));
    VoxelizeParams vp;
    vp.resolution.resolution = scene.bodies[i].resolution.value_or(models.back().defaultResolution);
    vp.threaded = params.threaded;
    vp.progress = params.progress;
    settings.push_back(std::move(vp));
  }
  checkSceneMemory(scene, models, settings, params);
  std::vector<VoxelGrid> grids;
  for (std::size_t i = 0; i < models.size(); ++i) {
    try {
      grids.push_back(voxelizeModel(models[i], settings[i]));
    } catch (const InputError& e) {
      throw InputError(bodyKey(scene, i) + ": " + e.what());
    }
    requireVoxels(grids.back(),
                  bodyKey(scene, i) + " (model '" + detail::oneLine(scene.bodies[i].model) + "')");
  }
  return grids;
}

std::vector<VoxelGrid> voxelizeSceneBodies(const Scene& scene, bool threaded,
                                           const ProgressCallback& progress) {
  SceneBodiesParams params;
  params.threaded = threaded;
  params.progress = progress;
  return voxelizeSceneBodies(scene, params);
}

}  // namespace voxcut
