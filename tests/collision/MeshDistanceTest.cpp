#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "voxcut/collision/MeshDistance.h"
#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/voxel/BuiltinModels.h"
#include "voxcut/voxel/WindingNumber.h"

namespace voxcut {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TriangleMesh translated(TriangleMesh mesh, const Vec3d& by) {
  for (Vec3d& v : mesh.vertices) v += by;
  return mesh;
}

// The box [lo, hi] as a mesh.
TriangleMesh boxMesh(const Vec3d& lo, const Vec3d& hi) {
  return translated(makeBox(hi - lo), 0.5 * (lo + hi));
}

Obstacle boxObstacle(const Vec3d& lo, const Vec3d& hi) {
  Obstacle o;
  o.type = ObstacleType::Box;
  o.lo = lo;
  o.hi = hi;
  return o;
}

std::vector<Vec3d> randomPoints(int n, const Vec3d& lo, const Vec3d& hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3d> out;
  for (int k = 0; k < n; ++k)
    out.push_back(lo + Vec3d(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo));
  return out;
}

// An icosphere of radius 1 (5,120 faces, inscribed: its facets lie up to about 1e-3 inside): inside
// and outside, the distance and normal of the sphere itself.
TEST(MeshDistance, IcosphereAgreesWithTheSphere) {
  const MeshDistance sphere(makeSphere(1.0, 4));
  ASSERT_EQ(sphere.triangleCount(), 5120u);
  int inside = 0;
  for (const Vec3d& x : randomPoints(2000, Vec3d::Constant(-1.8), Vec3d::Constant(1.8), 1)) {
    const double r = x.norm();
    if (std::abs(r - 1.0) < 0.05) continue;  // near the surface the facets decide the normal
    Vec3d n;
    const double d = sphere.signedDistance(x, n);
    EXPECT_NEAR(d, r - 1.0, 2e-3) << x.transpose();
    EXPECT_NEAR(n.norm(), 1.0, 1e-12);
    EXPECT_GT(n.dot(x / r), 0.995) << x.transpose();
    inside += d < 0.0;
  }
  EXPECT_GT(inside, 100);
}

// A box mesh gives what the Box obstacle gives, through the Obstacle interface.
TEST(MeshDistance, BoxMeshMatchesTheBoxObstacle) {
  const Vec3d lo(-0.2, -0.05, -0.1), hi(0.3, 0.0, 0.15);
  const Obstacle box = boxObstacle(lo, hi);
  const Obstacle mesh = meshObstacle(boxMesh(lo, hi));
  ASSERT_EQ(mesh.type, ObstacleType::Mesh);
  ASSERT_EQ(mesh.mesh->triangleCount(), 12u);
  for (const Vec3d& x :
       randomPoints(3000, lo - Vec3d::Constant(0.2), hi + Vec3d::Constant(0.2), 2)) {
    Vec3d nBox, nMesh;
    const double dBox = signedDistance(box, x, nBox);
    const double dMesh = signedDistance(mesh, x, nMesh);
    EXPECT_NEAR(dMesh, dBox, 1e-14) << x.transpose();
    EXPECT_TRUE(nMesh.isApprox(nBox, 1e-9))
        << x.transpose() << " | " << nMesh.transpose() << " vs " << nBox.transpose();
  }
  // On a face: distance 0, the face's outward normal.
  Vec3d n;
  EXPECT_NEAR(signedDistance(mesh, Vec3d(0.0, 0.0, 0.0), n), 0.0, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3d::UnitY()));
}

// Below the bound the answer is exact; at or beyond it, at least the bound.
TEST(MeshDistance, BoundedQueriesAreExactBelowTheBound) {
  const MeshDistance sphere(translated(makeSphere(0.5, 3), Vec3d(0.1, 0.0, -0.2)));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> bound(0.0, 0.6);
  for (const Vec3d& x : randomPoints(2000, Vec3d::Constant(-1.5), Vec3d::Constant(1.5), 4)) {
    Vec3d n, nb;
    const double exact = sphere.signedDistance(x, n);
    const double maxDistance = bound(rng);
    const double bounded = sphere.signedDistance(x, nb, maxDistance);
    EXPECT_NEAR(nb.norm(), 1.0, 1e-12);
    if (exact < maxDistance) {
      EXPECT_NEAR(bounded, exact, 1e-15) << x.transpose();
      EXPECT_TRUE(nb.isApprox(n, 1e-12)) << x.transpose();
    } else {
      EXPECT_GE(bounded, maxDistance) << x.transpose();
    }
  }
  // Deep inside with a bound: still the exact (negative) distance.
  Vec3d n;
  EXPECT_NEAR(sphere.signedDistance(Vec3d(0.1, 0.0, -0.2), n, 0.01), -0.5, 1e-2);
}

// Degenerate faces (a repeated corner, collinear corners, a point) change nothing, and a mesh
// of nothing else has no surface at all: no NaN either way.
TEST(MeshDistance, DegenerateTrianglesAreHarmless) {
  const Vec3d lo(0, 0, 0), hi(1, 0.5, 2);
  TriangleMesh mesh = boxMesh(lo, hi);
  const int base = static_cast<int>(mesh.vertices.size());
  mesh.vertices.push_back(Vec3d(0.5, 0.25, 1.0));  // inside
  mesh.vertices.push_back(Vec3d(0.5, 0.6, 1.0));   // outside
  mesh.vertices.push_back(Vec3d(0.5, 0.7, 1.0));   // collinear with the two above
  mesh.faces.push_back({base, base, base + 1});
  mesh.faces.push_back({base, base + 1, base + 2});
  mesh.faces.push_back({base + 2, base + 2, base + 2});
  mesh.faces.push_back({0, 0, 1});
  const MeshDistance clean(boxMesh(lo, hi)), dirty(mesh);
  EXPECT_EQ(dirty.triangleCount(), 12u);
  for (const Vec3d& x : randomPoints(500, Vec3d::Constant(-0.5), Vec3d(1.5, 1.0, 2.5), 5)) {
    Vec3d n0, n1;
    const double d = dirty.signedDistance(x, n1);
    ASSERT_TRUE(std::isfinite(d) && n1.allFinite());
    EXPECT_EQ(d, clean.signedDistance(x, n0));
    EXPECT_EQ(n1, n0);
  }

  TriangleMesh flat;
  flat.vertices = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(2, 0, 0)};
  flat.faces = {{0, 1, 2}, {0, 0, 0}, {1, 2, 1}};
  const MeshDistance none(flat);
  EXPECT_EQ(none.triangleCount(), 0u);
  Vec3d n;
  EXPECT_EQ(none.signedDistance(Vec3d(0.5, 0.1, 0), n), kInf);
  EXPECT_TRUE(n.allFinite());
  EXPECT_EQ(none.signedDistance(Vec3d(0.5, 0.1, 0), n, 0.3), kInf);
}

// A box with its top removed: the winding number still tells inside from outside below the
// opening, and the distances are those to the remaining five faces.
TEST(MeshDistance, OpenBoxKeepsItsSignThroughTheWindingNumber) {
  const Vec3d lo(0, 0, 0), hi(1, 1, 1);
  TriangleMesh open = boxMesh(lo, hi);
  std::vector<std::array<int, 3>> faces;
  for (const auto& f : open.faces)
    if (!(open.vertices[f[0]].y() == 1.0 && open.vertices[f[1]].y() == 1.0 &&
          open.vertices[f[2]].y() == 1.0))
      faces.push_back(f);
  ASSERT_EQ(faces.size(), 10u);
  open.faces = faces;
  const MeshDistance d(open);
  const Obstacle closed = boxObstacle(lo, hi);
  for (const Vec3d& x : randomPoints(1000, Vec3d(-0.3, -0.3, -0.3), Vec3d(1.3, 1.3, 1.3), 6)) {
    Vec3d n, nBox;
    const double dBox = signedDistance(closed, x, nBox);
    if (x.y() > 0.6 && dBox < 0.0) continue;  // inside near the opening: either may hold
    const double dOpen = d.signedDistance(x, n);
    EXPECT_EQ(dOpen < 0.0, dBox < 0.0) << x.transpose();
    // The nearest point is never on the missing face.
    const Vec3d c = d.closestPoint(x);
    EXPECT_NEAR(std::abs(dOpen), (x - c).norm(), 1e-15);
    EXPECT_TRUE(c.y() < 1.0 || c.x() == 0.0 || c.x() == 1.0 || c.z() == 0.0 || c.z() == 1.0);
  }
  // The middle of the box: inside, half a side from the walls.
  Vec3d n;
  EXPECT_DOUBLE_EQ(d.signedDistance(Vec3d(0.5, 0.5, 0.5), n), -0.5);
}

// An inverted mesh is the same obstacle: the sign takes |w|, the face normals are turned out.
TEST(MeshDistance, InvertedMeshIsTheSameObstacle) {
  TriangleMesh box = makeBox(Vec3d(1, 1, 1));
  const MeshDistance outward(box);
  for (auto& f : box.faces) std::swap(f[1], f[2]);
  const MeshDistance inward(box);
  for (const Vec3d& x : randomPoints(300, Vec3d::Constant(-1), Vec3d::Constant(1), 8)) {
    Vec3d n0, n1;
    EXPECT_EQ(inward.signedDistance(x, n1), outward.signedDistance(x, n0));
    EXPECT_TRUE(n1.isApprox(n0));
  }
  Vec3d n;
  EXPECT_NEAR(inward.signedDistance(Vec3d(0.1, 0.5, -0.2), n), 0.0, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3d::UnitY()));
}

// Where the sides of the nearest face decide (a watertight mesh), they decide as w does, also
// where two closed shells overlap (w = 2 there) and near the faces.
TEST(MeshDistance, SignsAgreeWithTheWindingNumber) {
  TriangleMesh two = boxMesh(Vec3d(0, 0, 0), Vec3d(1, 1, 1));
  const TriangleMesh other = boxMesh(Vec3d(0.5, 0.3, 0.2), Vec3d(1.5, 1.2, 0.9));
  const int base = static_cast<int>(two.vertices.size());
  two.vertices.insert(two.vertices.end(), other.vertices.begin(), other.vertices.end());
  for (const auto& f : other.faces) two.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
  std::mt19937 rng(10);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const TriangleMesh& mesh : {makeSphere(0.5, 3), two}) {
    const MeshDistance d(mesh);
    ASSERT_TRUE(d.watertight());
    const WindingNumberTree w(mesh);
    for (const Vec3d& p : randomPoints(1500, Vec3d::Constant(-0.7), Vec3d::Constant(1.7), 11)) {
      const Vec3d near = d.closestPoint(p) + 1e-3 * Vec3d(u(rng), u(rng), u(rng));
      for (const Vec3d& x : {p, near}) {
        Vec3d n;
        const double s = d.signedDistance(x, n);
        if (std::abs(s) < 1e-9) continue;
        EXPECT_EQ(s<0.0, std::abs(w(x))> 0.5) << x.transpose();
      }
    }
  }
}

// Built and queried with one thread or several, the answers are the same.
TEST(MeshDistance, SameForAnyThreadCount) {
  const TriangleMesh mesh = makeSphere(0.3, 3);
  const std::vector<Vec3d> points =
      randomPoints(4000, Vec3d::Constant(-0.5), Vec3d::Constant(0.5), 9);
  auto run = [&](int threads) {
    ThreadLimit limit(threads);
    const MeshDistance sphere(mesh);
    std::vector<double> out(points.size());
    parallelFor(0, points.size(), 16, [&](std::size_t lo, std::size_t hi) {
      for (std::size_t k = lo; k < hi; ++k) {
        Vec3d n;
        out[k] = sphere.signedDistance(points[k], n, k % 3 == 0 ? 0.05 : kInf);
      }
    });
    return out;
  };
  EXPECT_EQ(run(1), run(4));
}

}  // namespace
}  // namespace voxcut
