#include "voxcut/voxel/LabelResample.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/voxel/GridLinks.h"

namespace voxcut {
namespace {

constexpr float kMinT = 1e-3f;
constexpr int kRootIterations = 30;
// Crossings are stored as floats and placed by a QEF: 1e-4 of a link is far below what either
// can tell apart, and stops the search after a few steps.
constexpr double kRootTolerance = 1e-4;

// The file's materials over a box of file voxels around the chosen labels, and the smoothed
// indicators f_m of LabelResample.h evaluated from them.
class LabelField {
 public:
  // `keepLinks`: also keep which links change material, for forChangingLinks (one byte per
  // file voxel of the box).
  LabelField(const LabelVolume& volume, const std::vector<std::uint8_t>& materialOfIndex,
             const std::array<Index3, 2>& labelled, double radius, bool keepLinks, bool threaded)
      : radius_(radius), inverse_(volume.axes.inverse()), origin_(volume.origin) {
    reach_ = static_cast<int>(std::ceil(radius + 0.5)) - 1;
    const int margin = reach_ + 2;
    for (int a = 0; a < 3; ++a) {
      lo_[a] = labelled[0][a] - margin;
      dims_[a] = labelled[1][a] - labelled[0][a] + 1 + 2 * margin;
    }
    const std::size_t n = count();
    material_.assign(n, 0);
    parallelFor(
        0, static_cast<std::size_t>(dims_.z), 1,
        [&](std::size_t z0, std::size_t z1) {
          for (std::size_t z = z0; z < z1; ++z) {
            const int k = lo_.z + static_cast<int>(z);
            if (k < 0 || k >= volume.dims.z) continue;
            for (int y = 0; y < dims_.y; ++y) {
              const int j = lo_.y + y;
              if (j < 0 || j >= volume.dims.y) continue;
              for (int x = 0; x < dims_.x; ++x) {
                const int i = lo_.x + x;
                if (i < 0 || i >= volume.dims.x) continue;
                material_[local(x, y, static_cast<int>(z))] =
                    materialOfIndex[volume.index[volume.linear(i, j, k)]];
              }
            }
          }
        },
        threaded);
    buildUniform(keepLinks, threaded);
  }

  // Continuous file index of world point p.
  [[nodiscard]] Vec3d indexOf(const Vec3d& p) const { return inverse_ * (p - origin_); }
  [[nodiscard]] const Eigen::Matrix3d& inverse() const { return inverse_; }

  // The material with the largest smoothed indicator at continuous index u (ties: the lower
  // material, background first).
  [[nodiscard]] std::uint8_t materialAt(const Vec3d& u) const {
    Index3 q;
    for (int a = 0; a < 3; ++a) {
      const double r = std::floor(u[a] + 0.5) - lo_[a];
      if (r < 0 || r >= dims_[a]) return 0;  // beyond the margin: all background
      q[a] = static_cast<int>(r);
    }
    const std::size_t l = local(q.x, q.y, q.z);
    if (uniform_[l]) return material_[l];
    // Weights per material, in a small list (few materials meet at one point).
    std::array<std::pair<std::uint8_t, double>, 16> acc;
    std::size_t used = 0;
    // More materials than the list holds: all of them by material (filled only then; zeroing
    // it for every call would cost more than the sums).
    std::array<double, 256> overflow;
    bool spilled = false;
    forKernel(u, false, [&](std::uint8_t m, double w, const Vec3d&) {
      for (std::size_t i = 0; i < used; ++i)
        if (acc[i].first == m) {
          acc[i].second += w;
          return;
        }
      if (used < acc.size()) {
        acc[used++] = {m, w};
        return;
      }
      if (!spilled) overflow.fill(0.0);
      spilled = true;
      overflow[m] += w;
    });
    if (spilled)
      for (std::size_t i = 0; i < used; ++i) overflow[acc[i].first] += acc[i].second;
    std::uint8_t best = 0;
    double bestW = -1.0;
    if (spilled) {
      for (int m = 0; m < 256; ++m)
        if (overflow[static_cast<std::size_t>(m)] > bestW) {
          bestW = overflow[static_cast<std::size_t>(m)];
          best = static_cast<std::uint8_t>(m);
        }
      return best;
    }
    for (std::size_t i = 0; i < used; ++i)
      if (acc[i].second > bestW || (acc[i].second == bestW && acc[i].first < best)) {
        bestW = acc[i].second;
        best = acc[i].first;
      }
    return best;
  }

  // Calls fn(i, j, k, a, low, high) for every link between two materials from file voxel
  // (i, j, k) along +a (materials low at (i, j, k), high beyond), over voxels in [lo, hi].
  template <class Fn>
  void forChangingLinks(const Index3& lo, const Index3& hi, Fn&& fn) const {
    VOXCUT_ASSERT(!changes_.empty(), "the field was built without its links");
    Index3 a0, a1;
    for (int a = 0; a < 3; ++a) {
      a0[a] = std::max(lo[a] - lo_[a], 0);
      a1[a] = std::min(hi[a] - lo_[a], dims_[a] - 1);
    }
    for (int z = a0.z; z <= a1.z; ++z)
      for (int y = a0.y; y <= a1.y; ++y) {
        const std::size_t row = local(0, y, z);
        for (int x = a0.x; x <= a1.x; ++x) {
          const std::size_t l = row + static_cast<std::size_t>(x);
          const std::uint8_t bits = changes_[l];
          if (!bits) continue;
          const std::uint8_t m = material_[l];
          if (bits & 1) fn(x + lo_.x, y + lo_.y, z + lo_.z, 0, m, material_[l + 1]);
          if (bits & 2) fn(x + lo_.x, y + lo_.y, z + lo_.z, 1, m, material_[local(x, y + 1, z)]);
          if (bits & 4) fn(x + lo_.x, y + lo_.y, z + lo_.z, 2, m, material_[local(x, y, z + 1)]);
        }
      }
  }

  // g(u) = N_m0(u) - N_m1(u), the difference of the unnormalised kernel sums (same sign and
  // same zero set as f_m0 - f_m1), and its gradient with respect to u when `gradient`.
  [[nodiscard]] double difference(const Vec3d& u, std::uint8_t m0, std::uint8_t m1,
                                  Vec3d* gradient) const {
    double g = 0.0;
    Vec3d grad = Vec3d::Zero();
    forKernel(u, gradient != nullptr, [&](std::uint8_t m, double w, const Vec3d& dw) {
      if (m == m0) {
        g += w;
        grad += dw;
      } else if (m == m1) {
        g -= w;
        grad -= dw;
      }
    });
    if (gradient) *gradient = grad;
    return g;
  }

 private:
  [[nodiscard]] std::size_t count() const {
    return static_cast<std::size_t>(dims_.x) * static_cast<std::size_t>(dims_.y) *
           static_cast<std::size_t>(dims_.z);
  }
  [[nodiscard]] std::size_t local(int x, int y, int z) const {
    return static_cast<std::size_t>(x) +
           static_cast<std::size_t>(dims_.x) *
               (static_cast<std::size_t>(y) +
                static_cast<std::size_t>(dims_.y) * static_cast<std::size_t>(z));
  }

  // uniform_[l]: every file voxel within `reach_` (Chebyshev) of l holds l's material, so the
  // kernel around any point nearest to l sees one material. From the voxels whose +x, +y or +z
  // neighbour differs, dilated by reach_ along each axis in turn. Those neighbours are kept in
  // changes_ when `keepLinks` (for forChangingLinks).
  void buildUniform(bool keepLinks, bool threaded) {
    std::vector<std::uint8_t> edge(count(), 0);
    if (keepLinks) changes_.assign(count(), 0);
    std::uint8_t* const kept = keepLinks ? changes_.data() : nullptr;
    parallelFor(
        0, static_cast<std::size_t>(dims_.z), 1,
        [&](std::size_t z0, std::size_t z1) {
          for (int z = static_cast<int>(z0); z < static_cast<int>(z1); ++z)
            for (int y = 0; y < dims_.y; ++y)
              for (int x = 0; x < dims_.x; ++x) {
                const std::size_t l = local(x, y, z);
                const std::uint8_t m = material_[l];
                const auto bits = static_cast<std::uint8_t>(
                    (x + 1 < dims_.x && material_[l + 1] != m ? 1 : 0) |
                    (y + 1 < dims_.y && material_[local(x, y + 1, z)] != m ? 2 : 0) |
                    (z + 1 < dims_.z && material_[local(x, y, z + 1)] != m ? 4 : 0));
                edge[l] = bits != 0;
                if (kept) kept[l] = bits;
              }
        },
        threaded);
    for (int a = 0; a < 3; ++a) dilate(edge, a, threaded);
    uniform_.resize(edge.size());
    for (std::size_t l = 0; l < edge.size(); ++l) uniform_[l] = !edge[l];
  }

  // Max filter of radius reach_ along axis a, line by line.
  void dilate(std::vector<std::uint8_t>& flags, int a, bool threaded) const {
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    const std::size_t lines =
        static_cast<std::size_t>(dims_[u]) * static_cast<std::size_t>(dims_[w]);
    const std::size_t step = a == 0 ? 1
                                    : (a == 1 ? static_cast<std::size_t>(dims_.x)
                                              : static_cast<std::size_t>(dims_.x) * dims_.y);
    parallelFor(
        0, lines, 64,
        [&](std::size_t l0, std::size_t l1) {
          std::vector<std::uint8_t> line(static_cast<std::size_t>(dims_[a]));
          for (std::size_t li = l0; li < l1; ++li) {
            Index3 c;
            c[u] = static_cast<int>(li % static_cast<std::size_t>(dims_[u]));
            c[w] = static_cast<int>(li / static_cast<std::size_t>(dims_[u]));
            c[a] = 0;
            const std::size_t start = local(c.x, c.y, c.z);
            for (int s = 0; s < dims_[a]; ++s)
              line[static_cast<std::size_t>(s)] = flags[start + s * step];
            // Distance to the nearest set flag within reach, by a forward and a backward scan.
            int last = std::numeric_limits<int>::min() / 2;
            std::vector<int> near(static_cast<std::size_t>(dims_[a]),
                                  std::numeric_limits<int>::max());
            for (int s = 0; s < dims_[a]; ++s) {
              if (line[static_cast<std::size_t>(s)]) last = s;
              near[static_cast<std::size_t>(s)] = s - last;
            }
            last = std::numeric_limits<int>::max() / 2;
            for (int s = dims_[a] - 1; s >= 0; --s) {
              if (line[static_cast<std::size_t>(s)]) last = s;
              near[static_cast<std::size_t>(s)] =
                  std::min(near[static_cast<std::size_t>(s)], last - s);
            }
            for (int s = 0; s < dims_[a]; ++s)
              flags[start + s * step] = near[static_cast<std::size_t>(s)] <= reach_;
          }
        },
        threaded);
  }

  // Calls fn(material, W(u - j), dW/du) for every file voxel j in the kernel's support around u
  // (voxels outside the box count as background).
  template <class Fn>
  void forKernel(const Vec3d& u, bool gradient, Fn&& fn) const {
    constexpr int kMaxTaps = 9;  // 2 R + 1 for R up to 4
    std::array<std::array<double, kMaxTaps>, 3> w{}, dw{};
    std::array<int, 3> first{}, taps{};
    const double r2 = radius_ * radius_;
    for (int a = 0; a < 3; ++a) {
      first[a] = static_cast<int>(std::floor(u[a] - radius_)) + 1;
      const int last = static_cast<int>(std::ceil(u[a] + radius_)) - 1;
      taps[a] = std::min(kMaxTaps, last - first[a] + 1);
      for (int t = 0; t < taps[a]; ++t) {
        const double x = u[a] - (first[a] + t);
        const double s = std::max(0.0, 1.0 - x * x / r2);
        w[a][static_cast<std::size_t>(t)] = s * s * s;
        dw[a][static_cast<std::size_t>(t)] = -6.0 * x / r2 * s * s;
      }
    }
    for (int tz = 0; tz < taps[2]; ++tz) {
      const int z = first[2] + tz - lo_.z;
      for (int ty = 0; ty < taps[1]; ++ty) {
        const int y = first[1] + ty - lo_.y;
        for (int tx = 0; tx < taps[0]; ++tx) {
          const int x = first[0] + tx - lo_.x;
          const bool inside =
              x >= 0 && y >= 0 && z >= 0 && x < dims_.x && y < dims_.y && z < dims_.z;
          const std::uint8_t m = inside ? material_[local(x, y, z)] : std::uint8_t{0};
          const auto ix = static_cast<std::size_t>(tx), iy = static_cast<std::size_t>(ty),
                     iz = static_cast<std::size_t>(tz);
          const double wxy = w[0][ix] * w[1][iy];
          Vec3d d = Vec3d::Zero();
          if (gradient)
            d = Vec3d(dw[0][ix] * w[1][iy] * w[2][iz], w[0][ix] * dw[1][iy] * w[2][iz],
                      wxy * dw[2][iz]);
          fn(m, wxy * w[2][iz], d);
        }
      }
    }
  }

  double radius_;
  int reach_ = 2;
  Eigen::Matrix3d inverse_;
  Vec3d origin_;
  Index3 lo_, dims_;
  std::vector<std::uint8_t> material_;
  std::vector<std::uint8_t> uniform_;
  std::vector<std::uint8_t> changes_;  // bit a: the +a neighbour holds another material; or empty
};

// Per compact label index of the volume, its material (0 for labels not chosen).
std::vector<std::uint8_t> materialOfIndex(const LabelVolume& volume,
                                          const std::vector<LabelChoice>& choices) {
  std::vector<std::uint8_t> out(volume.labels.size() + 1, 0);
  for (std::size_t c = 0; c < choices.size(); ++c)
    for (std::size_t l = 0; l < volume.labels.size(); ++l)
      if (volume.labels[l].value == choices[c].value) out[l + 1] = static_cast<std::uint8_t>(c + 1);
  return out;
}

// Index bounding box ({min, max}, inclusive) of the voxels with a non-zero material.
std::array<Index3, 2> labelledBox(const LabelVolume& volume,
                                  const std::vector<std::uint8_t>& materialOf) {
  std::array<Index3, 2> box{Index3{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(),
                                   std::numeric_limits<int>::max()},
                            Index3{-1, -1, -1}};
  for (int k = 0; k < volume.dims.z; ++k)
    for (int j = 0; j < volume.dims.y; ++j) {
      const std::size_t row = volume.linear(0, j, k);
      for (int i = 0; i < volume.dims.x; ++i) {
        if (!materialOf[volume.index[row + static_cast<std::size_t>(i)]]) continue;
        const Index3 c{i, j, k};
        for (int a = 0; a < 3; ++a) {
          box[0][a] = std::min(box[0][a], c[a]);
          box[1][a] = std::max(box[1][a], c[a]);
        }
      }
    }
  return box;
}

// Sets each grid voxel's material from the field at its centre.
void fillMaterials(VoxelGrid& grid, const LabelField& field, bool threaded) {
  const Index3 d = grid.dims();
  std::uint8_t* mat = grid.materialData();
  const Vec3d base = field.indexOf(grid.origin());
  const Eigen::Matrix3d step = field.inverse() * grid.voxelSize();
  parallelFor(
      0, static_cast<std::size_t>(d.z), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z)
          for (int y = 0; y < d.y; ++y)
            for (int x = 0; x < d.x; ++x) {
              const Vec3d u = base + step * Vec3d(x, y, static_cast<double>(z));
              mat[grid.index(x, y, static_cast<int>(z))] = field.materialAt(u);
            }
      },
      threaded);
}

// Drops connected pieces (6-connected voxels of one material) under `minIsland` voxels: each
// takes the material most of its outside face neighbours hold (ties: the lower material).
// Pieces are found and reassigned in the order of their first voxel, so the result is
// deterministic.
void dropIslands(VoxelGrid& grid, int minIsland, LabelResampleReport& rep) {
  if (minIsland <= 1) return;
  const Index3 d = grid.dims();
  std::uint8_t* mat = grid.materialData();
  const std::size_t n = grid.voxelCount();
  std::vector<std::uint8_t> seen(n, 0);
  std::vector<std::size_t> piece;
  for (std::size_t seed = 0; seed < n; ++seed) {
    if (seen[seed] || mat[seed] == 0) continue;
    const std::uint8_t m = mat[seed];
    piece.clear();
    piece.push_back(seed);
    seen[seed] = 1;
    for (std::size_t head = 0; head < piece.size(); ++head) {
      const std::size_t v = piece[head];
      const Index3 c = grid.coord(v);
      for (int a = 0; a < 3; ++a) {
        const std::size_t s = grid.stride(a);
        if (c[a] > 0 && !seen[v - s] && mat[v - s] == m) {
          seen[v - s] = 1;
          piece.push_back(v - s);
        }
        if (c[a] + 1 < d[a] && !seen[v + s] && mat[v + s] == m) {
          seen[v + s] = 1;
          piece.push_back(v + s);
        }
      }
    }
    if (piece.size() >= static_cast<std::size_t>(minIsland)) continue;
    std::array<std::size_t, 256> votes{};
    for (const std::size_t v : piece) {
      const Index3 c = grid.coord(v);
      for (int a = 0; a < 3; ++a) {
        const std::size_t s = grid.stride(a);
        if (c[a] > 0 && mat[v - s] != m) ++votes[mat[v - s]];
        if (c[a] + 1 < d[a] && mat[v + s] != m) ++votes[mat[v + s]];
      }
    }
    const auto winner =
        static_cast<std::uint8_t>(std::max_element(votes.begin(), votes.end()) - votes.begin());
    for (const std::size_t v : piece) mat[v] = winner;
    ++rep.islandsDropped;
    rep.islandVoxels += piece.size();
  }
}

// A local fit of the boundary to the file's own boundary links (docs/algorithms.md, "Label
// volumes"). The kernel average cannot place a boundary that runs nearly parallel to a lattice
// plane of the file: over a terrace several voxels wide every voxel says only that the
// boundary lies between two voxel centres, and the average sits half-way whatever the true
// height. What does place it are the links that cross the boundary almost tangentially (the
// terraces' edges): the boundary crosses a link within half a link of its midpoint, so the
// midpoint is off the boundary by at most half the link's component along the normal. So
// around each crossing a quadric height field over the kernel's tangent plane is fitted to the
// midpoints of the links between m0 and other materials, each weighted by the inverse of that
// error's variance; the window grows until the fitted height at the centre is known to
// kFitSigma, and a fit is used only while its residuals are those of the quantisation.
constexpr int kFitWindows[] = {5, 8, 12};  // lateral radii tried, in file voxels
constexpr int kFitSmallWindow = 3;         // tried when no larger window gives a sound fit
constexpr double kFitSigma = 0.04;         // wanted standard error of the height, in voxels
constexpr double kFitLooseSigma = 0.12;    // least precision a fallback fit must have
constexpr double kModelSigma = 0.03;       // error floor of a midpoint, in voxels
constexpr double kFitMaxChi2 = 4.0;        // mean weighted squared residual accepted
constexpr std::size_t kFitMinLinks = 12;
// A smooth boundary crosses at most pi W^2 sqrt(3) links within a lateral radius W (fewer
// facing the way its normal does); three times that and the region is noise or folds.
constexpr double kFitMaxLinksPerArea = 3.0 * 3.14159265358979 * 1.7320508;
constexpr double kFitGridRatio = 1.5;  // grid voxel / file spacing up to which it is used

using Vec6 = Eigen::Matrix<double, 6, 1>;

// A quadric height field h(x, y) = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 over the
// tangent frame (s, t) at `centre`, height along n (outward from m0), in file index space.
struct HeightFit {
  Vec3d centre, n, s, t;
  Vec6 coef;
  // F(u) = height of u above the field: positive outside m0.
  [[nodiscard]] double value(const Vec3d& u) const {
    const Vec3d d = u - centre;
    const double x = d.dot(s), y = d.dot(t);
    return d.dot(n) - (coef[0] + coef[1] * x + coef[2] * y + coef[3] * x * x + coef[4] * x * y +
                       coef[5] * y * y);
  }
  [[nodiscard]] Vec3d gradient(const Vec3d& u) const {
    const Vec3d d = u - centre;
    const double x = d.dot(s), y = d.dot(t);
    return n - (coef[1] + 2 * coef[3] * x + coef[4] * y) * s -
           (coef[2] + coef[4] * x + 2 * coef[5] * y) * t;
  }
};

// One link midpoint in the fit's frame: lateral (x, y), height z, the window's falloff and
// the link's axis.
struct FitSample {
  double x, y, z, falloff;
  int axis;
};

// The result of one weighted least-squares fit (coefficients in window units).
struct FitResult {
  Vec6 k;
  double variance = 0;  // of the height at the centre
  double chi2 = 0;      // mean weighted squared residual per link
};

// Weighted least squares of the quadric over `samples` (lateral coordinates divided by
// `window`). The error of a midpoint along the boundary's normal N is its link's component N_a
// over sqrt(12) (uniform within half a link); N is the centre's n, or the normal of `prior` at
// the sample when given.
bool solveFit(const std::vector<FitSample>& samples, const HeightFit& frame, int window,
              const FitResult* prior, FitResult& out) {
  const double inv = 1.0 / window;
  Eigen::Matrix<double, 6, 6> m = Eigen::Matrix<double, 6, 6>::Zero();
  Vec6 rhs = Vec6::Zero();
  std::vector<double> w(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const FitSample& p = samples[i];
    const double x = p.x * inv, y = p.y * inv;
    double na = frame.n[p.axis];
    if (prior) {
      const Vec6& c = prior->k;
      const double hx = (c[1] + 2 * c[3] * x + c[4] * y) * inv;
      const double hy = (c[2] + c[4] * x + 2 * c[5] * y) * inv;
      na = (na - hx * frame.s[p.axis] - hy * frame.t[p.axis]) / std::sqrt(1 + hx * hx + hy * hy);
    }
    w[i] = p.falloff / (na * na / 12.0 + kModelSigma * kModelSigma);
    const std::array<double, 6> phi{1, x, y, x * x, x * y, y * y};
    for (int r = 0; r < 6; ++r) {
      const double wr = w[i] * phi[static_cast<std::size_t>(r)];
      for (int c = r; c < 6; ++c) m(r, c) += wr * phi[static_cast<std::size_t>(c)];
      rhs[r] += wr * p.z;
    }
  }
  m.triangularView<Eigen::StrictlyLower>() = m.transpose();
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(m);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
  out.variance = ldlt.solve(Vec6::Unit(0))[0];
  if (!(out.variance > 0.0) || !std::isfinite(out.variance)) return false;
  out.k = ldlt.solve(rhs);
  double sum = 0, weight = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const FitSample& p = samples[i];
    const double x = p.x * inv, y = p.y * inv;
    const Vec6& k = out.k;
    const double e = k[0] + k[1] * x + k[2] * y + k[3] * x * x + k[4] * x * y + k[5] * y * y - p.z;
    sum += w[i] * e * e;
    weight += p.falloff;
  }
  out.chi2 = sum / weight;
  return std::isfinite(out.chi2);
}

// The midpoints of m0's links to other materials within `window` (laterally) of u, facing the
// way n does. False, with the samples incomplete, when there are more than one smooth boundary
// has there (noise, or a boundary folded on itself): the fit would be both slow and wrong.
bool gatherFitSamples(const LabelField& field, const HeightFit& frame, std::uint8_t m0, int window,
                      std::vector<FitSample>& samples) {
  samples.clear();
  const auto most = static_cast<std::size_t>(kFitMaxLinksPerArea * window * window);
  bool tooMany = false;
  const Vec3d& u = frame.centre;
  const double r2 = static_cast<double>(window) * window;
  Index3 lo, hi;
  for (int a = 0; a < 3; ++a) {
    lo[a] = static_cast<int>(std::floor(u[a])) - window - 1;
    hi[a] = static_cast<int>(std::ceil(u[a])) + window;
  }
  field.forChangingLinks(
      lo, hi, [&](int i, int j, int k, int a, std::uint8_t low, std::uint8_t high) {
        const bool in0 = low == m0;
        if (in0 == (high == m0)) return;
        // From m0 to the other material along the link: it must not face against n.
        if ((in0 ? 1.0 : -1.0) * frame.n[a] < -0.3) return;
        Vec3d d(i - u.x(), j - u.y(), k - u.z());
        d[a] += 0.5;
        const double x = d.dot(frame.s), y = d.dot(frame.t);
        const double lateral = (x * x + y * y) / r2;
        if (lateral >= 1.0 || tooMany) return;
        samples.push_back({x, y, d.dot(frame.n), (1.0 - lateral) * (1.0 - lateral), a});
        tooMany = samples.size() > most;
      });
  return !tooMany;
}

// Fits m0's boundary links around index point u with outward index-space normal n (|n| = 1).
// The smallest window whose fit is precise enough is taken; failing that, the most precise
// fit that still matches its links (a larger window can reach past where the boundary is a
// height field over this plane). False when none is sound.
bool fitHeightField(const LabelField& field, const Vec3d& u, const Vec3d& n, std::uint8_t m0,
                    HeightFit& fit) {
  fit.centre = u;
  fit.n = n;
  fit.s = (std::abs(n.x()) < 0.9 ? Vec3d::UnitX() : Vec3d::UnitY()).cross(n).normalized();
  fit.t = n.cross(fit.s);
  std::vector<FitSample> samples;
  samples.reserve(512);
  // A fit, then a refit with each link weighted by the first fit's normal at it.
  const auto fitTwice = [&](int window, FitResult& out) {
    FitResult first;
    return solveFit(samples, fit, window, nullptr, first) &&
           solveFit(samples, fit, window, &first, out);
  };
  int bestWindow = 0;
  double bestVariance = kFitLooseSigma * kFitLooseSigma;
  FitResult r, best;
  for (const int window : kFitWindows) {
    if (!gatherFitSamples(field, fit, m0, window, samples)) break;
    if (samples.size() < kFitMinLinks || !fitTwice(window, r)) continue;
    if (r.chi2 > kFitMaxChi2) break;  // not a smooth height field at this scale
    if (r.variance < bestVariance) {
      bestVariance = r.variance;
      bestWindow = window;
      best = r;
    }
    if (r.variance <= kFitSigma * kFitSigma) break;
  }
  if (bestWindow == 0) {
    // Curved too tightly for the first window: a smaller one.
    if (!gatherFitSamples(field, fit, m0, kFitSmallWindow, samples) ||
        samples.size() < kFitMinLinks || !fitTwice(kFitSmallWindow, r) || r.chi2 > kFitMaxChi2 ||
        r.variance >= bestVariance)
      return false;
    bestWindow = kFitSmallWindow;
    best = r;
  }
  const double inv = 1.0 / bestWindow;
  fit.coef << best.k[0], best.k[1] * inv, best.k[2] * inv, best.k[3] * inv * inv,
      best.k[4] * inv * inv, best.k[5] * inv * inv;
  return true;
}

// Hermite data of the link from grid voxel c along a, between materials m0 (low) and m1.
Hermite linkHermite(const VoxelGrid& grid, const LabelField& field, const Index3& c, int a,
                    std::uint8_t m0, std::uint8_t m1, bool refine) {
  const Vec3d u0 = field.indexOf(grid.position(grid.index(c)));
  Vec3d along = Vec3d::Zero();
  along[a] = grid.voxelSize();
  const Vec3d du = field.inverse() * along;
  double t0 = 0.0, t1 = 1.0;
  double g0 = field.difference(u0, m0, m1, nullptr);
  double g1 = field.difference(u0 + du, m0, m1, nullptr);
  double t = 0.5;
  if (g0 > 0.0 && g1 < 0.0) {
    // Illinois regula falsi on g(t) = N_m0 - N_m1: bracketed, superlinear.
    int side = 0;
    for (int it = 0; it < kRootIterations && t1 - t0 > kRootTolerance; ++it) {
      t = (t0 * g1 - t1 * g0) / (g1 - g0);
      const double g = field.difference(u0 + t * du, m0, m1, nullptr);
      if (g == 0.0) break;
      if (g > 0.0) {
        t0 = t;
        g0 = g;
        if (side == 1) g1 *= 0.5;
        side = 1;
      } else {
        t1 = t;
        g1 = g;
        if (side == -1) g0 *= 0.5;
        side = -1;
      }
    }
  }
  Vec3d grad;
  (void)field.difference(u0 + t * du, m0, m1, &grad);
  // g grows into m0, so m0's outward normal in index space is -grad g.
  Vec3d nIndex = -grad;
  // Where the links around fit a quadric well, the crossing and normal come from it.
  const double gl = grad.norm();
  HeightFit fit;
  if (refine && gl > 0.0 && fitHeightField(field, u0 + t * du, nIndex / gl, m0, fit)) {
    // F(u0 + s du) = 0 is quadratic in s: F(s) = q0 + q1 s + q2 s^2.
    const double f0 = fit.value(u0), fh = fit.value(u0 + 0.5 * du), f1 = fit.value(u0 + du);
    const double q0 = f0, q2 = 2.0 * (f0 + f1 - 2.0 * fh), q1 = f1 - f0 - q2;
    double root = -1.0;
    if (std::abs(q2) <= 1e-9 * std::abs(q1)) {
      root = -q0 / q1;
    } else {
      const double disc = q1 * q1 - 4.0 * q2 * q0;
      if (disc >= 0.0) {
        const double sq = std::sqrt(disc);
        const double ra = (-q1 - sq) / (2.0 * q2), rb = (-q1 + sq) / (2.0 * q2);
        root = std::abs(ra - t) < std::abs(rb - t) ? ra : rb;
      }
    }
    if (root >= 0.0 && root <= 1.0) {
      t = root;
      nIndex = fit.gradient(u0 + root * du);
    }
  }
  Hermite h;
  h.t = std::clamp(static_cast<float>(t), kMinT, 1.f - kMinT);
  // To world space (u = A^-1 (p - o)).
  Vec3d n = field.inverse().transpose() * nIndex;
  const double len = n.norm();
  if (!(len > 0.0) || !std::isfinite(len)) {
    n = Vec3d::Zero();
    n[a] = 1.0;
  } else {
    n /= len;
  }
  const double s = n[a] < 0 ? -1.0 : 1.0;
  for (int i = 0; i < 3; ++i) h.n[i] = static_cast<float>(s * n[i]);
  return h;
}

}  // namespace

std::vector<LabelChoice> defaultLabelChoices(const LabelVolume& volume) {
  std::vector<LabelChoice> out;
  for (const LabelInfo& l : volume.labels)
    out.push_back({l.value, l.name.empty() ? "label_" + std::to_string(l.value) : l.name});
  return out;
}

void checkLabelChoices(const LabelVolume& volume, const std::vector<LabelChoice>& choices,
                       const std::string& source) {
  if (choices.size() > 255)
    throw InputError(source + ": " + std::to_string(choices.size()) +
                     " labels chosen; at most 255 materials are supported");
  std::map<std::int64_t, std::size_t> values;
  std::map<std::string, std::int64_t> names;
  for (std::size_t c = 0; c < choices.size(); ++c) {
    const LabelChoice& ch = choices[c];
    const bool present = std::any_of(volume.labels.begin(), volume.labels.end(),
                                     [&](const LabelInfo& l) { return l.value == ch.value; });
    if (!present) {
      std::string have;
      for (std::size_t l = 0; l < volume.labels.size() && l < 20; ++l)
        have += (l ? ", " : "") + std::to_string(volume.labels[l].value);
      if (volume.labels.size() > 20) have += ", ...";
      throw InputError(source + ": label " + std::to_string(ch.value) +
                       " is not in the volume (its labels: " + have + ")");
    }
    if (!values.emplace(ch.value, c).second)
      throw InputError(source + ": label " + std::to_string(ch.value) + " is chosen twice");
    if (ch.name.empty())
      throw InputError(source + ": label " + std::to_string(ch.value) + " has an empty name");
    const auto [it, fresh] = names.emplace(ch.name, ch.value);
    if (!fresh)
      throw InputError(source + ": labels " + std::to_string(it->second) + " and " +
                       std::to_string(ch.value) + " have the same name '" + ch.name + "'");
  }
}

std::array<Vec3d, 2> labelBounds(const LabelVolume& volume,
                                 const std::vector<LabelChoice>& choices) {
  const auto box = labelledBox(volume, materialOfIndex(volume, choices));
  if (box[1].x < 0) throw InputError("no voxel holds a chosen label");
  std::array<Vec3d, 2> bounds{Vec3d::Constant(std::numeric_limits<double>::infinity()),
                              Vec3d::Constant(-std::numeric_limits<double>::infinity())};
  for (int corner = 0; corner < 8; ++corner) {
    Vec3d ijk;
    for (int a = 0; a < 3; ++a) ijk[a] = (corner >> a) & 1 ? box[1][a] + 0.5 : box[0][a] - 0.5;
    const Vec3d p = volume.world(ijk);
    bounds[0] = bounds[0].cwiseMin(p);
    bounds[1] = bounds[1].cwiseMax(p);
  }
  return bounds;
}

VoxelGrid resampleLabels(const LabelVolume& volume, const LabelResampleParams& params,
                         LabelResampleReport* report) {
  std::vector<LabelChoice> choices =
      params.labels.empty() ? defaultLabelChoices(volume) : params.labels;
  checkLabelChoices(volume, choices, "label volume");
  if (choices.empty()) throw InputError("label volume: no label to resample");
  if (!(params.kernelRadius >= 1.0 && params.kernelRadius <= 4.0))
    throw InputError("label volume: smoothing kernel radius must be in [1, 4] voxels");
  if (params.minIsland < 0) throw InputError("label volume: the island size must be >= 0");
  reportProgress(params.progress, "resample", 0.0);
  const std::vector<std::uint8_t> materialOf = materialOfIndex(volume, choices);
  const auto box = labelledBox(volume, materialOf);
  if (box[1].x < 0) throw InputError("label volume: no voxel holds a chosen label");
  const GridFrame frame =
      gridFrameFor(labelBounds(volume, choices), params.resolution, params.maxVoxels);
  VoxelGrid grid(frame.dims, frame.origin, frame.voxelSize, params.maxVoxels);
  std::vector<std::string> names;
  for (const auto& c : choices) names.push_back(c.name);
  grid.setMaterialNames(names);
  std::vector<std::optional<std::array<float, 3>>> colours;
  for (const auto& c : choices)
    for (const LabelInfo& l : volume.labels)
      if (l.value == c.value) colours.push_back(l.colour);
  grid.setMaterialColours(std::move(colours));

  // The link fit matters where grid voxels are about the file's size; on a grid 1.5 times
  // coarser than the file's coarsest spacing, the kernel's error is under a third of a grid
  // voxel, and the fit is skipped for its cost.
  const double coarsest =
      std::max({volume.axes.col(0).norm(), volume.axes.col(1).norm(), volume.axes.col(2).norm()});
  const bool refine = grid.voxelSize() <= kFitGridRatio * coarsest;
  const LabelField field(volume, materialOf, box, params.kernelRadius, refine, params.threaded);
  reportProgress(params.progress, "resample", 0.2);
  fillMaterials(grid, field, params.threaded);
  clearPadding(grid);
  reportProgress(params.progress, "resample", 0.5);
  LabelResampleReport rep;
  dropIslands(grid, params.minIsland, rep);
  if (rep.islandsDropped > 0)
    rep.warnings.push_back("dropped " + std::to_string(rep.islandsDropped) +
                           " islands of fewer than " + std::to_string(params.minIsland) +
                           " voxels (" + std::to_string(rep.islandVoxels) + " voxels in all)");
  reportProgress(params.progress, "resample", 0.6);
  buildLinks(
      grid,
      [&](const Index3& c, int a, std::uint8_t m0, std::uint8_t m1) {
        return linkHermite(grid, field, c, a, m0, m1, refine);
      },
      params.threaded);
  std::vector<std::size_t> counts(choices.size() + 1, 0);
  for (std::size_t v = 0; v < grid.voxelCount(); ++v) ++counts[grid.material(v)];
  for (std::size_t c = 0; c < choices.size(); ++c)
    if (counts[c + 1] == 0) {
      rep.vanished.push_back(choices[c].name);
      rep.warnings.push_back("label " + std::to_string(choices[c].value) + " ('" + choices[c].name +
                             "') has no voxel at this resolution (too small for the grid)");
    }
  reportProgress(params.progress, "resample", 1.0);
  if (report) *report = std::move(rep);
  return grid;
}

}  // namespace voxcut
