#include "voxcut/voxel/ScanConvert.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "voxcut/core/Parallel.h"

namespace voxcut {
namespace {

constexpr int kSnapBits = 20;
constexpr std::int64_t kOne = std::int64_t{1} << kSnapBits;
__extension__ typedef __int128 Wide;

struct P2 {
  std::int64_t x, y;
};

// Twice the signed area of (a, b, p), exact.
Wide orient(const P2& a, const P2& b, const P2& p) {
  return static_cast<Wide>(b.x - a.x) * static_cast<Wide>(p.y - a.y) -
         static_cast<Wide>(b.y - a.y) * static_cast<Wide>(p.x - a.x);
}

// A point exactly on edge a->b of a counter-clockwise triangle belongs to it when the edge is
// "top-left": equivalent to moving the point by (-eps, -eps^2), a consistent perturbation.
bool topLeft(const P2& a, const P2& b) {
  const std::int64_t dx = b.x - a.x, dy = b.y - a.y;
  return dy > 0 || (dy == 0 && dx < 0);
}

bool covers(Wide e, const P2& a, const P2& b) {
  return e > 0 || (e == 0 && topLeft(a, b));
}

std::int64_t floorDiv(std::int64_t v) {
  return v >= 0 ? v / kOne : -((-v + kOne - 1) / kOne);
}
std::int64_t ceilDiv(std::int64_t v) {
  return -floorDiv(-v);
}

struct RawCrossing {
  std::uint32_t line;
  double s;
  int face;
  int sign;
  bool operator<(const RawCrossing& o) const {
    return std::tie(line, s, face) < std::tie(o.line, o.s, o.face);
  }
};

}  // namespace

std::array<AxisCrossings, 3> scanConvert(const TriangleMesh& mesh, const GridFrame& frame,
                                         bool threaded) {
  // Snap vertices to the 2^-20 voxel lattice, in grid coordinates.
  const std::size_t nv = mesh.vertices.size();
  std::vector<std::array<std::int64_t, 3>> snapped(nv);
  for (std::size_t i = 0; i < nv; ++i)
    for (int a = 0; a < 3; ++a)
      snapped[i][a] = std::llround((mesh.vertices[i][a] - frame.origin[a]) / frame.voxelSize *
                                   static_cast<double>(kOne));

  constexpr std::size_t kChunk = 256;
  const std::size_t nf = mesh.faces.size();
  const std::size_t nChunks = (nf + kChunk - 1) / kChunk;
  std::array<AxisCrossings, 3> result;
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    AxisCrossings& ax = result[a];
    ax.axis = a;
    ax.nu = frame.dims[u];
    ax.nw = frame.dims[w];
    std::vector<std::vector<RawCrossing>> chunks(nChunks);
    parallelFor(
        0, nChunks, 1,
        [&](std::size_t c0, std::size_t c1) {
          for (std::size_t c = c0; c < c1; ++c) {
            std::vector<RawCrossing>& out = chunks[c];
            for (std::size_t f = c * kChunk; f < std::min(nf, (c + 1) * kChunk); ++f) {
              const auto& tri = mesh.faces[f];
              P2 p[3];
              double h[3];
              for (int k = 0; k < 3; ++k) {
                p[k] = {snapped[tri[k]][u], snapped[tri[k]][w]};
                h[k] = static_cast<double>(snapped[tri[k]][a]) / static_cast<double>(kOne);
              }
              const Wide area = orient(p[0], p[1], p[2]);
              if (area == 0) continue;
              const int sign = area > 0 ? 1 : -1;
              if (area < 0) {
                std::swap(p[1], p[2]);
                std::swap(h[1], h[2]);
              }
              const double areaD = static_cast<double>(area > 0 ? area : -area);
              const std::int64_t x0 =
                  std::max<std::int64_t>(0, ceilDiv(std::min({p[0].x, p[1].x, p[2].x})));
              const std::int64_t x1 =
                  std::min<std::int64_t>(ax.nu - 1, floorDiv(std::max({p[0].x, p[1].x, p[2].x})));
              const std::int64_t y0 =
                  std::max<std::int64_t>(0, ceilDiv(std::min({p[0].y, p[1].y, p[2].y})));
              const std::int64_t y1 =
                  std::min<std::int64_t>(ax.nw - 1, floorDiv(std::max({p[0].y, p[1].y, p[2].y})));
              for (std::int64_t iy = y0; iy <= y1; ++iy)
                for (std::int64_t ix = x0; ix <= x1; ++ix) {
                  const P2 q{ix * kOne, iy * kOne};
                  const Wide e0 = orient(p[1], p[2], q), e1 = orient(p[2], p[0], q),
                             e2 = orient(p[0], p[1], q);
                  if (!covers(e0, p[1], p[2]) || !covers(e1, p[2], p[0]) || !covers(e2, p[0], p[1]))
                    continue;
                  // Barycentric interpolation of the coordinate along the line.
                  const double s =
                      (static_cast<double>(e0) * h[0] + static_cast<double>(e1) * h[1] +
                       static_cast<double>(e2) * h[2]) /
                      areaD;
                  out.push_back(
                      {static_cast<std::uint32_t>(ix + ax.nu * iy), s, static_cast<int>(f), sign});
                }
            }
          }
        },
        threaded);
    std::vector<RawCrossing> all;
    for (auto& c : chunks) all.insert(all.end(), c.begin(), c.end());
    std::sort(all.begin(), all.end());
    const std::size_t nLines = static_cast<std::size_t>(ax.nu) * static_cast<std::size_t>(ax.nw);
    ax.offsets.assign(nLines + 1, 0);
    for (const auto& r : all) ++ax.offsets[r.line + 1];
    for (std::size_t l = 0; l < nLines; ++l) ax.offsets[l + 1] += ax.offsets[l];
    ax.crossings.resize(all.size());
    for (std::size_t i = 0; i < all.size(); ++i)
      ax.crossings[i] = {all[i].s, all[i].face, all[i].sign};
  }
  return result;
}

}  // namespace voxcut
