#include "voxcut/octree/OctreeSubdivision.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <type_traits>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/core/Timer.h"
#include "voxcut/octree/SubdivisionWorker.h"

namespace voxcut {

using namespace subdivision_detail;

SubdivisionWorkspace::SubdivisionWorkspace() = default;
SubdivisionWorkspace::~SubdivisionWorkspace() = default;
SubdivisionWorkspace::SubdivisionWorkspace(SubdivisionWorkspace&&) noexcept = default;
SubdivisionWorkspace& SubdivisionWorkspace::operator=(SubdivisionWorkspace&&) noexcept = default;
SubdivisionWorkspace::SubdivisionWorkspace(const SubdivisionWorkspace& /*other*/) {}
SubdivisionWorkspace& SubdivisionWorkspace::operator=(const SubdivisionWorkspace& /*other*/) {
  return *this;
}

void markCubesAroundLink(const VoxelOctree& oct, const VoxelGrid& grid, std::uint64_t link,
                         std::vector<std::uint8_t>& marked) {
  const auto v = static_cast<std::size_t>(link / 3);
  forEachCubeAroundLink(
      oct, grid, grid.coord(v), static_cast<int>(link % 3), [&](std::size_t cube) {
        std::atomic_ref<std::uint8_t>(marked[cube]).store(1, std::memory_order_relaxed);
      });
}

void prefetchCubesAroundLink(const VoxelOctree& oct, const VoxelGrid& grid, std::uint64_t link) {
  const auto v = static_cast<std::size_t>(link / 3);
  const int a = static_cast<int>(link % 3);
  const std::size_t su = grid.stride((a + 1) % 3), sw = grid.stride((a + 2) % 3);
  const std::int32_t* cells = oct.cellCube.data();
  __builtin_prefetch(cells + v);
  if (v >= su) __builtin_prefetch(cells + (v - su));
  if (v >= sw) __builtin_prefetch(cells + (v - sw));
  if (v >= su + sw) __builtin_prefetch(cells + (v - su - sw));
}

namespace {

// One run of subdivideCutCubes: its inputs, what lasts from round to round, and the phases of a
// round (run() calls them in order).
struct SubdivisionRun {
  SubdivisionRun(VoxelOctree& octree, VoxelGrid& voxels, std::vector<LinkCut>& allCuts,
                 const SubdivisionHooks& linkHooks, SubdivisionWorkspace& workspace, bool parallel,
                 const SweepBoundary& sweepBoundary, bool givenStored,
                 std::vector<std::uint8_t>* marked);
  SubdivisionStats run();

  // (1) marks the cubes around the newly cut links in `affected`.
  void markAffected();
  // Lists the affected cubes in space order (list, slot); false when there are none.
  bool listAffected();
  // Whether listed cube i is one the sweep's boundary reaches into (first round only).
  [[nodiscard]] bool isReached(std::size_t i) const { return firstRound && reached[list[i]] != 0; }
  // Runs fn(worker, i) for every listed cube i, in parallel, each task with its thread's
  // worker, whose findings of the phase start empty; `side`, if set, runs as one more task
  // (first: the calling thread starts it while the others take cubes).
  template <class Fn, class Side>
  void forEachCube(Fn&& fn, Side&& side);
  // After each phase: the tested links counted, the cuts appended to `cuts` (from roundBegin
  // on, the faces phase's up to facesEnd).
  void mergeFindings();
  // Hermite data for cuts[b, e) (each cut was recorded once, by the task that disconnected it;
  // the table's contents do not depend on the order). Runs beside other work that does not
  // touch the table.
  void storeCuts(std::size_t b, std::size_t e) {
    storeHermite(grid.hermite(), cuts.data() + b, cuts.data() + e);
  }
  // (2)-(4) on the faces of listed cube i.
  void traceFaces(Worker& w, std::size_t i);
  // (5) on listed cube i.
  void splitCube(Worker& w, std::size_t i);
  // (6) the split cubes' leaves into the octree.
  void storeSubCubes(bool mapNow);

  VoxelOctree& oct;
  VoxelGrid& grid;
  std::vector<LinkCut>& cuts;
  const SubdivisionHooks& hooks;
  const bool threaded;
  const SweepBoundary& boundary;
  std::vector<std::uint8_t>* givenMarked;
  const Index3 d;
  SubdivisionStats stats;
  std::vector<std::uint64_t> pending;  // the links cut last round (first: the given cuts)
  std::size_t givenUnstored;           // cuts[0, this) lack their data
  std::vector<std::uint8_t> affected;  // per cube: 1 a cut link around it; 2 only the boundary
  std::vector<WorkerMemory>& kept;
  std::vector<std::unique_ptr<Worker>> workers;
  std::vector<std::uint8_t> reached;  // cubes the sweep's boundary reaches into
  // This round's: the affected cubes in space order, the slot of each cube in that list (-1
  // if none), whether it is the first round, and where its cuts begin in `cuts`.
  std::vector<std::uint32_t> list;
  std::vector<std::int32_t> slot;
  bool firstRound = true;
  std::size_t roundBegin = 0;
};

SubdivisionRun::SubdivisionRun(VoxelOctree& octree, VoxelGrid& voxels,
                               std::vector<LinkCut>& allCuts, const SubdivisionHooks& linkHooks,
                               SubdivisionWorkspace& workspace, bool parallel,
                               const SweepBoundary& sweepBoundary, bool givenStored,
                               std::vector<std::uint8_t>* marked)
    : oct(octree),
      grid(voxels),
      cuts(allCuts),
      hooks(linkHooks),
      threaded(parallel),
      boundary(sweepBoundary),
      givenMarked(marked),
      d(voxels.dims()),
      givenUnstored(givenStored ? 0 : allCuts.size()),
      // The workers' memory comes from the workspace and goes back to it (a run's workers are
      // indexed by the thread slots of its parallel loops, unique among the threads running at
      // once).
      kept(workspace.workers),
      workers(static_cast<std::size_t>(threadSlots())),
      reached(octree.cubes.size(), 0) {
  for (const LinkCut& c : cuts) pending.push_back(c.link);
  kept.resize(std::max(kept.size(), static_cast<std::size_t>(threadSlots())));
  // Cubes the sweep's boundary reaches into (the first round only; see the header).
  for (const std::uint32_t c : boundary.cubes) {
    VOXCUT_ASSERT(c < oct.cubes.size() && !oct.cubes[c].deleted, "boundary: not a live cube");
    reached[c] = 1;
  }
  VOXCUT_ASSERT(
      oct.unmappedCubes.empty(),
      "the deferred updates of the last subdivision have not run (activateNewCubeFrames)");
}

void SubdivisionRun::markAffected() {
  // (1) mark the cubes around the newly cut links (raising a raised flag is harmless); the
  // caller may have marked those of the given cuts.
  if (stats.rounds == 0 && givenMarked != nullptr) {
    VOXCUT_ASSERT(givenMarked->size() == oct.cubes.size(), "one mark per cube");
    affected = std::move(*givenMarked);
  } else {
    affected.assign(oct.cubes.size(), 0);
    parallelFor(
        0, pending.size(), 256,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t i = b; i < e; ++i) {
            if (i + 16 < e) prefetchCubesAroundLink(oct, grid, pending[i + 16]);
            markCubesAroundLink(oct, grid, pending[i], affected);
          }
        },
        threaded);
  }
  // 1: a cut link around it; 2: only the sweep's boundary reaches into it.
  if (stats.rounds == 0)
    for (const std::uint32_t c : boundary.cubes)
      if (affected[c] == 0) affected[c] = 2;
}

bool SubdivisionRun::listAffected() {
  // In space order (z, y, x of the origins, by their voxel index): the parallel loops hand
  // each thread runs of neighbouring cubes, which share face voxels and links.
  std::vector<std::pair<std::size_t, std::uint32_t>> order;
  for (std::size_t c = 0; c < affected.size(); ++c)
    if (affected[c])
      order.emplace_back(grid.index(oct.cubes[c].origin), static_cast<std::uint32_t>(c));
  if (order.empty()) return false;
  std::sort(order.begin(), order.end());
  list.assign(order.size(), 0);
  slot.assign(oct.cubes.size(), -1);
  for (std::size_t i = 0; i < order.size(); ++i) {
    list[i] = order[i].second;
    slot[list[i]] = static_cast<std::int32_t>(i);
  }
  firstRound = stats.rounds == 0;
  ++stats.rounds;
  stats.affectedCubes += list.size();
  if (firstRound) stats.boundaryCubes = boundary.cubes.size();
  return true;
}

template <class Fn, class Side>
void SubdivisionRun::forEachCube(Fn&& fn, Side&& side) {
  for (auto& w : workers)
    if (w) w->clearFindings();
  constexpr bool hasSide = !std::is_same_v<std::decay_t<Side>, std::nullptr_t>;
  const std::size_t first = hasSide ? 1 : 0;
  parallelFor(
      0, list.size() + first, 1,
      [&](std::size_t b, std::size_t e) {
        if constexpr (hasSide)
          if (b == 0) {
            side();
            ++b;
          }
        if (b == e) return;
        std::unique_ptr<Worker>& w = workers[static_cast<std::size_t>(threadSlot())];
        if (!w)
          w = std::make_unique<Worker>(oct, grid, hooks,
                                       std::move(kept[static_cast<std::size_t>(threadSlot())]));
        for (std::size_t i = b; i < e; ++i) fn(*w, i - first);
      },
      threaded);
}

void SubdivisionRun::mergeFindings() {
  for (const auto& w : workers) {
    if (!w) continue;
    stats.testedLinks += w->tested;
    cuts.insert(cuts.end(), w->cuts.begin(), w->cuts.end());
    w->cuts.clear();
  }
}

void SubdivisionRun::traceFaces(Worker& w, std::size_t i) {
  const OctreeCube& oc = oct.cubes[list[i]];
  const int s = 1 << oc.level;
  const bool seeded = isReached(i);
  w.listed = &slot;
  if (seeded) Worker::pointsNear(boundary.points, oc.origin, s, 2.0, w.cubePoints);
  for (int f = 0; f < 6; ++f) {
    Index3 o = oc.origin;
    o[f / 2] += (f & 1) * s;
    // A face shared whole with another affected cube of the same size is resolved once,
    // by the cube listed first; its cuts border only cubes split in this round. A face
    // that lies inside a face of a larger affected cube is left to that cube: its trace,
    // followed from its own border, crosses this face wherever the blade does (a trace
    // reaches the border of every face it crosses, short of the sweep's boundary).
    Index3 across = oc.origin;
    across[f / 2] += (f & 1) ? s : -1;
    bool shared = false;
    if (across[f / 2] >= 0 && across[f / 2] + 1 < d[f / 2]) {
      const std::int32_t other = oct.cellCube[grid.index(across)];
      // (A cube the boundary reaches into traces its faces itself, seeded.)
      if (other >= 0 && slot[static_cast<std::size_t>(other)] >= 0 && !seeded &&
          !isReached(static_cast<std::size_t>(slot[static_cast<std::size_t>(other)]))) {
        const int otherLevel = oct.cubes[static_cast<std::size_t>(other)].level;
        if (otherLevel > oc.level) continue;
        shared = otherLevel == oc.level;
        if (shared && slot[static_cast<std::size_t>(other)] < static_cast<std::int32_t>(i))
          continue;
      }
    }
    w.recordOutward = !shared;
    w.traceSquare(o, f / 2, s, seeded ? &w.cubePoints : nullptr);
    w.recordOutward = false;
  }
}

void SubdivisionRun::splitCube(Worker& w, std::size_t i) {
  const OctreeCube& oc = oct.cubes[list[i]];
  const CubeBox cube{oc.origin, oc.level};
  const auto begin = static_cast<std::uint32_t>(w.leaves.size());
  // A level-1 cube tests the links at its centre whatever its faces hold; one listed for
  // a cut around it has one on its faces, so they are gathered only for one listed for
  // the sweep's boundary alone (which stays whole if none of its links is cut).
  const bool cutAround = affected[list[i]] == 1;
  w.boundary.clear();
  if (cube.level > 1 || !cutAround) w.gatherBoundaryCuts(cube);
  w.cubePoints.clear();
  if (isReached(i)) Worker::pointsNear(boundary.points, cube.o, cube.size(), 1.0, w.cubePoints);
  const bool cutOnBoundary = cube.level > 1 || !cutAround ? !w.boundary.empty() : true;
  w.split(cube, w.boundary, w.cubePoints, cutOnBoundary);
  w.leafRanges.push_back(
      {static_cast<std::uint32_t>(i), begin, static_cast<std::uint32_t>(w.leaves.size())});
}

// The split level-1 cubes are listed for the frame activation (oct.openedCubes, in any
// order) and the sub-cubes stored (oct.cubes, oct.newCubes): the first sub-cube takes the
// split cube's slot, the others are appended in list order.
//
// The cube map (oct.cellCube): a split cube's leaves and its opened level-1 cubes tile it (a
// split ends in one or the other) and its cells hold its id, which its first leaf keeps; so
// only the other leaves' cells (their new ids) and the opened cubes' cells (none) change.
// Only the next round's marking reads the map in this frame: with none to follow, the
// writes are left to deferred update (b) (activateNewCubeFrames), like the frames.
void SubdivisionRun::storeSubCubes(bool mapNow) {
  for (const auto& w : workers)
    if (w) oct.openedCubes.insert(oct.openedCubes.end(), w->opened.begin(), w->opened.end());
  std::vector<const CubeBox*> leafBegin(list.size()), leafEnd(list.size());
  std::size_t leafCount = 0;
  for (const auto& w : workers)
    if (w) leafCount += w->leaves.size();
  // Room for them at once, growing geometrically (a scene splits cubes frame after frame).
  const auto makeRoom = [leafCount](auto& v) {
    if (v.size() + leafCount > v.capacity())
      v.reserve(std::max(v.size() + leafCount, 2 * v.capacity()));
  };
  makeRoom(oct.cubes);
  makeRoom(oct.newCubes);
  if (!mapNow) makeRoom(oct.unmappedCubes);
  for (const auto& w : workers)
    if (w)
      for (const auto& [i, b, e] : w->leafRanges) {
        leafBegin[i] = w->leaves.data() + b;
        leafEnd[i] = w->leaves.data() + e;
      }
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::uint32_t id = list[i];
    if (leafBegin[i] == leafEnd[i]) {
      oct.cubes[id].deleted = true;
      continue;
    }
    for (const CubeBox* leaf = leafBegin[i]; leaf != leafEnd[i]; ++leaf) {
      const OctreeCube sub{leaf->o, static_cast<std::uint8_t>(leaf->level), false};
      if (leaf == leafBegin[i]) {
        oct.cubes[id] = sub;
        oct.newCubes.push_back(id);
        continue;
      }
      const auto newId = static_cast<std::uint32_t>(oct.cubes.size());
      if (mapNow)
        oct.setCubeCells(leaf->o, leaf->level, static_cast<std::int32_t>(newId));
      else
        oct.unmappedCubes.push_back(newId);
      oct.newCubes.push_back(newId);
      oct.cubes.push_back(sub);
    }
  }
  if (mapNow)
    for (const auto& w : workers)
      if (w)
        for (const Index3& o : w->opened) oct.setCubeCells(o, 1, -1);
}

SubdivisionStats SubdivisionRun::run() {
  Timer total;
  while (!pending.empty() || (stats.rounds == 0 && !boundary.cubes.empty())) {
    markAffected();
    if (!listAffected()) break;
    roundBegin = cuts.size();
    // (2)-(4) the faces of the affected cubes: their voxels are positioned and their links
    // tested along the blade's trace (a face that two affected cubes of different sizes share
    // in part is resolved by both, with the same results). A face's border is the cube's
    // frame, or lines of the mid-planes of the cube it was split from: decided already.
    Timer phase;
    forEachCube([&](Worker& w, std::size_t i) { traceFaces(w, i); },
                [&] {
                  storeCuts(0, givenUnstored);
                  givenUnstored = 0;
                });
    mergeFindings();
    const std::size_t facesEnd = cuts.size();
    stats.facesMs += phase.ms();
    // Only these can touch cubes outside this round's list: the split cuts links strictly
    // inside the cubes it splits, and splits every sub-cube they border; a face shared whole by
    // two cubes of this round is split on both sides, and of the other faces' cuts only those
    // with an unlisted cube around them are kept (the single-frame cuts keep none: no second
    // round).
    pending.clear();
    for (const auto& w : workers)
      if (w) pending.insert(pending.end(), w->outward.begin(), w->outward.end());

    // (5) split every affected cube, in parallel: their insides are disjoint; the faces
    // phase's cuts get their Hermite data meanwhile (the split does not read it).
    phase.restart();
    forEachCube([&](Worker& w, std::size_t i) { splitCube(w, i); },
                [&] { storeCuts(roundBegin, facesEnd); });
    stats.splitMs += phase.ms();
    mergeFindings();
    // (6) the sub-cubes stored (storeSubCubes); the split's cuts get their Hermite data
    // beside it.
    const bool mapNow = !pending.empty();
    parallelFor(
        0, 2, 1,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t job = b; job < e; ++job) {
            if (job == 0) storeCuts(facesEnd, cuts.size());
            if (job == 1) storeSubCubes(mapNow);
          }
        },
        threaded);
    stats.cutLinks += cuts.size() - roundBegin;
  }
  if (givenUnstored > 0) storeCuts(0, givenUnstored);  // no round ran
  for (std::size_t k = 0; k < workers.size(); ++k)
    if (workers[k]) kept[k] = std::move(static_cast<WorkerMemory&>(*workers[k]));
  stats.bookkeepingMs = total.ms() - stats.facesMs - stats.splitMs;
  return stats;
}

}  // namespace

SubdivisionStats subdivideCutCubes(VoxelOctree& oct, VoxelGrid& grid, std::vector<LinkCut>& cuts,
                                   const SubdivisionHooks& hooks, SubdivisionWorkspace& workspace,
                                   bool threaded, const SweepBoundary& boundary, bool givenStored,
                                   std::vector<std::uint8_t>* givenMarked) {
  return SubdivisionRun(oct, grid, cuts, hooks, workspace, threaded, boundary, givenStored,
                        givenMarked)
      .run();
}

}  // namespace voxcut
