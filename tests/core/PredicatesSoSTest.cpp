// orient3dSoS against a brute-force reference: the perturbed 4x4 determinant expanded by the
// Leibniz formula into a polynomial in eps, whose lowest-order nonzero coefficient decides.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <random>

#include "voxcut/core/Predicates.h"

namespace voxcut {
namespace {

__extension__ typedef __int128 I128;

/// Sign of orient3d of the perturbed points, computed from scratch: rows (p_i, 1) with entry
/// (i, c) perturbed by eps^(2^(3 r_i + 2 - c)), r_i the rank of key i among the four.
/// Coordinates must be small integers.
int referenceSoS(const std::array<Vec3d, 4>& p, const std::array<SymbolicKey, 4>& k) {
  std::array<int, 4> rank{};
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) rank[i] += k[j] < k[i] ? 1 : 0;
  }
  std::map<int, I128> coefficient;  // exponent of eps -> coefficient
  std::array<int, 4> sigma{0, 1, 2, 3};
  do {
    int sgn = 1;
    for (int i = 0; i < 4; ++i) {
      for (int j = i + 1; j < 4; ++j) sgn *= sigma[i] > sigma[j] ? -1 : 1;
    }
    // Each row contributes either its entry or (when not in the ones column) eps^...
    for (int subset = 0; subset < 16; ++subset) {
      I128 value = sgn;
      int exponent = 0;
      bool valid = true;
      for (int i = 0; i < 4 && valid; ++i) {
        const int c = sigma[i];
        if ((subset >> i) & 1) {
          if (c == 3)
            valid = false;
          else
            exponent += 1 << (3 * rank[i] + 2 - c);
        } else {
          value *= c == 3 ? 1 : static_cast<I128>(p[i][c]);
        }
      }
      if (valid) coefficient[exponent] += value;
    }
  } while (std::next_permutation(sigma.begin(), sigma.end()));
  for (const auto& [exponent, value] : coefficient) {
    if (value != 0) return value > 0 ? -1 : 1;  // orient3d = -det[[p, 1]]
  }
  return 0;
}

std::array<SymbolicKey, 4> randomKeys(std::mt19937_64& rng) {
  std::array<SymbolicKey, 4> k;
  for (;;) {
    for (auto& key : k) key = SymbolicKey{rng() % 2, rng() % 6};
    bool distinct = true;
    for (int i = 0; i < 4; ++i) {
      for (int j = i + 1; j < 4; ++j) distinct = distinct && k[i] != k[j];
    }
    if (distinct) return k;
  }
}

TEST(Orient3dSoS, MatchesLeibnizExpansionOnDegenerateLatticePoints) {
  std::mt19937_64 rng(11);
  int degenerate = 0;
  for (int n = 0; n < 40000; ++n) {
    std::array<Vec3d, 4> p;
    const int range = n % 2 == 0 ? 1 : 3;
    for (auto& q : p) {
      for (int c = 0; c < 3; ++c)
        q[c] = static_cast<double>(static_cast<int>(rng() % (2 * range + 1)) - range);
    }
    if (n % 5 == 0) p[rng() % 4] = p[rng() % 4];  // coincident points
    const auto k = randomKeys(rng);
    const int got = orient3dSoS(p[0], p[1], p[2], p[3], k[0], k[1], k[2], k[3]);
    ASSERT_NE(got, 0);
    ASSERT_EQ(got, referenceSoS(p, k)) << n;
    degenerate += orient3d(p[0], p[1], p[2], p[3]) == 0;
  }
  EXPECT_GT(degenerate, 10000);
}

TEST(Orient3dSoS, SwappingTwoArgumentsNegates) {
  std::mt19937_64 rng(12);
  for (int n = 0; n < 3000; ++n) {
    std::array<Vec3d, 4> p;
    for (auto& q : p) {
      for (int c = 0; c < 3; ++c) q[c] = static_cast<double>(rng() % 2);
    }
    const auto k = randomKeys(rng);
    const int s = orient3dSoS(p[0], p[1], p[2], p[3], k[0], k[1], k[2], k[3]);
    std::array<int, 4> perm{0, 1, 2, 3};
    do {
      int parity = 1;
      for (int i = 0; i < 4; ++i) {
        for (int j = i + 1; j < 4; ++j) parity *= perm[i] > perm[j] ? -1 : 1;
      }
      const auto& [a, b, c, d] = perm;
      ASSERT_EQ(orient3dSoS(p[a], p[b], p[c], p[d], k[a], k[b], k[c], k[d]), parity * s);
    } while (std::next_permutation(perm.begin(), perm.end()));
  }
}

// A point with the smallest key on the plane of the other three counts as displaced towards
// +z, or +y when the plane contains z, or +x when it contains y and z.
TEST(Orient3dSoS, PointOnThePlaneWithTheSmallestKeyMovesAlongZThenYThenX) {
  const SymbolicKey kd{0, 7}, ka{1, 0}, kb{1, 1}, kc{1, 2};
  const Vec3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);  // normal +z
  EXPECT_EQ(orient3dSoS(a, b, c, Vec3d(0.25, 0.5, 0), ka, kb, kc, kd), 1);
  EXPECT_EQ(orient3dSoS(b, a, c, Vec3d(0.25, 0.5, 0), kb, ka, kc, kd), -1);
  EXPECT_EQ(orient3dSoS(a, b, c, Vec3d(7, -3, 0), ka, kb, kc, kd), 1);  // outside too
  const Vec3d e(0, 0, 1);  // plane y = 0 through a, b, e: normal (b - a) x (e - a) = -y
  EXPECT_EQ(orient3dSoS(a, b, e, Vec3d(2, 0, 5), ka, kb, kc, kd), -1);
  const Vec3d f(0, 1, 0);  // plane x = 0 through a, f, e: normal (f - a) x (e - a) = +x
  EXPECT_EQ(orient3dSoS(a, f, e, Vec3d(0, 2, 5), ka, kb, kc, kd), 1);
  // Non-degenerate inputs are unaffected by the keys.
  EXPECT_EQ(orient3dSoS(a, b, c, Vec3d(0, 0, -1), ka, kb, kc, kd), -1);
}

}  // namespace
}  // namespace voxcut
