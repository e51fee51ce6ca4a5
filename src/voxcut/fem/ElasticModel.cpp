#include "voxcut/fem/ElasticModel.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/fem/Corotation.h"
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

/// Which rows of the new sparsity are copies of old rows, and how to renumber them.
struct ElasticModel::SparsityReuse {
  const BlockSparsity* old = nullptr;
  std::vector<std::uint32_t> oldRow;     ///< per new row: the old row to copy, or kNotFree
  std::vector<std::uint32_t> newColumn;  ///< per old free index: the new one (kNotFree: gone)
  std::uint32_t oldMassBase = 0;         ///< 64 * old #elements
};

ElasticModel::SparsityReuse ElasticModel::sparsityReuse(
    const TopologyChange& change, const WeightedRows& oldProlongation,
    const WeightedRows& oldRestriction, const WeightedRows& oldIncidence,
    const std::vector<std::uint32_t>& oldFreeNodes, std::size_t oldElementCount) const {
  const std::size_t nodes = nodeCount(), oldNodes = oldProlongation.rows();
  // A node is unchanged when it is the old node of the same id (one source, itself), meets the
  // same element corners (kept elements keep their index) and has the same prolongation row
  // (the same free nodes, by id, with the same weights). Any other node is changed.
  std::vector<std::uint8_t> near(nodes, 0);
  parallelFor(
      0, nodes, 256,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t n = b; n < end; ++n) {
          const NodeSource& src = change.nodeSource[n];
          bool same = n < oldNodes && src.count == 1 && src.nodes[0] == n;
          if (same) {
            const std::uint32_t i0 = incidence_.start[n], i1 = incidence_.start[n + 1];
            const std::uint32_t o0 = oldIncidence.start[n], o1 = oldIncidence.start[n + 1];
            same = i1 - i0 == o1 - o0 &&
                   std::equal(incidence_.index.begin() + i0, incidence_.index.begin() + i1,
                              oldIncidence.index.begin() + o0);
          }
          if (same) {
            const std::uint32_t p0 = prolongation_.start[n], p1 = prolongation_.start[n + 1];
            const std::uint32_t o0 = oldProlongation.start[n];
            same = p1 - p0 == oldProlongation.start[n + 1] - o0;
            for (std::uint32_t k = 0; same && k < p1 - p0; ++k)
              same = freeNodes_[prolongation_.index[p0 + k]] ==
                         oldFreeNodes[oldProlongation.index[o0 + k]] &&
                     prolongation_.weight[p0 + k] == oldProlongation.weight[o0 + k];
          }
          near[n] = same ? 0 : 1;
        }
      },
      threaded_);
  // Widen by one ring of elements: a node all of whose elements have only unchanged corners
  // gathers exactly what it gathered before. (An element with a changed corner marks all its
  // corners; a new element's corners are changed, their incidence differs.)
  std::vector<std::uint8_t> ring = near;
  for (const auto& corners : elementNodes_)
    if (std::any_of(corners.begin(), corners.end(), [&](std::uint32_t n) { return near[n]; }))
      for (std::uint32_t n : corners) ring[n] = 1;

  SparsityReuse reuse;
  reuse.oldMassBase = static_cast<std::uint32_t>(64 * oldElementCount);
  reuse.newColumn.assign(oldFreeNodes.size(), kNotFree);
  for (std::size_t j = 0; j < oldFreeNodes.size(); ++j)
    if (oldFreeNodes[j] < nodes) reuse.newColumn[j] = freeIndex_[oldFreeNodes[j]];
  // Row i is copied when every node restricting to it, now and before, is an unchanged node
  // outside the ring (then the free node itself is one, and so was free before).
  const std::size_t free = freeNodes_.size();
  reuse.oldRow.assign(free, kNotFree);
  std::vector<std::uint32_t> oldFreeIndex(oldNodes, kNotFree);
  for (std::size_t j = 0; j < oldFreeNodes.size(); ++j)
    oldFreeIndex[oldFreeNodes[j]] = static_cast<std::uint32_t>(j);
  parallelFor(
      0, free, 256,
      [&](std::size_t b, std::size_t end) {
        for (std::size_t i = b; i < end; ++i) {
          const std::uint32_t f = freeNodes_[i];
          if (ring[f] != 0 || f >= oldNodes) continue;
          const std::uint32_t io = oldFreeIndex[f];
          if (io == kNotFree) continue;
          bool clean = true;
          for (std::uint32_t r = restriction_.start[i]; clean && r < restriction_.start[i + 1]; ++r)
            clean = ring[restriction_.index[r]] == 0;
          for (std::uint32_t r = oldRestriction.start[io];
               clean && r < oldRestriction.start[io + 1]; ++r) {
            const std::uint32_t n = oldRestriction.index[r];
            clean = n < nodes && ring[n] == 0;
          }
          if (clean) reuse.oldRow[i] = io;
        }
      },
      threaded_);
  return reuse;
}

void ElasticModel::buildSparsity(const SparsityReuse* reuse) {
  const std::size_t rows = freeNodes_.size();
  const auto massBase = static_cast<std::uint32_t>(64 * elementNodes_.size());
  VOXCUT_ASSERT(64 * elementNodes_.size() + nodeCount() < 0xffffffffull,
                "too many elements for 32-bit block sources");
  // Row i of P^T A P gathers, for every node n that restricts to i (weight wn): every element
  // corner a at n, coupled to every corner b and through P to free node j (weight wj); and
  // n's mass, coupled through P to free node j.
  // Per row: its columns ascending, and per column on or above the diagonal the sources in
  // the order they are met (restriction, incidence, corner, prolongation order: fixed, so
  // assembly sums are too); the blocks below the diagonal get none.
  // Three passes: (1) the rows are cut into fixed chunks, and each gathers its rows into its
  // part (flat arrays), except the rows copied from the old sparsity (SparsityReuse);
  // (2) every row's offsets, in row order; (3) each chunk writes its rows in place, gathered
  // or copied. Nothing depends on the partition or the thread count.
  struct Part {
    std::vector<std::uint32_t> rowEnd;     // per row: end of its columns in `column`
    std::vector<std::uint32_t> column;     // per gathered row, ascending
    std::vector<std::uint32_t> sourceEnd;  // per column: end of its sources in `source`
    std::vector<std::uint32_t> source;
    std::vector<double> weight;
  };
  struct Entry {
    std::uint32_t column, source;
    double weight;
  };
  auto copied = [&](std::size_t i) { return reuse != nullptr && reuse->oldRow[i] != kNotFree; };
  constexpr std::size_t kRowsPerPart = 32;
  std::vector<Part> parts((rows + kRowsPerPart - 1) / kRowsPerPart);
  parallelFor(
      0, parts.size(), 1,
      [&](std::size_t pb, std::size_t pe) {
        std::vector<std::uint32_t> position(rows, kNotFree);  // column -> index in the row
        std::vector<std::uint32_t> columns, fill;
        std::vector<Entry> entries;
        for (std::size_t pi = pb; pi < pe; ++pi) {
          Part& part = parts[pi];
          const std::size_t end = std::min(rows, (pi + 1) * kRowsPerPart);
          for (std::size_t i = pi * kRowsPerPart; i < end; ++i) {
            if (copied(i)) {
              part.rowEnd.push_back(static_cast<std::uint32_t>(part.column.size()));
              continue;
            }
            entries.clear();
            columns.clear();
            // A column left of the diagonal only needs noting: the assembly sums the blocks on
            // and above the diagonal and mirrors the others, so only those keep sources.
            auto add = [&](std::uint32_t column, std::uint32_t source, double weight) {
              if (position[column] == kNotFree) {
                position[column] = 0;
                columns.push_back(column);
              }
              if (column >= i) entries.push_back({column, source, weight});
            };
            for (std::uint32_t r = restriction_.start[i]; r < restriction_.start[i + 1]; ++r) {
              const std::uint32_t n = restriction_.index[r];
              const double wn = restriction_.weight[r];
              for (std::uint32_t k = incidence_.start[n]; k < incidence_.start[n + 1]; ++k) {
                const std::uint32_t e = incidence_.index[k] / 8, a = incidence_.index[k] % 8;
                for (std::uint32_t c = 0; c < 8; ++c) {
                  const std::uint32_t nb = elementNodes_[e][c];
                  for (std::uint32_t p = prolongation_.start[nb]; p < prolongation_.start[nb + 1];
                       ++p)
                    add(prolongation_.index[p], 64 * e + 8 * a + c, wn * prolongation_.weight[p]);
                }
              }
              for (std::uint32_t p = prolongation_.start[n]; p < prolongation_.start[n + 1]; ++p)
                add(prolongation_.index[p], massBase + n, wn * prolongation_.weight[p]);
            }
            // Distinct columns ascending; then the entries bucketed by column, in order.
            std::sort(columns.begin(), columns.end());
            fill.assign(columns.size() + 1, 0);
            for (std::size_t k = 0; k < columns.size(); ++k)
              position[columns[k]] = static_cast<std::uint32_t>(k);
            for (const Entry& en : entries) ++fill[position[en.column] + 1];
            const auto base = static_cast<std::uint32_t>(part.source.size());
            for (std::size_t k = 0; k < columns.size(); ++k) {
              fill[k + 1] += fill[k];
              part.column.push_back(columns[k]);
              part.sourceEnd.push_back(base + fill[k + 1]);
            }
            part.rowEnd.push_back(static_cast<std::uint32_t>(part.column.size()));
            part.source.resize(base + entries.size());
            part.weight.resize(base + entries.size());
            for (const Entry& en : entries) {
              const std::uint32_t at = base + fill[position[en.column]]++;
              part.source[at] = en.source;
              part.weight[at] = en.weight;
            }
            for (std::uint32_t j : columns) position[j] = kNotFree;
          }
        }
      },
      threaded_);

  // Offsets: each row's first block, and the first source of each row's first block.
  std::vector<std::uint64_t> rowSource(rows + 1, 0);
  sparsity_ = BlockSparsity{};
  sparsity_.rowStart.assign(rows + 1, 0);
  for (std::size_t pi = 0; pi < parts.size(); ++pi) {
    const Part& part = parts[pi];
    std::uint32_t k = 0;  // the part's blocks before this row
    for (std::size_t r = 0; r < part.rowEnd.size(); ++r) {
      const std::size_t i = pi * kRowsPerPart + r;
      std::uint64_t blocks = 0, sources = 0;
      if (copied(i)) {
        const BlockSparsity& old = *reuse->old;
        const std::uint32_t io = reuse->oldRow[i];
        blocks = old.rowStart[io + 1] - old.rowStart[io];
        sources = old.sourceStart[old.rowStart[io + 1]] - old.sourceStart[old.rowStart[io]];
      } else {
        blocks = part.rowEnd[r] - k;
        if (blocks > 0)
          sources = part.sourceEnd[part.rowEnd[r] - 1] - (k > 0 ? part.sourceEnd[k - 1] : 0);
        k = part.rowEnd[r];
      }
      const std::uint64_t next = sparsity_.rowStart[i] + blocks;
      rowSource[i + 1] = rowSource[i] + sources;
      VOXCUT_ASSERT(next < 0xffffffffull && rowSource[i + 1] < 0xffffffffull,
                    "too many blocks or block sources for 32-bit offsets");
      sparsity_.rowStart[i + 1] = static_cast<std::uint32_t>(next);
    }
  }
  const std::size_t blockCount = sparsity_.rowStart[rows];
  sparsity_.diagonal.assign(rows, kNotFree);
  sparsity_.column.resize(blockCount);
  sparsity_.sourceStart.resize(blockCount + 1);
  sparsity_.sourceStart[0] = 0;
  sparsity_.source.resize(rowSource[rows]);
  sparsity_.sourceWeight.resize(rowSource[rows]);
  std::vector<std::size_t> reused(parts.size(), 0);
  parallelFor(
      0, parts.size(), 1,
      [&](std::size_t pb, std::size_t pe) {
        for (std::size_t pi = pb; pi < pe; ++pi) {
          const Part& part = parts[pi];
          std::uint32_t k = 0;  // next block of the part
          for (std::size_t r = 0; r < part.rowEnd.size(); ++r) {
            const std::size_t i = pi * kRowsPerPart + r;
            std::uint32_t slot = sparsity_.rowStart[i];
            const auto sourceBase = static_cast<std::uint32_t>(rowSource[i]);
            if (copied(i)) {
              // An unchanged neighbourhood: the old row, renumbered. Free nodes keep their
              // order (node-grid order, ids kept), so the columns stay ascending and on the
              // same side of the diagonal; node n's mass moves with the mass base.
              const BlockSparsity& old = *reuse->old;
              const std::uint32_t io = reuse->oldRow[i];
              const std::uint32_t s0 = old.rowStart[io], s1 = old.rowStart[io + 1];
              const std::uint32_t k0 = old.sourceStart[s0], k1 = old.sourceStart[s1];
              for (std::uint32_t s = s0; s < s1; ++s, ++slot) {
                const std::uint32_t column = reuse->newColumn[old.column[s]];
                VOXCUT_ASSERT(column != kNotFree, "a copied row couples to a node no longer free");
                sparsity_.column[slot] = column;
                sparsity_.sourceStart[slot + 1] = old.sourceStart[s + 1] - k0 + sourceBase;
              }
              std::copy(old.sourceWeight.begin() + k0, old.sourceWeight.begin() + k1,
                        sparsity_.sourceWeight.begin() + sourceBase);
              for (std::uint32_t at = k0; at < k1; ++at) {
                const std::uint32_t src = old.source[at];
                sparsity_.source[sourceBase + at - k0] =
                    src < reuse->oldMassBase ? src : src - reuse->oldMassBase + massBase;
              }
              ++reused[pi];
            } else {
              const std::uint32_t partSource = k > 0 ? part.sourceEnd[k - 1] : 0;
              for (; k < part.rowEnd[r]; ++k, ++slot) {
                sparsity_.column[slot] = part.column[k];
                sparsity_.sourceStart[slot + 1] = part.sourceEnd[k] - partSource + sourceBase;
              }
              const std::uint32_t partEnd = k > 0 ? part.sourceEnd[k - 1] : 0;
              std::copy(part.source.begin() + partSource, part.source.begin() + partEnd,
                        sparsity_.source.begin() + sourceBase);
              std::copy(part.weight.begin() + partSource, part.weight.begin() + partEnd,
                        sparsity_.sourceWeight.begin() + sourceBase);
            }
            for (std::uint32_t s = sparsity_.rowStart[i]; s < slot; ++s)
              if (sparsity_.column[s] == i) sparsity_.diagonal[i] = s;
          }
        }
      },
      threaded_);
  for (std::size_t i = 0; i < rows; ++i)
    VOXCUT_ASSERT(sparsity_.diagonal[i] != kNotFree, "a free node without its diagonal block");
  sparsity_.mirror = blockMirrors(sparsity_);
  sparsityRowsReused_ = 0;
  for (std::size_t r : reused) sparsityRowsReused_ += r;
  static std::atomic<std::uint64_t> revisions{0};
  sparsityRevision_ = ++revisions;
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
