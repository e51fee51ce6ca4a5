#include "voxcut/voxel/Model.h"

namespace voxcut {

std::vector<std::string> Model::materialNames() const {
  std::vector<std::string> names;
  if (volume) {
    for (const LabelChoice& c : labels.empty() ? defaultLabelChoices(*volume) : labels)
      names.push_back(c.name);
    return names;
  }
  for (const MaterialMesh& m : materials) names.push_back(m.name);
  return names;
}

VoxelGrid voxelizeModel(const Model& model, const VoxelizeParams& params,
                        VoxelizeReport* meshReport, LabelResampleReport* volumeReport) {
  if (!model.volume) return voxelize(model.materials, params, meshReport);
  LabelResampleParams rp;
  rp.resolution = params.resolution;
  rp.labels = model.labels;
  rp.minIsland = model.minIsland;
  rp.maxVoxels = params.maxVoxels;
  rp.threaded = params.threaded;
  rp.progress = params.progress;
  return resampleLabels(*model.volume, rp, volumeReport);
}

}  // namespace voxcut
