#include "voxcut/fem/ElasticModel.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/fem/Corotation.h"
#include "voxcut/fem/ElasticModelSparsity.h"
#include "voxcut/linalg/SparseRows.h"

namespace voxcut {

namespace {

void checkMaterials(const std::vector<ElasticMaterial>& materials) {
  for (std::size_t m = 1; m < materials.size(); ++m) {
    const ElasticMaterial& mat = materials[m];
    const std::string name = "material " + std::to_string(m) + ": ";
    if (!(mat.youngModulus > 0.0) || !std::isfinite(mat.youngModulus))
      throw InputError(name + "young_modulus must be a finite number > 0");
    if (!(mat.poissonRatio > -1.0 && mat.poissonRatio < 0.5))
      throw InputError(name + "poisson_ratio must lie in (-1, 0.5)");
    if (!(mat.density > 0.0) || !std::isfinite(mat.density))
      throw InputError(name + "density must be a finite number > 0");
    if (!(mat.dampingMass >= 0.0) || !(mat.dampingStiffness >= 0.0) ||
        !std::isfinite(mat.dampingMass) || !std::isfinite(mat.dampingStiffness))
      throw InputError(name + "damping factors must be finite numbers >= 0");
  }
}

}  // namespace

ElasticModel::ElasticModel(const DeformationOctree& octree, const VoxelGrid& grid,
                           std::vector<ElasticMaterial> materials, bool threaded)
    : materials_(std::move(materials)), threaded_(threaded) {
  checkMaterials(materials_);
  VOXCUT_ASSERT(grid.voxelCount() == static_cast<std::size_t>(octree.gridDims().x) *
                                         static_cast<std::size_t>(octree.gridDims().y) *
                                         static_cast<std::size_t>(octree.gridDims().z),
                "the grid is not the octree's");
  elementNodes_.reserve(octree.elementCount());
  for (const OctreeElement& el : octree.elements()) elementNodes_.push_back(el.nodes);
  copyNodeCoords(octree);
  hanging_ = octree.hangingNodes();
  elements_.resize(octree.elementCount());
  std::vector<std::uint32_t> all(octree.elementCount());
  for (std::size_t e = 0; e < all.size(); ++e) all[e] = static_cast<std::uint32_t>(e);
  computeElements(octree, grid, all);
  requested_.assign(octree.nodeCount(), 0);
  buildNodeData();
  buildConstraints();
  buildSparsity(nullptr);
}

void ElasticModel::copyNodeCoords(const DeformationOctree& octree) {
  nodeCoord_.resize(octree.nodeCount());
  for (std::size_t n = 0; n < nodeCoord_.size(); ++n)
    nodeCoord_[n] = octree.nodeCoord(static_cast<std::uint32_t>(n));
}

void ElasticModel::computeElements(const DeformationOctree& octree, const VoxelGrid& grid,
                                   const std::vector<std::uint32_t>& which) {
  // A material outside the table is bad input (the scene's); remember it per element and
  // throw after the parallel loop.
  std::vector<std::uint16_t> badMaterial(which.size(), 0);
  const Index3 dims = grid.dims();
  // Elements full of one material (every level-0 element, most after a refinement) share
  // their matrices per level and material: made once, from the same rows of voxels the scan
  // below adds for such an element, so a copy is bit-identical to computing it again.
  const std::size_t table = materials_.size();
  if (fullElements_.size() != 8 * table) {
    fullElements_.assign(8 * table, ElementMatrices{});
    fullElementMade_.assign(8 * table, 0);
  }
  for (const std::uint32_t e : which) {
    const int level = octree.element(e).level;
    VOXCUT_ASSERT(level >= 0 && level < 8, "element level out of range");
    for (std::size_t m = 1; m < table; ++m) {
      const std::size_t slot = static_cast<std::size_t>(level) * table + m;
      if (fullElementMade_[slot] != 0) continue;
      const int s = 1 << level;
      std::vector<MaterialMoments> region;
      for (int z = 0; z < s; ++z)
        for (int y = 0; y < s; ++y)
          addVoxelRow(region, level, 0, s, y, z, static_cast<std::uint8_t>(m));
      fullElements_[slot] = hexElementMatrices(level, octree.voxelSize(), region, materials_);
      fullElementMade_[slot] = 1;
    }
  }
  parallelFor(
      0, which.size(), 4,
      [&](std::size_t b, std::size_t end) {
        std::vector<MaterialMoments> region;
        for (std::size_t k = b; k < end; ++k) {
          const std::uint32_t e = which[k];
          const OctreeElement& el = octree.element(e);
          const Index3 f = el.firstVoxel();
          const int s = el.size();
          region.clear();
          std::size_t voxels = 0;
          for (int z = f.z; z < std::min(f.z + s, dims.z); ++z)
            for (int y = f.y; y < std::min(f.y + s, dims.y); ++y) {
              const int xEnd = std::min(f.x + s, dims.x);
              int x = f.x;
              while (x < xEnd) {
                // A run of voxels owned by e with one material.
                const std::size_t v = grid.index(x, y, z);
                if (octree.owner(v) != e) {
                  ++x;
                  continue;
                }
                const std::uint8_t m = grid.material(v);
                int x1 = x + 1;
                while (x1 < xEnd && octree.owner(v + static_cast<std::size_t>(x1 - x)) == e &&
                       grid.material(v + static_cast<std::size_t>(x1 - x)) == m)
                  ++x1;
                if (m == 0 || m >= materials_.size()) {
                  badMaterial[k] = static_cast<std::uint16_t>(m == 0 ? 256 : m);
                } else {
                  addVoxelRow(region, el.level, x - f.x, x1 - x, y - f.y, z - f.z, m);
                  voxels += static_cast<std::size_t>(x1 - x);
                }
                x = x1;
              }
            }
          if (badMaterial[k] != 0) continue;
          const auto cube = static_cast<std::size_t>(s) * static_cast<std::size_t>(s) *
                            static_cast<std::size_t>(s);
          if (region.size() == 1 && voxels == cube)
            elements_[e] =
                fullElements_[static_cast<std::size_t>(el.level) * table + region[0].material];
          else
            elements_[e] = hexElementMatrices(el.level, octree.voxelSize(), region, materials_);
        }
      },
      threaded_);
  for (std::uint16_t m : badMaterial) {
    if (m == 256) throw InputError("an element holds an empty voxel (material 0)");
    if (m != 0)
      throw InputError("voxel material " + std::to_string(m) +
                       " has no elastic material (the table has " +
                       std::to_string(materials_.empty() ? 0 : materials_.size() - 1) + ")");
  }
}

void ElasticModel::buildNodeData() {
  const std::size_t nodes = requested_.size();
  // Incidence by counting sort: element-major fill keeps each row ascending in 8 e + c.
  incidence_ = WeightedRows{};
  incidence_.start.assign(nodes + 1, 0);
  for (const auto& corners : elementNodes_)
    for (std::uint32_t n : corners) ++incidence_.start[n + 1];
  for (std::size_t n = 0; n < nodes; ++n) incidence_.start[n + 1] += incidence_.start[n];
  incidence_.index.resize(incidence_.start[nodes]);
  incidence_.weight.assign(incidence_.start[nodes], 1.0);
  std::vector<std::uint32_t> fill(incidence_.start.begin(), incidence_.start.end() - 1);
  for (std::size_t e = 0; e < elementNodes_.size(); ++e)
    for (std::uint32_t c = 0; c < 8; ++c)
      incidence_.index[fill[elementNodes_[e][c]]++] = static_cast<std::uint32_t>(8 * e + c);

  nodeMass_.assign(nodes, 0.0);
  nodeMassDamping_.assign(nodes, 0.0);
  parallelFor(
      0, nodes, 256,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t n = b; n < end; ++n)
          for (std::uint32_t k = incidence_.start[n]; k < incidence_.start[n + 1]; ++k) {
            const std::uint32_t ec = incidence_.index[k];
            nodeMass_[n] += elements_[ec / 8].mass[ec % 8];
            nodeMassDamping_[n] += elements_[ec / 8].massDamping[ec % 8];
          }
      },
      threaded_);
}

void ElasticModel::setFixed(std::vector<std::uint8_t> fixed) {
  fixed.resize(nodeCount(), 0);
  requested_ = std::move(fixed);
  buildConstraints();
  buildSparsity(nullptr);
}

void ElasticModel::buildConstraints() {
  const std::size_t nodes = requested_.size();
  std::vector<std::uint8_t> hanging(nodes, 0), used(nodes, 0);
  for (const HangingNode& h : hanging_) hanging[h.node] = 1;
  // An element without voxels (possible in principle after a topology update) carries no
  // mass; nodes only it touches would make the system singular.
  for (std::size_t e = 0; e < elementNodes_.size(); ++e)
    if (elements_[e].volume > 0.0)
      for (std::uint32_t n : elementNodes_[e]) used[n] = 1;
  // Back to front visits dependants before their (coarser) masters, so closures propagate
  // down whole chains.
  fixed_.resize(nodes);
  for (std::size_t n = 0; n < nodes; ++n) fixed_[n] = requested_[n] != 0 ? 1 : 0;
  for (auto it = hanging_.rbegin(); it != hanging_.rend(); ++it)
    for (int m = 0; m < it->masterCount; ++m) {
      if (fixed_[it->node]) fixed_[it->masters[m]] = 1;
      if (used[it->node]) used[it->masters[m]] = 1;
    }

  // Unknowns in node-grid order (z, y, x, then node id): node copies made by cuts get their
  // place among their neighbours, which keeps the incomplete Cholesky factor as good as on an
  // uncut mesh (its quality depends on the order).
  freeNodes_.clear();
  freeIndex_.assign(nodes, kNotFree);
  for (std::size_t n = 0; n < nodes; ++n)
    if (!hanging[n] && !fixed_[n] && used[n]) freeNodes_.push_back(static_cast<std::uint32_t>(n));
  std::sort(freeNodes_.begin(), freeNodes_.end(), [&](std::uint32_t a, std::uint32_t b) {
    const Index3 &ca = nodeCoord_[a], &cb = nodeCoord_[b];
    return std::tie(ca.z, ca.y, ca.x, a) < std::tie(cb.z, cb.y, cb.x, b);
  });
  for (std::size_t i = 0; i < freeNodes_.size(); ++i)
    freeIndex_[freeNodes_[i]] = static_cast<std::uint32_t>(i);

  // Prolongation rows: a free node's is itself; hanging rows front to back (masters first),
  // each merged by free index; all kept in one arena (no list per node).
  std::vector<std::uint32_t> rowBegin(nodes, 0), rowEnd(nodes, 0);
  std::vector<std::pair<std::uint32_t, double>> arena, row;
  arena.reserve(nodes + 4 * hanging_.size());
  for (std::size_t n = 0; n < nodes; ++n) {
    rowBegin[n] = static_cast<std::uint32_t>(arena.size());
    if (freeIndex_[n] != kNotFree) arena.emplace_back(freeIndex_[n], 1.0);
    rowEnd[n] = static_cast<std::uint32_t>(arena.size());
  }
  for (const HangingNode& h : hanging_) {
    row.clear();
    const double w = 1.0 / h.masterCount;
    for (int m = 0; m < h.masterCount; ++m)
      for (std::uint32_t k = rowBegin[h.masters[m]]; k < rowEnd[h.masters[m]]; ++k)
        row.emplace_back(arena[k].first, w * arena[k].second);
    std::sort(row.begin(), row.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    rowBegin[h.node] = static_cast<std::uint32_t>(arena.size());
    for (const auto& entry : row) {
      if (arena.size() > rowBegin[h.node] && arena.back().first == entry.first)
        arena.back().second += entry.second;
      else
        arena.push_back(entry);
    }
    rowEnd[h.node] = static_cast<std::uint32_t>(arena.size());
  }
  prolongation_ = WeightedRows{};
  prolongation_.start.resize(nodes + 1, 0);
  for (std::size_t n = 0; n < nodes; ++n)
    prolongation_.start[n + 1] = prolongation_.start[n] + (rowEnd[n] - rowBegin[n]);
  prolongation_.index.resize(prolongation_.start[nodes]);
  prolongation_.weight.resize(prolongation_.start[nodes]);
  for (std::size_t n = 0; n < nodes; ++n)
    for (std::uint32_t k = rowBegin[n], at = prolongation_.start[n]; k < rowEnd[n]; ++k, ++at) {
      prolongation_.index[at] = arena[k].first;
      prolongation_.weight[at] = arena[k].second;
    }

  // Restriction = transpose, nodes ascending in each row.
  restriction_ = WeightedRows{};
  transposeRows(prolongation_.start, prolongation_.index, prolongation_.weight, freeNodes_.size(),
                restriction_.start, restriction_.index, restriction_.weight);
}

const NodeAggregation& ElasticModel::aggregation() const {
  if (aggregationRevision_ != sparsityRevision_) {
    aggregation_ = aggregateNodes(sparsity_, kAggregatePairings);
    aggregationRevision_ = sparsityRevision_;
  }
  return aggregation_;
}

void ElasticModel::updateTopology(const DeformationOctree& octree, const VoxelGrid& grid,
                                  const TopologyChange& change,
                                  const std::vector<std::uint8_t>* fixed) {
  if (!change.changed) return;
  VOXCUT_ASSERT(change.elementSource.size() == octree.elementCount(),
                "one element source per element");
  VOXCUT_ASSERT(change.nodeSource.size() == octree.nodeCount(), "one node source per node");
  // Most elements keep their index: they stay in place (an element's matrices are 4.7 kB).
  // The ones that moved are gathered first, so no source is overwritten before it is read.
  std::vector<std::uint32_t> fresh, moved;
  std::vector<ElementMatrices> movedMatrices;
  for (std::size_t e = 0; e < octree.elementCount(); ++e) {
    const std::uint32_t s = change.elementSource[e];
    if (s == kNewElement) {
      fresh.push_back(static_cast<std::uint32_t>(e));
      continue;
    }
    VOXCUT_ASSERT(s < elements_.size(), "element source out of range");
    if (s != e) {
      moved.push_back(static_cast<std::uint32_t>(e));
      movedMatrices.push_back(elements_[s]);
    }
  }
  elements_.resize(octree.elementCount());
  for (std::size_t k = 0; k < moved.size(); ++k) elements_[moved[k]] = movedMatrices[k];
  std::vector<std::uint8_t> requested(octree.nodeCount(), 0);
  if (fixed != nullptr) {
    std::copy_n(fixed->begin(), std::min(fixed->size(), requested.size()), requested.begin());
  } else {
    for (std::size_t n = 0; n < requested.size(); ++n) {
      const NodeSource& src = change.nodeSource[n];
      bool all = src.count > 0;
      for (int k = 0; k < src.count; ++k) {
        VOXCUT_ASSERT(src.nodes[k] < requested_.size(), "node source out of range");
        all = all && requested_[src.nodes[k]] != 0;
      }
      requested[n] = all ? 1 : 0;
    }
  }
  const std::size_t oldElementCount = elementNodes_.size();
  elementNodes_.clear();
  for (const OctreeElement& el : octree.elements()) elementNodes_.push_back(el.nodes);
  copyNodeCoords(octree);
  hanging_ = octree.hangingNodes();
  requested_ = std::move(requested);
  computeElements(octree, grid, fresh);
  const WeightedRows oldIncidence = std::move(incidence_);
  const WeightedRows oldProlongation = std::move(prolongation_);
  const WeightedRows oldRestriction = std::move(restriction_);
  const std::vector<std::uint32_t> oldFreeNodes = std::move(freeNodes_);
  const BlockSparsity oldSparsity = std::move(sparsity_);
  buildNodeData();
  buildConstraints();
  SparsityReuse reuse = sparsityReuse(change, oldProlongation, oldRestriction, oldIncidence,
                                      oldFreeNodes, oldElementCount);
  reuse.old = &oldSparsity;
  buildSparsity(&reuse);
}

double ElasticModel::totalMass() const {
  double sum = 0.0;
  for (double m : nodeMass_) sum += m;
  return sum;
}

// ---------------------------------------------------------------------------------------------
// Forces, energy, global matrices
// ---------------------------------------------------------------------------------------------

namespace {

void checkInStep(const ElasticModel& model, const DeformationOctree& octree) {
  VOXCUT_ASSERT(
      model.elementCount() == octree.elementCount() && model.nodeCount() == octree.nodeCount(),
      "the model does not match the octree (missing updateTopology?)");
}

}  // namespace

std::vector<Vec3d> elasticForces(const ElasticModel& model, const DeformationOctree& octree) {
  checkInStep(model, octree);
  std::vector<std::array<Vec3d, 8>> perElement(model.elementCount());
  parallelFor(
      0, model.elementCount(), 16,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t e = b; e < end; ++e) {
          const Corotation co =
              corotation(octree, static_cast<std::uint32_t>(e),
                         model.element(static_cast<std::uint32_t>(e)).gradientMean);
          const Eigen::Matrix<double, 24, 1> ky =
              model.element(static_cast<std::uint32_t>(e)).stiffness * co.displacement;
          for (int c = 0; c < 8; ++c)
            perElement[e][static_cast<std::size_t>(c)] = -(co.rotation * ky.segment<3>(3 * c));
        }
      },
      model.threaded());
  std::vector<Vec3d> force(model.nodeCount(), Vec3d::Zero());
  const WeightedRows& inc = model.incidence();
  parallelFor(
      0, force.size(), 256,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t n = b; n < end; ++n)
          for (std::uint32_t k = inc.start[n]; k < inc.start[n + 1]; ++k)
            force[n] += perElement[inc.index[k] / 8][inc.index[k] % 8];
      },
      model.threaded());
  return force;
}

double elasticEnergy(const ElasticModel& model, const DeformationOctree& octree) {
  checkInStep(model, octree);
  std::vector<double> energy(model.elementCount());
  parallelFor(
      0, model.elementCount(), 16,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t e = b; e < end; ++e) {
          const Eigen::Matrix<double, 24, 1> y =
              corotation(octree, static_cast<std::uint32_t>(e),
                         model.element(static_cast<std::uint32_t>(e)).gradientMean)
                  .displacement;
          energy[e] = 0.5 * y.dot(model.element(static_cast<std::uint32_t>(e)).stiffness * y);
        }
      },
      model.threaded());
  double sum = 0.0;
  for (double w : energy) sum += w;
  return sum;
}

Eigen::SparseMatrix<double> restStiffnessMatrix(const ElasticModel& model) {
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(model.elementCount() * 576);
  for (std::size_t e = 0; e < model.elementCount(); ++e) {
    const auto& k = model.element(static_cast<std::uint32_t>(e)).stiffness;
    const auto& nodes = model.elementNodes()[e];
    for (int a = 0; a < 24; ++a)
      for (int b = 0; b < 24; ++b)
        triplets.emplace_back(static_cast<int>(3 * nodes[static_cast<std::size_t>(a / 3)]) + a % 3,
                              static_cast<int>(3 * nodes[static_cast<std::size_t>(b / 3)]) + b % 3,
                              k(a, b));
  }
  const auto n = static_cast<Eigen::Index>(3 * model.nodeCount());
  Eigen::SparseMatrix<double> out(n, n);
  out.setFromTriplets(triplets.begin(), triplets.end());
  return out;
}

Eigen::SparseMatrix<double> prolongationMatrix(const ElasticModel& model) {
  std::vector<Eigen::Triplet<double>> triplets;
  const WeightedRows& p = model.prolongation();
  for (std::size_t n = 0; n < p.rows(); ++n)
    for (std::uint32_t k = p.start[n]; k < p.start[n + 1]; ++k)
      for (int a = 0; a < 3; ++a)
        triplets.emplace_back(static_cast<int>(3 * n) + a, static_cast<int>(3 * p.index[k]) + a,
                              p.weight[k]);
  Eigen::SparseMatrix<double> out(static_cast<Eigen::Index>(3 * model.nodeCount()),
                                  static_cast<Eigen::Index>(3 * model.freeNodeCount()));
  out.setFromTriplets(triplets.begin(), triplets.end());
  return out;
}

}  // namespace voxcut
