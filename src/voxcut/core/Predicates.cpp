#include "voxcut/core/Predicates.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "voxcut/core/Error.h"

namespace voxcut {
namespace {

// ---------------------------------------------------------------------------------------------
// Error bounds. kEps is the unit roundoff of binary64 (half an ulp of 1). The bounds are
// Shewchuk's bounds A (relative to the permanent). kUnderflowSlack covers the absolute errors of
// products that underflow: the filter is only trusted when the permanent is at least
// kMinPermanent * (1 + |u|_1); then those errors (at most 2^-1070 (1 + |u|_1)) are below
// 2^-270 times the permanent, well inside the slack. Fused multiply-adds that the compiler may
// contract only remove roundings, so the bounds stay valid.
constexpr double kEps = 0x1p-53;
constexpr double kUnderflowSlack = 0x1p-260;
constexpr double kOrient2dBound = (3.0 + 16.0 * kEps) * kEps + kUnderflowSlack;
constexpr double kOrient3dBound = (7.0 + 56.0 * kEps) * kEps + kUnderflowSlack;
constexpr double kMinPermanent = 0x1p-800;

// ---------------------------------------------------------------------------------------------
// Floating-point expansions: a value is the exact sum of its components, which are
// nonoverlapping and stored in increasing magnitude, zeros eliminated (a zero value is the
// single component 0). The sign of an expansion is the sign of its last component.

/// s + e = a + b exactly, s = fl(a + b) (Knuth's TwoSum; no magnitude precondition).
inline void twoSum(double a, double b, double& s, double& e) {
  s = a + b;
  const double bv = s - a;
  const double av = s - bv;
  e = (a - av) + (b - bv);
}

/// p + e = a * b exactly, p = fl(a * b) (exact unless the product underflows or overflows).
inline void twoProduct(double a, double b, double& p, double& e) {
  p = a * b;
  e = std::fma(a, b, -p);
}

/// An expansion with a fixed capacity, on the stack.
template <int N>
struct Expansion {
  std::array<double, N> c{};
  int n = 0;
  [[nodiscard]] int sign() const { return c[n - 1] > 0 ? 1 : (c[n - 1] < 0 ? -1 : 0); }
  void push(double x) {
    if (x != 0.0) c[n++] = x;
  }
  void finish() {
    if (n == 0) c[n++] = 0.0;
  }
};

/// The exact difference b - a as an expansion of at most two components.
Expansion<2> difference(double b, double a) {
  double s = 0, e = 0;
  twoSum(b, -a, s, e);
  Expansion<2> h;
  h.push(e);
  h.push(s);
  h.finish();
  return h;
}

/// h = e + f by repeated growth (Shewchuk's EXPANSION-SUM; quadratic but simple, and this path
/// only runs for nearly degenerate inputs). h needs e.n + f.n slots (checked).
template <int N, int M, int K>
void sum(const Expansion<N>& e, const Expansion<M>& f, Expansion<K>& h) {
  VOXCUT_ASSERT(e.n + f.n <= K, "expansion capacity");
  Expansion<K> other;
  Expansion<K>* a = &h;
  Expansion<K>* b = &other;
  std::copy_n(e.c.begin(), e.n, a->c.begin());
  a->n = e.n;
  for (int j = 0; j < f.n; ++j) {
    if (f.c[j] == 0.0) continue;
    b->n = 0;
    double q = f.c[j];
    for (int i = 0; i < a->n; ++i) {
      double s = 0, err = 0;
      twoSum(q, a->c[i], s, err);
      b->push(err);
      q = s;
    }
    b->push(q);
    b->finish();
    std::swap(a, b);
  }
  if (a != &h) h = *a;
}

/// h = e * b (Shewchuk's SCALE-EXPANSION with TwoSum in place of FastTwoSum, which gives the
/// same results without relying on its magnitude precondition).
template <int N, int M>
void scale(const Expansion<N>& e, double b, Expansion<M>& h) {
  static_assert(M >= 2 * N);
  h.n = 0;
  double q = 0, lo = 0;
  twoProduct(e.c[0], b, q, lo);
  h.push(lo);
  for (int i = 1; i < e.n; ++i) {
    double hi = 0, t = 0, s = 0, err = 0;
    twoProduct(e.c[i], b, hi, t);
    twoSum(q, t, s, err);
    h.push(err);
    twoSum(hi, s, q, err);
    h.push(err);
  }
  h.push(q);
  h.finish();
}

/// h = e * f: the sum over f's components of e scaled by each.
template <int N, int M, int K>
void product(const Expansion<N>& e, const Expansion<M>& f, Expansion<K>& h) {
  static_assert(K >= 2 * N * M);
  Expansion<K> other;
  Expansion<K>* acc = &h;
  Expansion<K>* next = &other;
  acc->n = 0;
  acc->finish();
  for (int j = 0; j < f.n; ++j) {
    Expansion<2 * N> part;
    scale(e, f.c[j], part);
    sum(*acc, part, *next);
    std::swap(acc, next);
  }
  if (acc != &h) h = *acc;
}

template <int N>
Expansion<N> negated(Expansion<N> e) {
  for (int i = 0; i < e.n; ++i) e.c[i] = -e.c[i];
  return e;
}

/// Multiplies all coordinates by a power of two so that the largest magnitude lies in
/// [0.5, 1) when it is outside [2^-200, 2^200]: exact, and keeps the expansion products away
/// from overflow and underflow.
template <std::size_t K>
void rescale(std::array<double, K>& v) {
  double m = 0;
  for (const double x : v) {
    VOXCUT_ASSERT(std::isfinite(x), "orientation predicate on a non-finite coordinate");
    m = std::max(m, std::abs(x));
  }
  if (m == 0.0 || (m >= 0x1p-200 && m <= 0x1p200)) return;
  int exponent = 0;
  std::frexp(m, &exponent);
  for (double& x : v) x = std::ldexp(x, -exponent);
}

/// x * y - z * w for two-component expansions (at most 16 components).
Expansion<16> minor2(const Expansion<2>& x, const Expansion<2>& y, const Expansion<2>& z,
                     const Expansion<2>& w) {
  Expansion<8> p, q;
  product(x, y, p);
  product(z, w, q);
  Expansion<16> r;
  sum(p, negated(q), r);
  return r;
}

int orient2dExactImpl(std::array<double, 6> v) {
  rescale(v);
  const Expansion<2> ux = difference(v[2], v[0]), uy = difference(v[3], v[1]);
  const Expansion<2> wx = difference(v[4], v[0]), wy = difference(v[5], v[1]);
  return minor2(ux, wy, uy, wx).sign();
}

int orient3dExactImpl(std::array<double, 12> v) {
  rescale(v);
  std::array<Expansion<2>, 9> d;  // u = b - a, v = c - a, w = d - a, coordinate-major
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < 3; ++i) d[3 * k + i] = difference(v[3 * (k + 1) + i], v[i]);
  }
  const auto& [ux, uy, uz, vx, vy, vz, wx, wy, wz] = d;
  // det = ux (vy wz - vz wy) + uy (vz wx - vx wz) + uz (vx wy - vy wx)
  Expansion<64> tx, ty, tz;
  product(minor2(vy, wz, vz, wy), ux, tx);
  product(minor2(vz, wx, vx, wz), uy, ty);
  product(minor2(vx, wy, vy, wx), uz, tz);
  Expansion<128> txy;
  sum(tx, ty, txy);
  Expansion<192> det;
  sum(txy, tz, det);
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
  return orient2dExact(a, b, c);
}

int orient2dExact(const Vec2d& a, const Vec2d& b, const Vec2d& c) {
  return orient2dExactImpl({a.x(), a.y(), b.x(), b.y(), c.x(), c.y()});
}

int orient3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const double ux = b.x() - a.x(), uy = b.y() - a.y(), uz = b.z() - a.z();
  const double vx = c.x() - a.x(), vy = c.y() - a.y(), vz = c.z() - a.z();
  const double wx = d.x() - a.x(), wy = d.y() - a.y(), wz = d.z() - a.z();
  const double vywz = vy * wz, vzwy = vz * wy;
  const double vzwx = vz * wx, vxwz = vx * wz;
  const double vxwy = vx * wy, vywx = vy * wx;
  const double det = ux * (vywz - vzwy) + uy * (vzwx - vxwz) + uz * (vxwy - vywx);
  const double aux = std::abs(ux), auy = std::abs(uy), auz = std::abs(uz);
  const double permanent = aux * (std::abs(vywz) + std::abs(vzwy)) +
                           auy * (std::abs(vzwx) + std::abs(vxwz)) +
                           auz * (std::abs(vxwy) + std::abs(vywx));
  if (permanent >= kMinPermanent * (1.0 + aux + auy + auz)) {
    const double bound = kOrient3dBound * permanent;
    if (det > bound) return 1;
    if (-det > bound) return -1;
  }
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
