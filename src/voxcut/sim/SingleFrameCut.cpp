#include "voxcut/sim/SingleFrameCut.h"

#include <algorithm>

#include "voxcut/surface/DualContour.h"
#include "voxcut/voxel/Pieces.h"

namespace voxcut {
namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? 0.0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

}  // namespace

BladeMotion defaultBladeMotion(const CutBody& body) {
  Eigen::AlignedBox3d box;
  const VoxelGrid& g = body.grid;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    if (g.occupied(v)) box.extend(body.deformation.voxelPosition(v));
  const Vec3d ext = box.sizes();
  int longest = 0, thinnest = 0;
  for (int a = 1; a < 3; ++a) {
    if (ext[a] > ext[longest]) longest = a;
    if (ext[a] < ext[thinnest]) thinnest = a;
  }
  if (thinnest == longest) thinnest = (longest + 1) % 3;
  const Vec3d margin = 0.1 * ext + Vec3d::Constant(2.0 * g.voxelSize());
  const Vec3d c = box.center();
  BladeMotion m;
  m.from.a = c;
  m.from.a[longest] = box.min()[longest] - margin[longest];
  m.from.a[thinnest] = box.min()[thinnest] - margin[thinnest];
  m.from.b = m.from.a;
  m.from.b[longest] = box.max()[longest] + margin[longest];
  m.to = m.from;
  m.to.a[thinnest] = m.to.b[thinnest] = box.max()[thinnest] + margin[thinnest];
  return m;
}

std::vector<SingleFrameResult> runSingleFrameCuts(const std::vector<const CutBody*>& prepared,
                                                  const BladeMotion& blade,
                                                  const SingleFrameParams& params) {
  const BladeSweep sweep = makeSweep(blade.from, blade.to, 0);
  const std::size_t n = prepared.size();
  std::vector<SingleFrameResult> out(n);
  std::vector<std::vector<double>> pos(n), inter(n), sub(n), def(n);
  const int repeat = std::max(1, params.repeat);
  // One per body, kept across the repetitions as a simulation keeps it across frames.
  std::vector<SubdivisionWorkspace> workspaces(n);
  for (int r = 0; r < repeat; ++r)
    for (std::size_t k = 0; k < n; ++k) {
      CutBody body = *prepared[k];
      out[k].activeVoxelsBefore = body.activity.activeVoxels.size();
      CutStepResult step = cutStep(body, sweep, workspaces[k], params.threaded);
      pos[k].push_back(step.positionUpdateMs);
      inter[k].push_back(step.intersectionMs);
      sub[k].push_back(step.subdivisionMs);
      def[k].push_back(step.deferredMs);
      if (r + 1 == repeat) {
        out[k].step = std::move(step);
        out[k].body = std::move(body);
      }
    }
  for (std::size_t k = 0; k < n; ++k) {
    SingleFrameResult& o = out[k];
    o.step.positionUpdateMs = median(pos[k]);
    o.step.intersectionMs = median(inter[k]);
    o.step.subdivisionMs = median(sub[k]);
    o.step.deferredMs = median(def[k]);
    o.cutHash = cutSetHash(o.step.cuts);
    o.activeVoxelsAfter = o.body.activity.activeVoxels.size();
    if (params.contour) {
      o.pieces = findPieces(o.body.grid).count;
      o.surface = dualContour(o.body.grid, {.qefThreshold = 0.1, .threaded = params.threaded});
      o.topology = surfaceTopology(o.surface);
    }
  }
  return out;
}

SingleFrameResult runSingleFrameCut(const CutBody& prepared, const BladeMotion& blade,
                                    const SingleFrameParams& params) {
  return std::move(runSingleFrameCuts({&prepared}, blade, params).front());
}

}  // namespace voxcut
