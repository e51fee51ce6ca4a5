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

SingleFrameResult runSingleFrameCut(const CutBody& prepared, const BladeMotion& blade,
                                    const SingleFrameParams& params) {
  SingleFrameResult out;
  const BladeSweep sweep = makeSweep(blade.from, blade.to, 0);
  std::vector<double> pos, inter, sub, def;
  const int repeat = std::max(1, params.repeat);
  for (int r = 0; r < repeat; ++r) {
    CutBody body = prepared;
    out.activeVoxelsBefore = body.activity.activeVoxels.size();
    CutStepResult step = cutStep(body, sweep, params.threaded);
    pos.push_back(step.positionUpdateMs);
    inter.push_back(step.intersectionMs);
    sub.push_back(step.subdivisionMs);
    def.push_back(step.deferredMs);
    if (r + 1 == repeat) {
      out.step = std::move(step);
      out.body = std::move(body);
    }
  }
  out.step.positionUpdateMs = median(pos);
  out.step.intersectionMs = median(inter);
  out.step.subdivisionMs = median(sub);
  out.step.deferredMs = median(def);
  out.cutHash = cutSetHash(out.step.cuts);
  out.activeVoxelsAfter = out.body.activity.activeVoxels.size();
  if (params.contour) {
    out.pieces = findPieces(out.body.grid).count;
    out.surface = dualContour(out.body.grid, {.qefThreshold = 0.1, .threaded = params.threaded});
    out.topology = surfaceTopology(out.surface);
  }
  return out;
}

}  // namespace voxcut
