/// @file CutStage.cpp
/// The cutting stage of a frame and what follows a cut (docs/architecture.md, "One frame"):
/// the blades' sweeps, the cut, the cut topology, refinement under resting fronts and
/// coarsening after cuts, and the surface and model brought up to date.

#include <algorithm>
#include <tuple>

#include "voxcut/cutting/Fragments.h"
#include "voxcut/sim/WorldImpl.h"
#include "voxcut/topology/CutTopology.h"

namespace voxcut {

// What follows a body's cuts: its cut topology (the model's and solver's with it), its surface
// and its rest distance field.
void World::Impl::afterCut(SimBody& b, const std::vector<std::uint64_t>& cut, const BladeEnds& ends,
                           Frame& f) {
  // The topology (deformation octree, model, solver, fronts) beside the surface's and the
  // distance field's own updates: all three only read the grid, and write apart.
  TopologyChange change;
  SurfaceDelta delta;
  // Each branch times its own figures; they join the report once both are done.
  double topologyMs = 0.0, surfaceMs = 0.0, distanceMs = 0.0;
  parallelInvoke(
      [&] {
        const StageTimer time(topologyMs);
        change = updateTopology(b, cut, ends);
      },
      [&] {
        if (cut.empty()) return;
        StageTimer time(surfaceMs);
        delta = b.surface.update(b.cut.grid, cut);
        time.next(distanceMs);
        b.restDistance.update(b.cut.grid, cut);
      },
      settings.threaded && !cut.empty());
  f.ms(kCutTopology) += topologyMs;
  f.ms(kObjectCollision) += distanceMs;
  f.ms(kSurfaceUpdate) += surfaceMs;
  const StageTimer time(f.ms(kSurfaceUpdate));
  if (!cut.empty()) embedSurfaceChange(b, std::move(delta), change);
}

// Cutting tool collision: per moving blade, the strip of sweeps from its cut front (carried
// with the material since the last frame) to its new pose.
std::vector<std::uint64_t> World::Impl::cutBody(SimBody& b, BladeEnds& ends, Frame& f) {
  const Motion& motion = f.motion;
  std::vector<LinkCut> frameCuts;
  b.cutWork = {};
  ends.points.assign(tools.size(), {});
  ends.ids.assign(tools.size(), {});
  for (std::size_t ti = 0; ti < tools.size(); ++ti) {
    if (tools[ti].kind != ToolKind::Blade) continue;
    const std::optional<std::vector<BladeSweep>> moving = toolSweeps(b, ti, motion, ends);
    if (!moving || moving->empty()) continue;
    CutStepResult r = cutStepLeavingUpdates(b.cut, *moving, b.subdivision, settings.threaded);
    b.cutWork.add(r);
    // The cutting step times its own stages (cutting/CutStep.h).
    f.ms(kPositionUpdate) += r.positionUpdateMs;
    f.ms(kIntersectionTest) += r.intersectionMs;
    f.ms(kOctreeSubdivision) += r.subdivisionMs;
    f.ms(kDeferredUpdates) += r.deferredMs;
    frameCuts.insert(frameCuts.end(), std::make_move_iterator(r.cuts.begin()),
                     std::make_move_iterator(r.cuts.end()));
  }
  // Debris: undo the fewest cuts that keep every tiny fragment attached (cutting/Fragments.h).
  std::sort(frameCuts.begin(), frameCuts.end(),
            [](const LinkCut& x, const LinkCut& y) { return x.link < y.link; });
  (void)healSmallFragments(b.cut.grid, frameCuts, settings.minFragmentVoxels);
  std::vector<std::uint64_t> cut;
  cut.reserve(frameCuts.size());
  for (const LinkCut& c : frameCuts) cut.push_back(c.link);
  b.cuts.insert(b.cuts.end(), frameCuts.begin(), frameCuts.end());
  return cut;
}

namespace {

/// Segments of a blade's carried front in a body: at least `minimum`, and no longer than a
/// voxel along the longest the blade has been, so that the front follows the material closely:
/// a chord of the carried front strays from the material line it stands for where the body
/// bends across it, and a link under that gap crosses neither frame's sweep. Capped at four
/// times the grid's longest side (a blade much longer than the body gains nothing inside it).
int frontSegments(double length, const VoxelGrid& grid, int minimum) {
  if (minimum <= 0) return minimum;
  const double cap = 4.0 * std::max({grid.dims().x, grid.dims().y, grid.dims().z});
  const double perVoxel = std::min(std::ceil(length / grid.voxelSize()), cap);
  return std::max(minimum, static_cast<int>(perVoxel));
}

}  // namespace

// The sweeps of tool ti this frame (nullopt when it does not move); with blade segments, its
// end pose's samples and ids go to `ends`.
std::optional<std::vector<BladeSweep>> World::Impl::toolSweeps(SimBody& b, std::size_t ti,
                                                               const Motion& motion,
                                                               BladeEnds& ends) const {
  const auto frameIndex = static_cast<std::uint64_t>(frame);
  const BladePose& from = motion.from[ti];
  const BladePose& to = motion.to[ti];
  if (samePose(from, to)) return std::nullopt;
  // The front's sampling is fixed the first time the blade moves in this body: the carried
  // front and the new pose's samples must pair up.
  if (b.frontSegments[ti] == 0)
    b.frontSegments[ti] = frontSegments(tools[ti].longest, b.cut.grid, settings.bladeSegments);
  const int segs = b.frontSegments[ti];
  const std::uint64_t n = static_cast<std::uint64_t>(std::max(segs, 1)) + 1;
  std::vector<BladeSweep> sweeps;
  if (segs <= 0) {
    sweeps.push_back(makeSweep(from, to, frameIndex));
  } else {
    ends.points[ti] = sampleBlade(to, segs);
    ends.ids[ti].resize(n);
    for (std::uint64_t i = 0; i < n; ++i) ends.ids[ti][i] = (2 * frameIndex + 1) * n + i;
    std::vector<Vec3d> start;
    std::vector<std::uint64_t> startIds;
    if (b.fronts[ti].empty()) {
      start = sampleBlade(from, segs);
      for (std::uint64_t i = 0; i < n; ++i) startIds.push_back(2 * frameIndex * n + i);
    } else {
      frontStart(b.fronts[ti], b.cut.deformation, 2 * frameIndex * n, start, startIds,
                 &ends.points[ti]);
    }
    sweeps = sweepStrip(start, startIds, ends.points[ti], ends.ids[ti], frameIndex);
  }
  // Only sweeps that reach the body can cross its links (every voxel lies in the hull of its
  // element's nodes): a blade much longer than the body keeps the few sweeps near it.
  Eigen::AlignedBox3d box;
  for (const Vec3d& x : b.cut.deformation.positions()) box.extend(x);
  box.extend(box.min() - Vec3d::Constant(b.cut.grid.voxelSize()));
  box.extend(box.max() + Vec3d::Constant(b.cut.grid.voxelSize()));
  std::erase_if(sweeps, [&](const BladeSweep& s) {
    return !s.bounds[0].merged(s.bounds[1]).intersects(box);
  });
  return sweeps;
}

// After the cuts: the cut topology, the model's and solver's, and the blades' fronts embedded
// again. Returns how the topology changed.
TopologyChange World::Impl::updateTopology(SimBody& b, const std::vector<std::uint64_t>& cut,
                                           const BladeEnds& ends) {
  TopologyChange change;
  // Fronts of blades that did not move this frame, where they are now (re-embedded after a
  // topology change, which renumbers elements but moves no material).
  std::vector<std::vector<Vec3d>> still(tools.size());
  if (!cut.empty()) {
    // The start-level regions cut in this frame wait before they coarsen.
    const int S = b.settings.elementLevel;
    for (std::uint64_t id : cut) {
      const std::size_t v = static_cast<std::size_t>(id / 3);
      for (std::size_t u : {v, v + b.cut.grid.stride(static_cast<int>(id % 3))}) {
        b.cutRegions[regionKey(S, b.cut.grid.coord(u), b.cut.grid.dims())] = frame;
      }
    }
    for (std::size_t ti = 0; ti < tools.size(); ++ti)
      if (ends.points[ti].empty() && !b.fronts[ti].empty()) {
        std::vector<std::uint64_t> ids;
        frontStart(b.fronts[ti], b.cut.deformation, 0, still[ti], ids);
      }
    // A cut refines nothing below the start level in its own frame: most fronts move on in
    // the next (refineRestingFronts refines those that stay).
    change = updateCutTopology(b.cut.deformation, b.cut.grid, cut,
                               CutTopologyParams{S, settings.threaded});
    if (change.changed) {
      applyTopologyChange(b, change);
      noteRefinedRegions(b, change, true);
      b.quietPassDone = false;
    }
  }
  for (std::size_t ti = 0; ti < tools.size(); ++ti) {
    if (!ends.points[ti].empty())
      b.fronts[ti] = embedFront(ends.points[ti], ends.ids[ti], b.cut.deformation);
    else if (change.changed && !b.fronts[ti].empty())
      b.fronts[ti] = embedFront(still[ti], b.fronts[ti].ids, b.cut.deformation);
  }
  // The regions the fronts rest in: where they were at the end of the last frame too.
  std::vector<std::uint64_t> now = frontRegions(b);
  b.restingRegions.clear();
  std::set_intersection(now.begin(), now.end(), b.frontRegions.begin(), b.frontRegions.end(),
                        std::back_inserter(b.restingRegions));
  b.frontRegions = std::move(now);
  return change;
}

std::vector<Index3> World::Impl::frontVoxels(const SimBody& b) const {
  const DeformationOctree& d = b.cut.deformation;
  std::vector<Index3> out;
  for (const BladeFront& bf : b.fronts)
    for (std::size_t i = 0; i < bf.element.size(); ++i) {
      if (bf.element[i] == kNoElement) continue;
      const OctreeElement& el = d.element(bf.element[i]);
      const Index3 f = el.firstVoxel();
      const Vec3d p = Vec3d(f.x, f.y, f.z) + el.size() * bf.local[i];
      out.push_back({static_cast<int>(p.x()), static_cast<int>(p.y()), static_cast<int>(p.z())});
    }
  return out;
}

std::vector<std::uint64_t> World::Impl::frontRegions(const SimBody& b) const {
  std::vector<std::uint64_t> out;
  for (const Index3& c : frontVoxels(b))
    out.push_back(regionKey(b.settings.elementLevel, c, b.cut.grid.dims()));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void World::Impl::refineRestingFronts(SimBody& b, Frame& f) {
  const int S = b.settings.elementLevel;
  const int finest = finestLevelOf(b.settings);
  if (b.restingRegions.empty() || finest >= S) return;
  const StageTimer time(f.ms(kCutTopology));
  // The cut links near the front points in resting regions: within two finest elements of a
  // point (other cuts' fronts in the region stay as they are).
  const VoxelGrid& g = b.cut.grid;
  const Index3 gd = g.dims();
  const int r = 2 << finest;
  // The boxes of neighbouring points overlap almost wholly: per voxel row (y, z), the union of
  // their x ranges, so that each voxel is looked at once.
  struct Span {
    int z, y, x0, x1;
  };
  std::vector<Span> spans;
  for (const Index3& c : frontVoxels(b)) {
    if (!std::binary_search(b.restingRegions.begin(), b.restingRegions.end(), regionKey(S, c, gd)))
      continue;
    for (int z = std::max(c.z - r, 0); z < std::min(c.z + r, gd.z); ++z)
      for (int y = std::max(c.y - r, 0); y < std::min(c.y + r, gd.y); ++y)
        spans.push_back({z, y, std::max(c.x - r, 0), std::min(c.x + r, gd.x)});
  }
  std::sort(spans.begin(), spans.end(), [](const Span& p, const Span& q) {
    return std::tie(p.z, p.y, p.x0) < std::tie(q.z, q.y, q.x0);
  });
  std::vector<std::uint64_t> links;
  for (std::size_t i = 0; i < spans.size();) {
    const int z = spans[i].z, y = spans[i].y;
    int x = spans[i].x0;
    for (; i < spans.size() && spans[i].z == z && spans[i].y == y; ++i) {
      for (x = std::max(x, spans[i].x0); x < spans[i].x1; ++x) {
        const std::size_t v = g.index(x, y, z);
        if (!g.occupied(v)) continue;
        for (int a = 0; a < 3; ++a)
          if (g.hasLink(v, a) && !g.connected(v, a) && g.occupied(v + g.stride(a)))
            links.push_back(VoxelGrid::linkId(v, a));
      }
    }
  }
  if (links.empty()) return;
  const std::vector<std::vector<Vec3d>> front = frontPoints(b);
  CutTopologyParams cp{finest, settings.threaded};
  cp.refineOnly = true;
  const TopologyChange change = updateCutTopology(b.cut.deformation, g, links, cp);
  if (change.changed) {
    applyFrameStartChange(b, change, front);
    noteRefinedRegions(b, change, true);
    b.quietPassDone = false;
  }
}

// The start-level regions holding new elements finer than the start level (refined around a
// cut by the 2:1 rule or for an unambiguous hanging node, possibly outside the cut's own
// regions) wait with the cut's before they coarsen.
void World::Impl::noteRefinedRegions(SimBody& b, const TopologyChange& change, bool settled) {
  const int S = b.settings.elementLevel;
  const DeformationOctree& d = b.cut.deformation;
  for (std::size_t e = 0; e < change.elementSource.size(); ++e) {
    const OctreeElement& el = d.element(static_cast<std::uint32_t>(e));
    if (change.elementSource[e] != kNewElement || el.level >= S) continue;
    const std::uint64_t key = regionKey(S, el.firstVoxel(), b.cut.grid.dims());
    if (settled)
      b.cutRegions.try_emplace(key, frame);
    else if (b.cutRegions.count(key) == 0)
      b.unsettledRegions.insert(key);
  }
}

std::vector<std::vector<Vec3d>> World::Impl::frontPoints(const SimBody& b) const {
  std::vector<std::vector<Vec3d>> out(tools.size());
  for (std::size_t ti = 0; ti < tools.size(); ++ti)
    if (!b.fronts[ti].empty()) {
      std::vector<std::uint64_t> ids;
      frontStart(b.fronts[ti], b.cut.deformation, 0, out[ti], ids);
    }
  return out;
}

void World::Impl::applyFrameStartChange(SimBody& b, const TopologyChange& change,
                                        const std::vector<std::vector<Vec3d>>& front) {
  applyTopologyChange(b, change);
  renumberVertexElements(b, change);
  // Both caches hold element ids.
  b.selfCandidates.valid = false;
  b.verticesByElement.valid = false;
  for (std::size_t ti = 0; ti < tools.size(); ++ti)
    if (!b.fronts[ti].empty())
      b.fronts[ti] = embedFront(front[ti], b.fronts[ti].ids, b.cut.deformation);
}

void World::Impl::applyTopologyChange(SimBody& b, const TopologyChange& change) {
  // The fixed boxes, applied to the new nodes in the same rebuild of the constraints.
  const std::vector<std::uint8_t> fixed =
      b.settings.fixed.empty() ? std::vector<std::uint8_t>{} : fixedFlags(b);
  b.model.updateTopology(b.cut.deformation, b.cut.grid, change,
                         b.settings.fixed.empty() ? nullptr : &fixed);
  b.solver.updateTopology(change);
}

void World::Impl::coarsenBody(SimBody& b, Frame& f) {
  if (b.cutRegions.empty()) return;
  const StageTimer time(f.ms(kCutTopology));
  // Regions where a blade's front is stay as they are: the cut goes on there.
  const int S = b.settings.elementLevel;
  for (std::uint64_t key : b.frontRegions) {
    const auto it = b.cutRegions.find(key);
    if (it != b.cutRegions.end()) it->second = frame;
  }
  // Due: left alone long enough, and so are its neighbours among the regions cut. Merging
  // next to a refined region that is still busy could leave a coarse cube whose parts meet
  // only through the finer neighbour, which the node rule would refine again: the two merge
  // together once both are due.
  auto waiting = [&](std::uint64_t key) {
    const auto it = b.cutRegions.find(key);
    return it != b.cutRegions.end() && frame - it->second < kCoarsenAfterFrames;
  };
  std::vector<std::uint64_t> due;
  // Nothing busy: every refined region at once, those the node rule refined again included
  // (merged together, they leave no finer neighbour to refine them again). Once after each
  // cut, so that a configuration the rule keeps refining costs one change.
  bool busy = false;
  for (const auto& [key, last] : b.cutRegions) busy = busy || frame - last < kCoarsenAfterFrames;
  const bool quietPass = !busy && !b.quietPassDone;
  if (quietPass) {
    for (const auto& [key, last] : b.cutRegions) due.push_back(key);
    due.insert(due.end(), b.unsettledRegions.begin(), b.unsettledRegions.end());
    b.unsettledRegions.clear();
    b.quietPassDone = true;
  }
  for (const auto& [key, last] : b.cutRegions) {
    if (quietPass) break;
    if (frame - last < kCoarsenAfterFrames) continue;
    constexpr std::uint64_t m = (std::uint64_t{1} << 20) - 1;
    const Index3 c{static_cast<int>((key >> 40) & m), static_cast<int>((key >> 20) & m),
                   static_cast<int>(key & m)};
    bool ready = true;
    for (int n = 0; n < 27 && ready; ++n) {
      const Index3 q{c.x + n % 3 - 1, c.y + (n / 3) % 3 - 1, c.z + n / 9 - 1};
      if (n != 13 && q.x >= 0 && q.y >= 0 && q.z >= 0)
        ready = !waiting(DeformationOctree::cubeKey(S, q));
    }
    if (ready) due.push_back(key);
  }
  if (due.empty()) return;
  // The oldest regions first, a bounded number a frame (all of them in a quiet pass).
  auto lastOf = [&](std::uint64_t k) {
    const auto it = b.cutRegions.find(k);
    return it != b.cutRegions.end() ? it->second : -1;
  };
  std::sort(due.begin(), due.end(), [&](std::uint64_t x, std::uint64_t y) {
    const int fx = lastOf(x), fy = lastOf(y);
    return fx != fy ? fx < fy : x < y;
  });
  due.erase(std::unique(due.begin(), due.end()), due.end());
  if (!quietPass && due.size() > kCoarsenRegionsPerFrame) due.resize(kCoarsenRegionsPerFrame);
  std::unordered_map<std::uint64_t, int> lastCut;
  for (std::uint64_t k : due) {
    lastCut.emplace(k, lastOf(k));
    b.cutRegions.erase(k);
  }
  // The blades' fronts where they are now, to embed again in the new elements.
  const std::vector<std::vector<Vec3d>> front = frontPoints(b);
  CoarsenParams cp;
  cp.startLevel = S;
  const Index3 gd = b.cut.grid.dims();
  cp.surfaceLevel = initialFinestLevel(S, b.settings.surfaceLevel, std::max({gd.x, gd.y, gd.z}));
  cp.frontLevel = b.settings.frontLevel < 0 ? S : std::clamp(b.settings.frontLevel, 0, S);
  cp.threaded = settings.threaded;
  CoarsenResult res = coarsenCutTopology(b.cut.deformation, b.cut.grid, due, cp);
  // Refused for a finer neighbour: tried again as it was (the neighbour may coarsen first).
  // Refined again by the node rule: left as it is until a cut comes back, since trying again
  // would refine again, every few frames.
  for (std::uint64_t k : res.blocked)
    if (!std::binary_search(res.unsettled.begin(), res.unsettled.end(), k))
      b.cutRegions.emplace(k, lastCut.at(k));
  b.unsettledRegions.insert(res.unsettled.begin(), res.unsettled.end());
  if (res.change.changed) {
    applyFrameStartChange(b, res.change, front);
    noteRefinedRegions(b, res.change, false);
  }
}

}  // namespace voxcut
