// orient2d / orient3d against an independent exact reference: the doubles are converted to
// integers on a common power-of-two grid and the determinant is evaluated in 512-bit
// two's-complement integer arithmetic.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "voxcut/core/Predicates.h"

namespace voxcut {
namespace {

__extension__ typedef unsigned __int128 U128;

/// Signed integers modulo 2^512 (two's complement): exact for the determinants below, whose
/// magnitudes stay far below 2^511.
struct Big {
  std::array<std::uint64_t, 8> w{};

  static Big of(std::int64_t x) {
    Big b;
    b.w.fill(x < 0 ? ~std::uint64_t{0} : 0);
    b.w[0] = static_cast<std::uint64_t>(x);
    return b;
  }
  Big operator+(const Big& o) const {
    Big r;
    U128 carry = 0;
    for (std::size_t i = 0; i < w.size(); ++i) {
      const U128 t = U128{w[i]} + o.w[i] + carry;
      r.w[i] = static_cast<std::uint64_t>(t);
      carry = t >> 64;
    }
    return r;
  }
  Big operator-(const Big& o) const {
    Big n;
    for (std::size_t i = 0; i < w.size(); ++i) n.w[i] = ~o.w[i];
    return *this + n + of(1);
  }
  Big operator*(const Big& o) const {
    Big r;
    for (std::size_t i = 0; i < w.size(); ++i) {
      U128 carry = 0;
      for (std::size_t j = 0; i + j < w.size(); ++j) {
        const U128 t = U128{w[i]} * o.w[j] + r.w[i + j] + carry;
        r.w[i + j] = static_cast<std::uint64_t>(t);
        carry = t >> 64;
      }
    }
    return r;
  }
  Big shifted(int k) const {  // * 2^k, k >= 0
    Big r;
    const int limbs = k / 64, bits = k % 64;
    for (int i = 7; i >= limbs; --i) {
      std::uint64_t v = w[static_cast<std::size_t>(i - limbs)] << bits;
      if (bits != 0 && i - limbs - 1 >= 0) {
        v |= w[static_cast<std::size_t>(i - limbs - 1)] >> (64 - bits);
      }
      r.w[static_cast<std::size_t>(i)] = v;
    }
    return r;
  }
  int sign() const {
    if (w[7] >> 63) return -1;
    return std::any_of(w.begin(), w.end(), [](std::uint64_t v) { return v != 0; }) ? 1 : 0;
  }
};

/// The exact values of the doubles, as integers times 2^e for a common e.
template <std::size_t N>
std::array<Big, N> exactValues(const std::array<double, N>& x) {
  int lowest = 1 << 20, highest = -(1 << 20);
  for (const double v : x) {
    if (v == 0.0) continue;
    int e = 0;
    std::frexp(v, &e);
    lowest = std::min(lowest, e - 53);
    highest = std::max(highest, e);
  }
  EXPECT_LE(highest - lowest, 150) << "exponent range too wide for the reference";
  std::array<Big, N> r;
  for (std::size_t i = 0; i < N; ++i) {
    if (x[i] == 0.0) continue;
    int e = 0;
    const double m = std::frexp(x[i], &e);
    r[i] = Big::of(static_cast<std::int64_t>(std::ldexp(m, 53))).shifted(e - 53 - lowest);
  }
  return r;
}

int referenceOrient3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const auto v = exactValues<12>(
      {a.x(), a.y(), a.z(), b.x(), b.y(), b.z(), c.x(), c.y(), c.z(), d.x(), d.y(), d.z()});
  const Big ux = v[3] - v[0], uy = v[4] - v[1], uz = v[5] - v[2];
  const Big vx = v[6] - v[0], vy = v[7] - v[1], vz = v[8] - v[2];
  const Big wx = v[9] - v[0], wy = v[10] - v[1], wz = v[11] - v[2];
  return (ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx)).sign();
}

int referenceOrient2d(const Vec2d& a, const Vec2d& b, const Vec2d& c) {
  const auto v = exactValues<6>({a.x(), a.y(), b.x(), b.y(), c.x(), c.y()});
  return ((v[2] - v[0]) * (v[5] - v[1]) - (v[3] - v[1]) * (v[4] - v[0])).sign();
}

int naiveOrient3d(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const double det = (b - a).cross(c - a).dot(d - a);
  return det > 0 ? 1 : (det < 0 ? -1 : 0);
}

Vec3d randomInts(std::mt19937_64& rng, std::int64_t range) {
  std::uniform_int_distribution<std::int64_t> dist(-range, range);
  return {static_cast<double>(dist(rng)), static_cast<double>(dist(rng)),
          static_cast<double>(dist(rng))};
}

TEST(Orient3d, SignConvention) {
  const Vec3d o = Vec3d::Zero(), x = Vec3d::UnitX(), y = Vec3d::UnitY(), z = Vec3d::UnitZ();
  EXPECT_EQ(orient3d(o, x, y, z), 1);
  EXPECT_EQ(orient3d(o, y, x, z), -1);
  EXPECT_EQ(orient3d(o, x, y, -z), -1);
  EXPECT_EQ(orient3d(o, x, y, Vec3d(5, -7, 0)), 0);
  EXPECT_EQ(orient3d(o, o, y, z), 0);
}

// Integer points (beyond 2^53, so neither the points nor their differences are always exact
// integers; the reference takes the doubles as they are) around a line:
// b - a = e, c - a = 2e + r1, d - a = 3e + r2 with tiny r: the determinant det[e, r1, r2] is
// tiny against the products, and naive floating point often gets its sign wrong.
TEST(Orient3d, NearlyCollinearIntegerPointsMatchExactReference) {
  std::mt19937_64 rng(1);
  int naiveWrong = 0, zeros = 0;
  for (int i = 0; i < 20000; ++i) {
    // Large a and e make differences up to 2^54 that doubles cannot hold exactly.
    const Vec3d a = randomInts(rng, std::int64_t{1} << (i % 2 == 0 ? 52 : 4));
    const Vec3d e = randomInts(rng, std::int64_t{1} << (i % 2 == 0 ? 51 : 49));
    const Vec3d b = a + e;
    const Vec3d c = a + 2 * e + randomInts(rng, 2);
    const Vec3d d = a + 3 * e + randomInts(rng, 2);
    const int ref = referenceOrient3d(a, b, c, d);
    ASSERT_EQ(orient3d(a, b, c, d), ref) << i;
    ASSERT_EQ(orient3dExact(a, b, c, d), ref) << i;
    naiveWrong += naiveOrient3d(a, b, c, d) != ref;
    zeros += ref == 0;
  }
  EXPECT_GT(naiveWrong, 1000);  // the test has teeth
  EXPECT_GT(zeros, 100);
}

// Exactly coplanar lattice points d = a + i (b - a) + j (c - a), then perturbed by at most
// one unit in each coordinate (or not at all).
TEST(Orient3d, PerturbedCoplanarLatticePoints) {
  std::mt19937_64 rng(2);
  int naiveWrong = 0;
  for (int n = 0; n < 20000; ++n) {
    const Vec3d a = randomInts(rng, std::int64_t{1} << 40);
    const Vec3d u = randomInts(rng, std::int64_t{1} << 24);
    const Vec3d v = randomInts(rng, std::int64_t{1} << 24);
    const double i = static_cast<double>(rng() % 64), j = static_cast<double>(rng() % 64);
    const Vec3d d =
        n % 3 == 0 ? Vec3d(a + i * u + j * v) : Vec3d(a + i * u + j * v + randomInts(rng, 1));
    const int ref = referenceOrient3d(a, a + u, a + v, d);
    ASSERT_EQ(orient3d(a, a + u, a + v, d), ref);
    naiveWrong += naiveOrient3d(a, a + u, a + v, d) != ref;
  }
  EXPECT_GT(naiveWrong, 100);
}

// Power-of-two scalings are exact, so the sign must not change, including at scales where
// the products overflow or underflow (the exact path rescales).
TEST(Orient3d, PowerOfTwoScalesDoNotChangeTheSign) {
  std::mt19937_64 rng(3);
  for (const int s : {-100, 100, -300, 300, -400, 400, -900, 900, -1000, 1000}) {
    for (int n = 0; n < 2000; ++n) {
      const Vec3d a = randomInts(rng, 1 << 20);
      const Vec3d e = randomInts(rng, 1 << 18);
      const Vec3d b = a + e, c = a + 2 * e + randomInts(rng, 1), d = a - e + randomInts(rng, 1);
      const double k = std::ldexp(1.0, s);
      ASSERT_EQ(orient3d(k * a, k * b, k * c, k * d), referenceOrient3d(a, b, c, d)) << s;
      ASSERT_EQ(orient3d(k * d, k * b, k * c, k * a), -referenceOrient3d(a, b, c, d)) << s;
    }
  }
}

// Points exactly on a line at scales 1e-30 and 1e30 (b, b + delta, b + 2 delta with delta on
// b's ulp grid, so the sums are exact), and points near that line.
TEST(Orient3d, PointsOnALineAtScales1eMinus30And1e30) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const double scale : {1e-30, 1e30}) {
    int exactZeros = 0, naiveWrong = 0;
    for (int n = 0; n < 5000; ++n) {
      Vec3d b, delta;
      for (int k = 0; k < 3; ++k) {
        b[k] = scale * (1.0 + 0.5 * std::abs(unit(rng)));  // in [1, 1.5) * scale
        int e = 0;
        std::frexp(b[k], &e);
        delta[k] = std::ldexp(static_cast<double>(static_cast<int>(rng() % 2001) - 1000), e - 53);
      }
      const Vec3d a(scale * unit(rng), scale * unit(rng), scale * unit(rng));
      const Vec3d c = b + delta;
      const Vec3d d = n % 2 == 0 ? Vec3d(b + 2 * delta) : Vec3d(b + 2 * delta + delta * 1e-3);
      const int ref = referenceOrient3d(a, b, c, d);
      ASSERT_EQ(orient3d(a, b, c, d), ref);
      ASSERT_EQ(orient3d(b, c, d, a), -ref);
      exactZeros += ref == 0;
      naiveWrong += naiveOrient3d(a, b, c, d) != ref;
    }
    EXPECT_GE(exactZeros, 2500) << scale;
    EXPECT_GT(naiveWrong, 100) << scale;
  }
}

TEST(Orient3d, SwappingTwoArgumentsNegates) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int n = 0; n < 3000; ++n) {
    std::array<Vec3d, 4> p;
    for (auto& q : p) {
      q = n % 2 == 0 ? randomInts(rng, 1) : Vec3d(unit(rng), unit(rng), unit(rng));
    }
    if (n % 4 == 1) p[3] = p[0] + 0.25 * (p[1] - p[0]) + 0.5 * (p[2] - p[0]);
    std::array<int, 4> perm{0, 1, 2, 3};
    const int s = orient3d(p[0], p[1], p[2], p[3]);
    ASSERT_EQ(s, referenceOrient3d(p[0], p[1], p[2], p[3]));
    do {
      int parity = 1;
      for (int i = 0; i < 4; ++i) {
        for (int j = i + 1; j < 4; ++j) parity *= perm[i] > perm[j] ? -1 : 1;
      }
      ASSERT_EQ(orient3d(p[perm[0]], p[perm[1]], p[perm[2]], p[perm[3]]), parity * s);
    } while (std::next_permutation(perm.begin(), perm.end()));
  }
}

// The exact path alone on random doubles of mixed magnitudes agrees with the reference.
TEST(Orient3d, ExactPathOnRandomDoubles) {
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-20, 20);
  for (int n = 0; n < 20000; ++n) {
    std::array<Vec3d, 4> p;
    for (auto& q : p) {
      for (int k = 0; k < 3; ++k) q[k] = std::ldexp(unit(rng), exponent(rng));
    }
    const int ref = referenceOrient3d(p[0], p[1], p[2], p[3]);
    ASSERT_EQ(orient3dExact(p[0], p[1], p[2], p[3]), ref);
    ASSERT_EQ(orient3d(p[0], p[1], p[2], p[3]), ref);
  }
}

// The classic failure of naive orient2d (Kettner et al., "Classroom examples of robustness
// problems"): p = (0.5 + x u, 0.5 + y u), q = (12, 12), r = (24, 24), u = 2^-53.
TEST(Orient2d, KettnerGridNearALine) {
  const double u = std::ldexp(1.0, -53);
  const Vec2d q(12, 12), r(24, 24);
  int naiveWrong = 0, zeros = 0;
  for (int x = 0; x < 256; ++x) {
    for (int y = 0; y < 256; ++y) {
      const Vec2d p(0.5 + x * u, 0.5 + y * u);
      const int ref = referenceOrient2d(p, q, r);
      ASSERT_EQ(orient2d(p, q, r), ref) << x << " " << y;
      ASSERT_EQ(orient2d(q, p, r), -ref);
      ASSERT_EQ(orient2dExact(r, p, q), ref);
      const double naive = (q.x() - p.x()) * (r.y() - p.y()) - (q.y() - p.y()) * (r.x() - p.x());
      naiveWrong += (naive > 0 ? 1 : (naive < 0 ? -1 : 0)) != ref;
      zeros += ref == 0;
    }
  }
  EXPECT_GT(naiveWrong, 1000);
  EXPECT_EQ(zeros, 256);  // the diagonal x == y
}

TEST(Orient2d, ConventionAndScales) {
  EXPECT_EQ(orient2d(Vec2d(0, 0), Vec2d(1, 0), Vec2d(0, 1)), 1);
  EXPECT_EQ(orient2d(Vec2d(0, 0), Vec2d(0, 1), Vec2d(1, 0)), -1);
  EXPECT_EQ(orient2d(Vec2d(0, 0), Vec2d(1, 1), Vec2d(3, 3)), 0);
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<std::int64_t> dist(-(std::int64_t{1} << 50), std::int64_t{1} << 50);
  for (const int s : {0, -100, 100, -700, 700}) {
    for (int n = 0; n < 5000; ++n) {
      const Vec2d a(static_cast<double>(dist(rng)), static_cast<double>(dist(rng)));
      const Vec2d e(static_cast<double>(dist(rng) >> 2), static_cast<double>(dist(rng) >> 2));
      const Vec2d b = a + e;
      const Vec2d c = a + 3 * e + Vec2d(static_cast<double>(n % 3 - 1), 0.0);
      const double k = std::ldexp(1.0, s);
      ASSERT_EQ(orient2d(k * a, k * b, k * c), referenceOrient2d(a, b, c)) << s;
    }
  }
}

}  // namespace
}  // namespace voxcut
