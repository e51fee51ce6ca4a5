#include "voxcut/core/Predicates.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "voxcut/core/Error.h"

namespace voxcut {
namespace {

using predicates_detail::kMinPermanent;
using predicates_detail::kOrient2dBound;

// ---------------------------------------------------------------------------------------------
// Exact arithmetic with floating-point expansions: a value is the exact sum of components that
// are nonoverlapping and stored in increasing magnitude, zeros eliminated; its sign is the
// sign of its largest component. All operations are error-free transformations, exact as long
// as no product underflows or overflows (rescale() sees to that within the documented domain).

/// s + e = a + b exactly, s = fl(a + b) (Knuth's TwoSum; no magnitude precondition).
inline void twoSum(double a, double b, double& s, double& e) {
  s = a + b;
  const double bv = s - a;
  const double av = s - bv;
  e = (a - av) + (b - bv);
}

/// p + e = a * b exactly, p = fl(a * b).
inline void twoProduct(double a, double b, double& p, double& e) {
  p = a * b;
  e = std::fma(a, b, -p);
}

/// The exact sum of the doubles added to it, kept as an expansion. add() is Shewchuk's
/// GROW-EXPANSION with zero elimination, done in place (component k is written only after
/// component i >= k has been read).
template <int N>
class ExactSum {
 public:
  void add(double x) {
    if (x == 0.0) return;
    VOXCUT_ASSERT(n_ < N, "exact sum capacity");
    double q = x;
    int k = 0;
    for (int i = 0; i < n_; ++i) {
      double s = 0, e = 0;
      twoSum(q, c_[i], s, e);
      if (e != 0.0) c_[k++] = e;
      q = s;
    }
    if (q != 0.0) c_[k++] = q;
    n_ = k;
  }
  /// Adds x * y * z exactly: x y = p + e, then p z and e z split the same way.
  void addProduct(double x, double y, double z) {
    if (x == 0.0 || y == 0.0 || z == 0.0) return;
    double p = 0, e = 0, hi = 0, lo = 0;
    twoProduct(x, y, p, e);
    twoProduct(p, z, hi, lo);
    add(lo);
    add(hi);
    if (e != 0.0) {
      twoProduct(e, z, hi, lo);
      add(lo);
      add(hi);
    }
  }
  /// Adds x * y exactly.
  void addProduct(double x, double y) {
    if (x == 0.0 || y == 0.0) return;
    double p = 0, e = 0;
    twoProduct(x, y, p, e);
    add(e);
    add(p);
  }
  [[nodiscard]] int sign() const { return n_ == 0 ? 0 : (c_[n_ - 1] > 0 ? 1 : -1); }

 private:
  double c_[N];  // uninitialised on purpose: only the first n_ are ever read
  int n_ = 0;
};

/// The exact difference b - a as two doubles (hi, lo), hi = fl(b - a).
std::array<double, 2> difference(double b, double a) {
  double s = 0, e = 0;
  twoSum(b, -a, s, e);
  return {s, e};
}

/// Multiplies all coordinates by a power of two so that the largest magnitude lies in
/// [0.5, 1): exact. Then, when the nonzero magnitudes lie within 2^300 of the largest, every
/// coordinate difference is a multiple of 2^-353, every product of three a multiple of
/// 2^-1059, and no error-free transformation underflows or overflows.
template <std::size_t K>
void rescale(std::array<double, K>& v) {
  double m = 0;
  for (const double x : v) {
    VOXCUT_ASSERT(std::isfinite(x), "orientation predicate on a non-finite coordinate");
    m = std::max(m, std::abs(x));
  }
  int exponent = 0;
  std::frexp(m, &exponent);
  if (m == 0.0 || exponent == 0) return;
  for (double& x : v) x = std::ldexp(x, -exponent);
}

int orient2dExactImpl(std::array<double, 6> v) {
  rescale(v);
  const auto ux = difference(v[2], v[0]), uy = difference(v[3], v[1]);
  const auto wx = difference(v[4], v[0]), wy = difference(v[5], v[1]);
  ExactSum<16> det;  // ux wy - uy wx, each difference in two parts
  for (const double a : ux) {
    for (const double b : wy) det.addProduct(a, b);
  }
  for (const double a : uy) {
    for (const double b : wx) det.addProduct(-a, b);
  }
  return det.sign();
}

int orient3dExactImpl(std::array<double, 12> v) {
  rescale(v);
  // d[3 k + i]: coordinate i of the k-th difference (b - a, c - a, d - a), in two parts.
  std::array<std::array<double, 2>, 9> d;
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < 3; ++i) d[3 * k + i] = difference(v[3 * (k + 1) + i], v[i]);
  }
  // det[u, v, w] = sum over permutations (i, j, k) of sign * u_i v_j w_k.
  constexpr int kPerms[6][4] = {{0, 1, 2, 1},  {0, 2, 1, -1}, {1, 2, 0, 1},
                                {1, 0, 2, -1}, {2, 0, 1, 1},  {2, 1, 0, -1}};
  ExactSum<192> det;
  for (const auto& p : kPerms) {
    for (const double x : d[p[0]]) {
      for (const double y : d[3 + p[1]]) {
        for (const double z : d[6 + p[2]]) det.addProduct(p[3] * x, y, z);
      }
    }
  }
  return det.sign();
}

// ---------------------------------------------------------------------------------------------
// Simulation of simplicity for the 4x4 determinant D = det[[p_i, 1]] (rows sorted by key),
// D = -orient3d. Entry (row r, coordinate c) is perturbed by eps^(2^(3r + 2 - c)). Expanding D
// multilinearly, each set S of perturbed entries (distinct rows, distinct coordinate columns)
// contributes eps^(sum of its exponents) times the signed complementary minor; exponents of
// distinct sets differ, so the first set, in increasing exponent, whose minor is nonzero
// decides. Sets of size 3 leave the constant minor 1, so the scan always ends.

struct SosTerm {
  int size = 0;
  std::array<int, 3> row{}, col{};
  int sign = 1;         // sign of the cofactor expansion for the removed entries
  unsigned weight = 0;  // sum of 2^(3r + 2 - c)
};

constexpr int kSosTermCount = 1 + 12 + 36 + 24;

constexpr std::array<SosTerm, kSosTermCount> makeSosTerms() {
  std::array<SosTerm, kSosTermCount> terms{};
  int count = 0;
  // choice[r] in {-1 (unperturbed), 0, 1, 2 (perturbed coordinate)} for r = 0..3.
  for (int code = 0; code < 256; ++code) {
    std::array<int, 4> choice{};
    bool used[3] = {false, false, false};
    bool valid = true;
    SosTerm t;
    for (int r = 0; r < 4; ++r) {
      choice[r] = ((code >> (2 * r)) & 3) - 1;
      if (choice[r] < 0) continue;
      if (choice[r] > 2 || used[choice[r]]) valid = false;
      if (!valid) break;
      used[choice[r]] = true;
      t.row[t.size] = r;
      t.col[t.size] = choice[r];
      ++t.size;
      t.weight += 1u << (3 * r + 2 - choice[r]);
    }
    if (!valid || t.size > 3) continue;
    // Laplace expansion along each removed row in turn; indices shift as rows and columns
    // before them are removed.
    for (int k = 0; k < t.size; ++k) {
      int r = t.row[k], c = t.col[k];
      for (int m = 0; m < k; ++m) {
        if (t.row[m] < t.row[k]) --r;
        if (t.col[m] < t.col[k]) --c;
      }
      if ((r + c) % 2 != 0) t.sign = -t.sign;
    }
    terms[count++] = t;
  }
  for (int i = 1; i < count; ++i) {  // insertion sort by weight
    for (int j = i; j > 0 && terms[j].weight < terms[j - 1].weight; --j) {
      std::swap(terms[j], terms[j - 1]);
    }
  }
  return terms;
}

constexpr std::array<SosTerm, kSosTermCount> kSosTerms = makeSosTerms();
static_assert(kSosTerms[0].size == 0 && kSosTerms[1].weight == 1);

/// Sign of the perturbed D for rows q[0..3] sorted by increasing key, given that the
/// unperturbed D is exactly 0.
int perturbedDeterminantSign(const std::array<const Vec3d*, 4>& q) {
  for (int i = 1; i < kSosTermCount; ++i) {
    const SosTerm& t = kSosTerms[i];
    std::array<int, 4> rows{};
    int nRows = 0;
    for (int r = 0; r < 4; ++r) {
      if (std::find(t.row.begin(), t.row.begin() + t.size, r) == t.row.begin() + t.size) {
        rows[nRows++] = r;
      }
    }
    std::array<int, 3> cols{};
    int nCols = 0;
    for (int c = 0; c < 3; ++c) {
      if (std::find(t.col.begin(), t.col.begin() + t.size, c) == t.col.begin() + t.size) {
        cols[nCols++] = c;
      }
    }
    int minor = 1;
    if (t.size == 1) {
      // det[[x_c1, x_c2, 1]] over the three remaining rows = orient2d of the projections.
      const auto proj = [&](int r) { return Vec2d((*q[r])[cols[0]], (*q[r])[cols[1]]); };
      minor = orient2d(proj(rows[0]), proj(rows[1]), proj(rows[2]));
    } else if (t.size == 2) {
      // det[[x_c, 1], [y_c, 1]] = x_c - y_c.
      const double x = (*q[rows[0]])[cols[0]], y = (*q[rows[1]])[cols[0]];
      minor = x > y ? 1 : (x < y ? -1 : 0);
    }
    if (minor != 0) return t.sign * minor;
  }
  VOXCUT_ASSERT(false, "simulation of simplicity did not terminate");
  return 0;
}

}  // namespace

int orient2d(const Vec2d& a, const Vec2d& b, const Vec2d& c) {
  const double ux = b.x() - a.x(), uy = b.y() - a.y();
  const double wx = c.x() - a.x(), wy = c.y() - a.y();
  const double l = ux * wy, r = uy * wx;
  const double det = l - r;
  const double permanent = std::abs(l) + std::abs(r);
  if (permanent >= kMinPermanent * (1.0 + std::abs(ux) + std::abs(uy))) {
    const double bound = kOrient2dBound * permanent;
    if (det > bound) return 1;
    if (-det > bound) return -1;
  }
  // A difference rounds to zero only when it is zero: both products vanish exactly when each
  // has a zero factor (common for axis-aligned data), no need for the exact sum.
  if ((ux == 0.0 || wy == 0.0) && (uy == 0.0 || wx == 0.0)) return 0;
  return orient2dExact(a, b, c);
}

int orient2dExact(const Vec2d& a, const Vec2d& b, const Vec2d& c) {
  return orient2dExactImpl({a.x(), a.y(), b.x(), b.y(), c.x(), c.y()});
}

int orient3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const Vec3d u = b - a, v = c - a, w = d - a;
  const int filtered = orient3dFilter(u, v, w);
  if (filtered != 0) return filtered;
  // A difference rounds to zero only when it is zero: if u, v, w share a zero coordinate
  // (axis-aligned data) or one of them vanishes, the determinant is exactly 0.
  for (int i = 0; i < 3; ++i) {
    if (u[i] == 0.0 && v[i] == 0.0 && w[i] == 0.0) return 0;
  }
  if ((u.array() == 0.0).all() || (v.array() == 0.0).all() || (w.array() == 0.0).all()) return 0;
  return orient3dExact(a, b, c, d);
}

int orient3dExact(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  return orient3dExactImpl(
      {a.x(), a.y(), a.z(), b.x(), b.y(), b.z(), c.x(), c.y(), c.z(), d.x(), d.y(), d.z()});
}

int orient3dSoS(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d,
                const SymbolicKey& ka, const SymbolicKey& kb, const SymbolicKey& kc,
                const SymbolicKey& kd) {
  const int exact = orient3d(a, b, c, d);
  if (exact != 0) return exact;
  std::array<const Vec3d*, 4> q{&a, &b, &c, &d};
  std::array<SymbolicKey, 4> k{ka, kb, kc, kd};
  int parity = 1;
  for (int i = 1; i < 4; ++i) {
    for (int j = i; j > 0 && k[j] < k[j - 1]; --j) {
      std::swap(k[j], k[j - 1]);
      std::swap(q[j], q[j - 1]);
      parity = -parity;
    }
  }
  VOXCUT_ASSERT(k[0] != k[1] && k[1] != k[2] && k[2] != k[3],
                "orient3dSoS needs four distinct symbolic keys");
  return -parity * perturbedDeterminantSign(q);
}

}  // namespace voxcut
