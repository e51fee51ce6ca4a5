/// @file ElasticModelSparsity.cpp
/// ElasticModel's reduced 3x3-block sparsity P^T A P with its assembly plan: which rows an
/// update can copy from the sparsity before (sparsityReuse) and the build in three passes
/// (buildSparsity).

#include <algorithm>
#include <atomic>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/fem/ElasticModelSparsity.h"
#include "voxcut/linalg/SparseRows.h"

namespace voxcut {

namespace {

/// The gathered rows of a chunk of kRowsPerPart rows of the reduced sparsity (flat arrays).
struct SparsityPart {
  std::vector<std::uint32_t> rowEnd;     // per row: end of its columns in `column`
  std::vector<std::uint32_t> column;     // per gathered row, ascending
  std::vector<std::uint32_t> sourceEnd;  // per column: end of its sources in `source`
  std::vector<std::uint32_t> source;
  std::vector<double> weight;
};

/// One source of a block met while gathering a row: its column, source id and weight.
struct SparsityEntry {
  std::uint32_t column, source;
  double weight;
};

constexpr std::size_t kRowsPerPart = 32;

/// What the rows of P^T A P gather from: the model's restriction, incidence, prolongation and
/// element corners, and the first source id of the node masses.
struct GatherSources {
  const WeightedRows& restriction;
  const WeightedRows& incidence;
  const WeightedRows& prolongation;
  const std::vector<std::array<std::uint32_t, 8>>& elementNodes;
  std::uint32_t massBase;
};

/// The rows copied from an old sparsity (ElasticModel::SparsityReuse), as the passes of
/// ElasticModel::buildSparsity read them; none when oldRow is null.
struct RowCopies {
  const BlockSparsity* old = nullptr;
  const std::uint32_t* oldRow = nullptr;     ///< per new row: the old row, or kNotFree
  const std::uint32_t* newColumn = nullptr;  ///< per old free index: the new one
  std::uint32_t oldMassBase = 0;
  [[nodiscard]] bool copied(std::size_t i) const {
    return oldRow != nullptr && oldRow[i] != kNotFree;
  }
};

/// Scratch of one task gathering rows: per column its index in the row (kNotFree when not
/// in it), the row's columns, bucket fills and entries.
struct GatherScratch {
  std::vector<std::uint32_t> position, columns, fill;
  std::vector<SparsityEntry> entries;
};

/// Gathers row i's columns and, per column on or above the diagonal, its sources in the order
/// they are met (restriction, incidence, corner, prolongation order) into `scratch`.
void gatherEntries(const GatherSources& from, std::size_t i, GatherScratch& scratch) {
  std::vector<std::uint32_t>& position = scratch.position;
  scratch.entries.clear();
  scratch.columns.clear();
  // A column left of the diagonal only needs noting: the assembly sums the blocks on and
  // above the diagonal and mirrors the others, so only those keep sources.
  auto add = [&](std::uint32_t column, std::uint32_t source, double weight) {
    if (position[column] == kNotFree) {
      position[column] = 0;
      scratch.columns.push_back(column);
    }
    if (column >= i) scratch.entries.push_back({column, source, weight});
  };
  const WeightedRows& restriction = from.restriction;
  const WeightedRows& incidence = from.incidence;
  const WeightedRows& prolongation = from.prolongation;
  for (std::uint32_t r = restriction.start[i]; r < restriction.start[i + 1]; ++r) {
    const std::uint32_t n = restriction.index[r];
    const double wn = restriction.weight[r];
    for (std::uint32_t k = incidence.start[n]; k < incidence.start[n + 1]; ++k) {
      const std::uint32_t e = incidence.index[k] / 8, a = incidence.index[k] % 8;
      for (std::uint32_t c = 0; c < 8; ++c) {
        const std::uint32_t nb = from.elementNodes[e][c];
        for (std::uint32_t p = prolongation.start[nb]; p < prolongation.start[nb + 1]; ++p)
          add(prolongation.index[p], 64 * e + 8 * a + c, wn * prolongation.weight[p]);
      }
    }
    for (std::uint32_t p = prolongation.start[n]; p < prolongation.start[n + 1]; ++p)
      add(prolongation.index[p], from.massBase + n, wn * prolongation.weight[p]);
  }
}

/// Appends the gathered row in `scratch` to `part`: its distinct columns ascending, then the
/// entries bucketed by column, in order. Leaves scratch.position all kNotFree again.
void appendRow(GatherScratch& scratch, SparsityPart& part) {
  std::vector<std::uint32_t>& position = scratch.position;
  std::vector<std::uint32_t>& columns = scratch.columns;
  std::vector<std::uint32_t>& fill = scratch.fill;
  std::sort(columns.begin(), columns.end());
  fill.assign(columns.size() + 1, 0);
  for (std::size_t k = 0; k < columns.size(); ++k)
    position[columns[k]] = static_cast<std::uint32_t>(k);
  for (const SparsityEntry& en : scratch.entries) ++fill[position[en.column] + 1];
  const auto base = static_cast<std::uint32_t>(part.source.size());
  for (std::size_t k = 0; k < columns.size(); ++k) {
    fill[k + 1] += fill[k];
    part.column.push_back(columns[k]);
    part.sourceEnd.push_back(base + fill[k + 1]);
  }
  part.rowEnd.push_back(static_cast<std::uint32_t>(part.column.size()));
  part.source.resize(base + scratch.entries.size());
  part.weight.resize(base + scratch.entries.size());
  for (const SparsityEntry& en : scratch.entries) {
    const std::uint32_t at = base + fill[position[en.column]]++;
    part.source[at] = en.source;
    part.weight[at] = en.weight;
  }
  for (std::uint32_t j : columns) position[j] = kNotFree;
}

/// Pass 1 of the sparsity build: each chunk of rows gathers its rows into its part, except
/// the copied ones (an empty row there).
std::vector<SparsityPart> gatherParts(const GatherSources& from, const RowCopies& copies,
                                      std::size_t rows, bool threaded) {
  std::vector<SparsityPart> parts((rows + kRowsPerPart - 1) / kRowsPerPart);
  parallelFor(
      0, parts.size(), 1,
      [&](std::size_t pb, std::size_t pe) {
        GatherScratch scratch;
        scratch.position.assign(rows, kNotFree);
        for (std::size_t pi = pb; pi < pe; ++pi) {
          SparsityPart& part = parts[pi];
          const std::size_t end = std::min(rows, (pi + 1) * kRowsPerPart);
          for (std::size_t i = pi * kRowsPerPart; i < end; ++i) {
            if (copies.copied(i)) {
              part.rowEnd.push_back(static_cast<std::uint32_t>(part.column.size()));
              continue;
            }
            gatherEntries(from, i, scratch);
            appendRow(scratch, part);
          }
        }
      },
      threaded);
  return parts;
}

/// Pass 2: each row's first block (out.rowStart) and, returned, the first source of each
/// row's first block, in row order.
std::vector<std::uint64_t> rowOffsets(const std::vector<SparsityPart>& parts,
                                      const RowCopies& copies, std::size_t rows,
                                      BlockSparsity& out) {
  std::vector<std::uint64_t> rowSource(rows + 1, 0);
  out.rowStart.assign(rows + 1, 0);
  for (std::size_t pi = 0; pi < parts.size(); ++pi) {
    const SparsityPart& part = parts[pi];
    std::uint32_t k = 0;  // the part's blocks before this row
    for (std::size_t r = 0; r < part.rowEnd.size(); ++r) {
      const std::size_t i = pi * kRowsPerPart + r;
      std::uint64_t blocks = 0, sources = 0;
      if (copies.copied(i)) {
        const BlockSparsity& old = *copies.old;
        const std::uint32_t io = copies.oldRow[i];
        blocks = old.rowStart[io + 1] - old.rowStart[io];
        sources = old.sourceStart[old.rowStart[io + 1]] - old.sourceStart[old.rowStart[io]];
      } else {
        blocks = part.rowEnd[r] - k;
        if (blocks > 0)
          sources = part.sourceEnd[part.rowEnd[r] - 1] - (k > 0 ? part.sourceEnd[k - 1] : 0);
        k = part.rowEnd[r];
      }
      const std::uint64_t next = out.rowStart[i] + blocks;
      rowSource[i + 1] = rowSource[i] + sources;
      VOXCUT_ASSERT(next < 0xffffffffull && rowSource[i + 1] < 0xffffffffull,
                    "too many blocks or block sources for 32-bit offsets");
      out.rowStart[i + 1] = static_cast<std::uint32_t>(next);
    }
  }
  return rowSource;
}

/// Writes copied row i of `out` from the old sparsity, from slot `slot` and source
/// `sourceBase` on; returns the slot past it. An unchanged neighbourhood: the old row,
/// renumbered. Free nodes keep their order (node-grid order, ids kept), so the columns stay
/// ascending and on the same side of the diagonal; node n's mass moves with the mass base.
std::uint32_t copyRow(const RowCopies& copies, std::size_t i, std::uint32_t slot,
                      std::uint32_t sourceBase, std::uint32_t massBase, BlockSparsity& out) {
  const BlockSparsity& old = *copies.old;
  const std::uint32_t io = copies.oldRow[i];
  const std::uint32_t s0 = old.rowStart[io], s1 = old.rowStart[io + 1];
  const std::uint32_t k0 = old.sourceStart[s0], k1 = old.sourceStart[s1];
  for (std::uint32_t s = s0; s < s1; ++s, ++slot) {
    const std::uint32_t column = copies.newColumn[old.column[s]];
    VOXCUT_ASSERT(column != kNotFree, "a copied row couples to a node no longer free");
    out.column[slot] = column;
    out.sourceStart[slot + 1] = old.sourceStart[s + 1] - k0 + sourceBase;
  }
  std::copy(old.sourceWeight.begin() + k0, old.sourceWeight.begin() + k1,
            out.sourceWeight.begin() + sourceBase);
  for (std::uint32_t at = k0; at < k1; ++at) {
    const std::uint32_t src = old.source[at];
    out.source[sourceBase + at - k0] =
        src < copies.oldMassBase ? src : src - copies.oldMassBase + massBase;
  }
  return slot;
}

/// Writes gathered row r of `part` (its blocks from k on) into `out` from slot `slot` and
/// source `sourceBase` on; returns the slot past it and advances k past the row.
std::uint32_t placeRow(const SparsityPart& part, std::size_t r, std::uint32_t& k,
                       std::uint32_t slot, std::uint32_t sourceBase, BlockSparsity& out) {
  const std::uint32_t partSource = k > 0 ? part.sourceEnd[k - 1] : 0;
  for (; k < part.rowEnd[r]; ++k, ++slot) {
    out.column[slot] = part.column[k];
    out.sourceStart[slot + 1] = part.sourceEnd[k] - partSource + sourceBase;
  }
  const std::uint32_t partEnd = k > 0 ? part.sourceEnd[k - 1] : 0;
  std::copy(part.source.begin() + partSource, part.source.begin() + partEnd,
            out.source.begin() + sourceBase);
  std::copy(part.weight.begin() + partSource, part.weight.begin() + partEnd,
            out.sourceWeight.begin() + sourceBase);
  return slot;
}

/// Pass 3: sizes `out` (its rowStart set) and each chunk writes its rows in place, gathered
/// or copied, with their diagonal slots; returns the number of rows copied.
std::size_t writeRows(const std::vector<SparsityPart>& parts, const RowCopies& copies,
                      const std::vector<std::uint64_t>& rowSource, std::uint32_t massBase,
                      BlockSparsity& out, bool threaded) {
  const std::size_t rows = out.rowStart.size() - 1;
  const std::size_t blockCount = out.rowStart[rows];
  out.diagonal.assign(rows, kNotFree);
  out.column.resize(blockCount);
  out.sourceStart.resize(blockCount + 1);
  out.sourceStart[0] = 0;
  out.source.resize(rowSource[rows]);
  out.sourceWeight.resize(rowSource[rows]);
  std::vector<std::size_t> reused(parts.size(), 0);
  parallelFor(
      0, parts.size(), 1,
      [&](std::size_t pb, std::size_t pe) {
        for (std::size_t pi = pb; pi < pe; ++pi) {
          const SparsityPart& part = parts[pi];
          std::uint32_t k = 0;  // next block of the part
          for (std::size_t r = 0; r < part.rowEnd.size(); ++r) {
            const std::size_t i = pi * kRowsPerPart + r;
            std::uint32_t slot = out.rowStart[i];
            const auto sourceBase = static_cast<std::uint32_t>(rowSource[i]);
            if (copies.copied(i)) {
              slot = copyRow(copies, i, slot, sourceBase, massBase, out);
              ++reused[pi];
            } else {
              slot = placeRow(part, r, k, slot, sourceBase, out);
            }
            for (std::uint32_t s = out.rowStart[i]; s < slot; ++s)
              if (out.column[s] == i) out.diagonal[i] = s;
          }
        }
      },
      threaded);
  std::size_t total = 0;
  for (std::size_t n : reused) total += n;
  return total;
}

}  // namespace

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
  RowCopies copies;
  if (reuse != nullptr)
    copies = {reuse->old, reuse->oldRow.data(), reuse->newColumn.data(), reuse->oldMassBase};
  const GatherSources from{restriction_, incidence_, prolongation_, elementNodes_, massBase};
  const std::vector<SparsityPart> parts = gatherParts(from, copies, rows, threaded_);
  sparsity_ = BlockSparsity{};
  const std::vector<std::uint64_t> rowSource = rowOffsets(parts, copies, rows, sparsity_);
  const std::size_t reused = writeRows(parts, copies, rowSource, massBase, sparsity_, threaded_);
  for (std::size_t i = 0; i < rows; ++i)
    VOXCUT_ASSERT(sparsity_.diagonal[i] != kNotFree, "a free node without its diagonal block");
  sparsity_.mirror = blockMirrors(sparsity_);
  sparsityRowsReused_ = reused;
  static std::atomic<std::uint64_t> revisions{0};
  sparsityRevision_ = ++revisions;
}

}  // namespace voxcut
