#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "voxcut/voxel/BuiltinModels.h"

namespace voxcut {
namespace {

// ------------------------------------------------------------------ mesh checks used below

/// Every undirected edge is used by exactly two faces, once in each direction; faces have three
/// distinct, valid indices; and V - E + F = 2 (one closed genus-0 surface).
::testing::AssertionResult isClosedOrientedSphere(const TriangleMesh& m) {
  const int nv = static_cast<int>(m.vertices.size());
  std::map<std::pair<int, int>, int> directed;
  for (const auto& f : m.faces) {
    for (int k = 0; k < 3; ++k) {
      if (f[k] < 0 || f[k] >= nv) return ::testing::AssertionFailure() << "index out of range";
      if (f[k] == f[(k + 1) % 3]) return ::testing::AssertionFailure() << "repeated index";
      ++directed[{f[k], f[(k + 1) % 3]}];
    }
  }
  for (const auto& [edge, count] : directed) {
    if (count != 1)
      return ::testing::AssertionFailure() << "edge " << edge.first << "-" << edge.second
                                           << " used " << count << " times in one direction";
    if (!directed.contains({edge.second, edge.first}))
      return ::testing::AssertionFailure() << "edge " << edge.first << "-" << edge.second
                                           << " has no twin (boundary or flipped face)";
  }
  const auto edges = static_cast<long>(directed.size() / 2);
  const long euler = nv - edges + static_cast<long>(m.faces.size());
  if (euler != 2) return ::testing::AssertionFailure() << "V - E + F = " << euler;
  return ::testing::AssertionSuccess();
}

Vec3d faceNormal(const TriangleMesh& m, const std::array<int, 3>& f) {
  return (m.vertices[f[1]] - m.vertices[f[0]]).cross(m.vertices[f[2]] - m.vertices[f[0]]);
}

/// Smallest face area relative to the squared bounding-box diagonal.
double minRelativeArea(const TriangleMesh& m) {
  const auto [lo, hi] = m.bounds();
  double smallest = std::numeric_limits<double>::infinity();
  for (const auto& f : m.faces) smallest = std::min(smallest, 0.5 * faceNormal(m, f).norm());
  return smallest / (hi - lo).squaredNorm();
}

/// Largest angle (radians) between the normals of two faces sharing an edge.
double maxDihedralTurn(const TriangleMesh& m) {
  std::map<std::pair<int, int>, Vec3d> normalOfEdge;
  for (const auto& f : m.faces)
    for (int k = 0; k < 3; ++k)
      normalOfEdge[{f[k], f[(k + 1) % 3]}] = faceNormal(m, f).normalized();
  double worst = 0.0;
  for (const auto& [e, n] : normalOfEdge) {
    const auto twin = normalOfEdge.find({e.second, e.first});
    if (twin != normalOfEdge.end())
      worst = std::max(worst, std::acos(std::clamp(n.dot(twin->second), -1.0, 1.0)));
  }
  return worst;
}

/// Uniform grid of face ids over a mesh's bounds, for local queries.
class FaceGrid {
 public:
  FaceGrid(const TriangleMesh& m, int res) : res_(res) {
    const auto [lo, hi] = m.bounds();
    lo_ = lo;
    cell_ = (hi - lo) / res;
    cells_.resize(static_cast<std::size_t>(res * res * res));
    for (int i = 0; i < static_cast<int>(m.faces.size()); ++i) {
      const auto& f = m.faces[i];
      const Vec3d a = m.vertices[f[0]], b = m.vertices[f[1]], c = m.vertices[f[2]];
      forEachCell(a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c),
                  [&](std::vector<int>& cell) { cell.push_back(i); });
    }
  }

  /// Ids of the faces in the cells that the box [lo, hi] touches, sorted and unique.
  std::vector<int> near(const Vec3d& lo, const Vec3d& hi) {
    std::vector<int> out;
    forEachCell(lo, hi,
                [&](std::vector<int>& cell) { out.insert(out.end(), cell.begin(), cell.end()); });
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

 private:
  template <class Fn>
  void forEachCell(const Vec3d& lo, const Vec3d& hi, Fn&& fn) {
    const auto index = [&](const Vec3d& p, int a) {
      const int i = static_cast<int>(std::floor((p[a] - lo_[a]) / cell_[a]));
      return std::clamp(i, 0, res_ - 1);
    };
    for (int z = index(lo, 2); z <= index(hi, 2); ++z)
      for (int y = index(lo, 1); y <= index(hi, 1); ++y)
        for (int x = index(lo, 0); x <= index(hi, 0); ++x) fn(cells_[x + res_ * (y + res_ * z)]);
  }

  int res_;
  Vec3d lo_, cell_;
  std::vector<std::vector<int>> cells_;
};

double orient(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  return (b - a).cross(c - a).dot(d - a);
}

/// Whether segment pq properly crosses the interior of triangle abc.
bool segmentCrossesTriangle(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b,
                            const Vec3d& c) {
  if (orient(a, b, c, p) * orient(a, b, c, q) >= 0.0) return false;
  const double e0 = orient(p, q, a, b), e1 = orient(p, q, b, c), e2 = orient(p, q, c, a);
  return (e0 > 0 && e1 > 0 && e2 > 0) || (e0 < 0 && e1 < 0 && e2 < 0);
}

/// Number of (edge, face) pairs with no common vertex where the edge crosses the face: zero
/// for a surface without self-intersections (two triangles that intersect transversally always
/// have an edge of one crossing the other).
int countSelfIntersections(const TriangleMesh& m) {
  FaceGrid grid(m, 48);
  int crossings = 0;
  for (const auto& f : m.faces)
    for (int k = 0; k < 3; ++k) {
      const int i = f[k], j = f[(k + 1) % 3];
      if (i > j) continue;  // each undirected edge once
      const Vec3d& p = m.vertices[i];
      const Vec3d& q = m.vertices[j];
      for (int g : grid.near(p.cwiseMin(q), p.cwiseMax(q))) {
        const auto& t = m.faces[g];
        if (std::find(t.begin(), t.end(), i) != t.end() ||
            std::find(t.begin(), t.end(), j) != t.end())
          continue;
        if (segmentCrossesTriangle(p, q, m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]))
          ++crossings;
      }
    }
  return crossings;
}

/// Inside test by ray parity: counts the faces that the ray from p towards +x crosses, using
/// a grid of the faces' bounds projected onto the yz plane. (A ray through an edge or vertex
/// has probability zero for the generic points tested here.)
class RayParity {
 public:
  RayParity(const TriangleMesh& m, int res) : mesh_(m), res_(res), cells_(res * res) {
    const auto [lo, hi] = m.bounds();
    lo_ = lo.tail<2>();
    cell_ = (hi - lo).tail<2>() / res;
    for (int i = 0; i < static_cast<int>(m.faces.size()); ++i) {
      Eigen::Vector2d flo = Eigen::Vector2d::Constant(1e300), fhi = -flo;
      for (int v : m.faces[i]) {
        flo = flo.cwiseMin(m.vertices[v].tail<2>());
        fhi = fhi.cwiseMax(m.vertices[v].tail<2>());
      }
      for (int z = index(flo, 1); z <= index(fhi, 1); ++z)
        for (int y = index(flo, 0); y <= index(fhi, 0); ++y) cells_[y + res_ * z].push_back(i);
    }
  }

  [[nodiscard]] bool isInside(const Vec3d& p) const {
    const Eigen::Vector2d q = p.tail<2>();
    int crossings = 0;
    for (int i : cells_[index(q, 0) + res_ * index(q, 1)]) {
      const auto& f = mesh_.faces[i];
      const Vec3d &a = mesh_.vertices[f[0]], &b = mesh_.vertices[f[1]], &c = mesh_.vertices[f[2]];
      // Barycentric coordinates of q in the face projected onto yz.
      const Eigen::Vector2d ab = (b - a).tail<2>(), ac = (c - a).tail<2>(), aq = q - a.tail<2>();
      const double det = ab.x() * ac.y() - ab.y() * ac.x();
      if (det == 0.0) continue;
      const double u = (aq.x() * ac.y() - aq.y() * ac.x()) / det;
      const double v = (ab.x() * aq.y() - ab.y() * aq.x()) / det;
      if (u <= 0.0 || v <= 0.0 || u + v >= 1.0) continue;
      if (a.x() + u * (b.x() - a.x()) + v * (c.x() - a.x()) > p.x()) ++crossings;
    }
    return crossings % 2 == 1;
  }

 private:
  int index(const Eigen::Vector2d& q, int a) const {
    return std::clamp(static_cast<int>(std::floor((q[a] - lo_[a]) / cell_[a])), 0, res_ - 1);
  }

  const TriangleMesh& mesh_;
  int res_;
  Eigen::Vector2d lo_, cell_;
  std::vector<std::vector<int>> cells_;
};

/// Closest point to p on triangle abc (Ericson, Real-Time Collision Detection, 5.1.5).
Vec3d closestPointOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Vec3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

/// The checks every built-in surface must pass.
void expectValidSurface(const TriangleMesh& m) {
  EXPECT_TRUE(isClosedOrientedSphere(m));
  EXPECT_GT(m.signedVolume(), 0.0);
  EXPECT_GT(minRelativeArea(m), 1e-9);
  EXPECT_EQ(countSelfIntersections(m), 0);
}

Vec3d extent(const TriangleMesh& m) {
  const auto [lo, hi] = m.bounds();
  return hi - lo;
}

// ------------------------------------------------------------------ box and sphere

TEST(BuiltinModels, BoxIsExact) {
  const Vec3d size(0.3, 0.2, 0.1);
  const TriangleMesh box = makeBox(size);
  EXPECT_EQ(box.vertices.size(), 8u);
  EXPECT_EQ(box.faces.size(), 12u);
  expectValidSurface(box);
  EXPECT_NEAR(box.signedVolume(), 0.3 * 0.2 * 0.1, 1e-15);
  const auto [lo, hi] = box.bounds();
  EXPECT_EQ(lo, -0.5 * size);
  EXPECT_EQ(hi, 0.5 * size);
}

TEST(BuiltinModels, SphereCountsAndRadius) {
  for (int s = 0; s <= 4; ++s) {
    const TriangleMesh sphere = makeSphere(0.05, s);
    const std::size_t four = std::size_t{1} << (2 * s);
    EXPECT_EQ(sphere.faces.size(), 20 * four);
    EXPECT_EQ(sphere.vertices.size(), 10 * four + 2);
    EXPECT_TRUE(isClosedOrientedSphere(sphere)) << "subdivisions " << s;
    for (const auto& v : sphere.vertices) EXPECT_NEAR(v.norm(), 0.05, 1e-15);
  }
}

TEST(BuiltinModels, SphereVolumeAndSmoothness) {
  const double r = 0.07;
  const TriangleMesh sphere = makeSphere(r);
  expectValidSurface(sphere);
  const double exact = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  EXPECT_NEAR(sphere.signedVolume() / exact, 1.0, 0.005);
  EXPECT_LT(sphere.signedVolume(), exact);   // inscribed polyhedron
  EXPECT_LT(maxDihedralTurn(sphere), 0.05);  // measured 0.025
}

// ------------------------------------------------------------------ liver

TEST(BuiltinModels, LiverMaterialsAndProportions) {
  const std::vector<MaterialMesh> liver = makeLiver();
  ASSERT_EQ(liver.size(), 2u);
  EXPECT_EQ(liver[0].name, "liver");
  EXPECT_EQ(liver[1].name, "tumor");
  const Vec3d e = extent(liver[0].mesh);
  EXPECT_NEAR(e.x(), 0.20, 0.02);
  EXPECT_NEAR(e.y() / e.x(), 0.62, 0.62 * 0.08);
  EXPECT_NEAR(e.z() / e.x(), 0.88, 0.88 * 0.08);
  EXPECT_GE(liver[0].mesh.faces.size(), 2000u);
  EXPECT_LE(liver[0].mesh.faces.size(), 25000u);
}

TEST(BuiltinModels, LiverAndTumorAreValidSmoothSurfaces) {
  const std::vector<MaterialMesh> liver = makeLiver();
  for (const auto& material : liver) {
    SCOPED_TRACE(material.name);
    expectValidSurface(material.mesh);
    EXPECT_LT(maxDihedralTurn(material.mesh), 0.35);  // measured 0.22 (liver), 0.08 (tumor)
  }
}

TEST(BuiltinModels, LiverHasThickRightLobeAndThinLeftLobe) {
  const std::vector<MaterialMesh> model = makeLiver();
  const TriangleMesh& m = model[0].mesh;
  // Extents in y (depth) and z (height) of the parts beyond x = -+0.04 m.
  Vec3d loR = Vec3d::Constant(1), hiR = Vec3d::Constant(-1), loL = loR, hiL = hiR;
  for (const auto& v : m.vertices) {
    if (v.x() < -0.04) loR = loR.cwiseMin(v), hiR = hiR.cwiseMax(v);
    if (v.x() > 0.04) loL = loL.cwiseMin(v), hiL = hiL.cwiseMax(v);
  }
  EXPECT_GT(hiR.y() - loR.y(), 1.3 * (hiL.y() - loL.y()));
  EXPECT_GT(hiR.z() - loR.z(), 1.3 * (hiL.z() - loL.z()));
}

TEST(BuiltinModels, TumorIsInsideLiverWithMargin) {
  const std::vector<MaterialMesh> model = makeLiver();
  const TriangleMesh& liver = model[0].mesh;
  const TriangleMesh& tumor = model[1].mesh;

  const auto [lo, hi] = liver.bounds();
  const auto [tlo, thi] = tumor.bounds();
  EXPECT_TRUE((tlo.array() > lo.array()).all() && (thi.array() < hi.array()).all());

  // Size: a blob of radius ~0.018 m, off-centre towards the thick right lobe (-x).
  Vec3d centre = Vec3d::Zero();
  for (const auto& v : tumor.vertices) centre += v;
  centre /= static_cast<double>(tumor.vertices.size());
  for (const auto& v : tumor.vertices) {
    EXPECT_GT((v - centre).norm(), 0.015);
    EXPECT_LT((v - centre).norm(), 0.021);
  }
  EXPECT_LT(centre.x(), -0.02);

  // Every tumor vertex inside the liver, at least 0.01 m from its surface.
  constexpr double margin = 0.01;
  const RayParity parity(liver, 64);
  FaceGrid grid(liver, 32);
  double nearest = std::numeric_limits<double>::infinity();
  for (const auto& p : tumor.vertices) {
    ASSERT_TRUE(parity.isInside(p)) << p.transpose();
    for (int g : grid.near((p.array() - margin).matrix(), (p.array() + margin).matrix())) {
      const auto& f = liver.faces[g];
      const Vec3d c = closestPointOnTriangle(p, liver.vertices[f[0]], liver.vertices[f[1]],
                                             liver.vertices[f[2]]);
      nearest = std::min(nearest, (c - p).norm());
    }
  }
  EXPECT_GE(nearest, margin);
}

TEST(BuiltinModels, LiverIsDeterministic) {
  const auto a = makeLiver(), b = makeLiver();
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].mesh.faces, b[i].mesh.faces);
    EXPECT_TRUE(a[i].mesh.vertices == b[i].mesh.vertices);
  }
}

// ------------------------------------------------------------------ starfish

TEST(BuiltinModels, StarfishMaterialAndProportions) {
  const std::vector<MaterialMesh> star = makeStarfish();
  ASSERT_EQ(star.size(), 1u);
  EXPECT_EQ(star[0].name, "default");
  const Vec3d e = extent(star[0].mesh);
  EXPECT_NEAR(e.x(), 0.20, 0.02);
  EXPECT_NEAR(e.y() / e.x(), 166.0 / 180.0, 166.0 / 180.0 * 0.08);
  EXPECT_NEAR(e.z() / e.x(), 30.0 / 180.0, 30.0 / 180.0 * 0.08);
  EXPECT_GE(star[0].mesh.faces.size(), 2000u);
  EXPECT_LE(star[0].mesh.faces.size(), 25000u);
}

TEST(BuiltinModels, StarfishIsValidSmoothSurface) {
  const std::vector<MaterialMesh> model = makeStarfish();
  const TriangleMesh& m = model[0].mesh;
  expectValidSurface(m);
  EXPECT_LT(maxDihedralTurn(m), 0.6);  // measured 0.43, at the thin arm rims
}

TEST(BuiltinModels, StarfishHasFiveArmsAndIsThickestAtCentre) {
  const std::vector<MaterialMesh> model = makeStarfish();
  const TriangleMesh& m = model[0].mesh;
  const auto [lo, hi] = m.bounds();
  const Vec3d mid = 0.5 * (lo + hi);
  // Outline: the largest planar radius per 2-degree sector; arms are its sharp local maxima.
  constexpr int bins = 180;
  std::vector<double> outline(bins, 0.0);
  for (const auto& v : m.vertices) {
    const Vec3d d = v - mid;
    const double angle = std::atan2(d.y(), d.x()) + std::numbers::pi;
    const int b = std::min(bins - 1, static_cast<int>(angle / (2.0 * std::numbers::pi) * bins));
    outline[b] = std::max(outline[b], d.head<2>().norm());
  }
  const double longest = *std::max_element(outline.begin(), outline.end());
  int arms = 0;
  for (int i = 0; i < bins; ++i) {
    bool peak = outline[i] > 0.8 * longest;
    for (int k = 1; k <= 10 && peak; ++k)
      peak = outline[i] >= outline[(i + k) % bins] && outline[i] > outline[(i - k + bins) % bins];
    arms += peak ? 1 : 0;
  }
  EXPECT_EQ(arms, 5);
  // Both the highest and the lowest point lie near the centre.
  const auto top = std::max_element(m.vertices.begin(), m.vertices.end(),
                                    [](const Vec3d& a, const Vec3d& b) { return a.z() < b.z(); });
  const auto bottom =
      std::min_element(m.vertices.begin(), m.vertices.end(),
                       [](const Vec3d& a, const Vec3d& b) { return a.z() < b.z(); });
  EXPECT_LT((*top - mid).head<2>().norm(), 0.02);
  EXPECT_LT((*bottom - mid).head<2>().norm(), 0.02);
}

}  // namespace
}  // namespace voxcut
