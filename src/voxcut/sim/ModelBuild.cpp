#include "voxcut/sim/ModelBuild.h"

#include "voxcut/core/Parallel.h"
#include "voxcut/surface/DualContour.h"
#include "voxcut/voxel/Pieces.h"

namespace voxcut {

ModelStats countModel(const VoxelGrid& grid, bool threaded) {
  const Index3 d = grid.dims();
  const std::size_t nMat = grid.materialNames().size();
  struct Count {
    std::vector<std::size_t> perMaterial;
    std::size_t connected = 0, surface = 0, cut = 0, interface = 0;
  };
  std::vector<Count> slices(static_cast<std::size_t>(d.z));
  parallelFor(
      0, slices.size(), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z) {
          Count& c = slices[z];
          c.perMaterial.assign(nMat + 1, 0);
          for (int y = 0; y < d.y; ++y)
            for (int x = 0; x < d.x; ++x) {
              const Index3 ci{x, y, static_cast<int>(z)};
              const std::size_t v = grid.index(ci);
              const std::uint8_t m0 = grid.material(v);
              ++c.perMaterial[m0 <= nMat ? m0 : 0];
              for (int a = 0; a < 3; ++a) {
                if (ci[a] + 1 >= d[a]) continue;
                const std::uint8_t m1 = grid.material(v + grid.stride(a));
                if (m0 == 0 && m1 == 0) continue;
                if (grid.connected(v, a)) {
                  ++c.connected;
                  if (m0 != m1) ++c.interface;
                } else if (m0 != 0 && m1 != 0) {
                  ++c.cut;
                } else {
                  ++c.surface;
                }
              }
            }
        }
      },
      threaded);
  ModelStats s;
  std::vector<std::size_t> perMaterial(nMat + 1, 0);
  for (const auto& c : slices) {
    for (std::size_t m = 0; m <= nMat; ++m) perMaterial[m] += c.perMaterial[m];
    s.connectedLinks += c.connected;
    s.surfaceLinks += c.surface;
    s.cutLinks += c.cut;
    s.interfaceLinks += c.interface;
  }
  for (std::size_t m = 1; m <= nMat; ++m) {
    s.voxelsPerMaterial.emplace_back(grid.materialNames()[m - 1], perMaterial[m]);
    s.voxels += perMaterial[m];
  }
  s.bytes = grid.bytes();
  return s;
}

MemoryEstimate estimateModelMemory(const Model& model, const MemoryEstimateParams& params) {
  return model.volume ? estimateModelMemory(*model.volume, model.labels, params)
                      : estimateModelMemory(model.materials, params);
}

ModelBuild buildModel(const Model& model, const ModelBuildParams& params) {
  ModelBuild out;
  out.volume = model.volume;
  MemoryEstimateParams mp;
  mp.resolution = params.voxelize.resolution;
  mp.maxVoxels = params.voxelize.maxVoxels;
  mp.octrees = params.octrees;
  mp.elementLevel = params.deformation.startLevel;
  mp.surfaceLevel = params.deformation.surfaceLevel;
  out.memory = estimateModelMemory(model, mp);
  checkMemory(out.memory, params.maxMemory, "model");
  Timer timer;
  VoxelizeParams vp = params.voxelize;
  vp.threaded = params.threaded;
  out.grid = voxelizeModel(model, vp, &out.voxelizeReport, &out.resampleReport);
  out.timings.emplace_back("voxelize", timer.ms());

  timer.restart();
  for (const Plane& p : params.cuts) cutWithPlane(out.grid, p, params.threaded);
  out.timings.emplace_back("cut", timer.ms());

  timer.restart();
  out.surface = dualContour(out.grid, {.qefThreshold = 0.1, .threaded = params.threaded});
  out.timings.emplace_back("contour", timer.ms());

  timer.restart();
  out.stats = countModel(out.grid, params.threaded);
  out.stats.pieces = findPieces(out.grid).count;
  out.timings.emplace_back("pieces", timer.ms());

  timer.restart();
  out.stats.topology = surfaceTopology(out.surface);
  out.timings.emplace_back("topology", timer.ms());
  if (!params.octrees) return out;

  timer.restart();
  OctreeParams op = params.octree;
  if (op.maxInternalLevel.empty())
    op = OctreeParams::uniform(out.grid.materialNames().size(), 4, 0);
  const VoxelOctree octree = buildVoxelOctree(out.grid, op, params.threaded);
  out.stats.octreeCubes = octree.cubesPerLevel();
  out.stats.activeVoxels = octree.activeVoxels.size();
  out.stats.activeLinks = octree.activeLinkCount();
  out.timings.emplace_back("voxel_octree", timer.ms());

  timer.restart();
  DeformationOctreeParams dp = params.deformation;
  dp.threaded = params.threaded;
  const DeformationOctree def = buildDeformationOctree(out.grid, dp);
  out.stats.deformationElements = def.elementCountPerLevel();
  out.stats.deformationNodes = def.nodeCountPerLevel();
  out.stats.hangingNodes = def.hangingNodeCount();
  out.timings.emplace_back("deformation_octree", timer.ms());
  return out;
}

}  // namespace voxcut
