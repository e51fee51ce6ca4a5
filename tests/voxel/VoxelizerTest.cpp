#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "voxcut/core/Parallel.h"
#include "voxcut/voxel/BuiltinModels.h"
#include "voxcut/voxel/Pieces.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

constexpr double kPi = std::numbers::pi;

std::size_t countMaterial(const VoxelGrid& g, int m) {
  std::size_t n = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) n += g.material(v) == m;
  return n;
}

VoxelGrid voxelizeOne(const TriangleMesh& mesh, int resolution, VoxelizeReport* rep = nullptr) {
  VoxelizeParams p;
  p.resolution.resolution = resolution;
  return voxelize({{"m", mesh}}, p, rep);
}

double voxelVolume(const VoxelGrid& g) {
  return std::pow(g.voxelSize(), 3);
}

// Every link obeys the model's rules: same material connected, material/empty disconnected
// with Hermite data, two materials connected with Hermite data, empty/empty disconnected.
void expectLinkInvariants(const VoxelGrid& g) {
  const Index3 d = g.dims();
  for (std::size_t v = 0; v < g.voxelCount(); ++v) {
    const Index3 c = g.coord(v);
    for (int a = 0; a < 3; ++a) {
      if (c[a] + 1 >= d[a]) {
        ASSERT_FALSE(g.connected(v, a));
        continue;
      }
      const int m0 = g.material(v), m1 = g.material(v + g.stride(a));
      const Hermite* h = g.hermite().find(VoxelGrid::linkId(v, a));
      if (m0 == 0 && m1 == 0) {
        ASSERT_FALSE(g.connected(v, a));
        ASSERT_EQ(h, nullptr);
      } else if (m0 == 0 || m1 == 0) {
        ASSERT_FALSE(g.connected(v, a));
        ASSERT_NE(h, nullptr);
      } else {
        ASSERT_TRUE(g.connected(v, a));
        ASSERT_EQ(h != nullptr, m0 != m1);
      }
      if (h) {
        ASSERT_GT(h->t, 0.f);
        ASSERT_LT(h->t, 1.f);
        ASSERT_NEAR(std::sqrt(h->n[0] * h->n[0] + h->n[1] * h->n[1] + h->n[2] * h->n[2]), 1.0,
                    1e-5);
        ASSERT_GE(h->n[a], 0.f);
      }
    }
  }
}

TEST(GridFrame, ResolutionCountsPaddingAndCentresTheModel) {
  const GridFrame f =
      gridFrameFor({Vec3d(0, 0, 0), Vec3d(1.0, 0.5, 0.25)}, {.resolution = 12}, 1u << 20);
  EXPECT_EQ(f.dims.x, 12);
  EXPECT_DOUBLE_EQ(f.voxelSize, 0.1);
  EXPECT_EQ(f.dims.y, 7);
  EXPECT_EQ(f.dims.z, 5);
  for (int a = 0; a < 3; ++a) {
    const double lo = f.origin[a], hi = f.origin[a] + (f.dims[a] - 1) * f.voxelSize;
    EXPECT_LT(lo, 0.0);
    EXPECT_NEAR(lo + hi, a == 0 ? 1.0 : (a == 1 ? 0.5 : 0.25), 1e-12);
  }
}

TEST(GridFrame, RejectsAbsurdResolutions) {
  const std::array<Vec3d, 2> b{Vec3d(0, 0, 0), Vec3d(1, 1, 1)};
  EXPECT_THROW((void)gridFrameFor(b, {.resolution = 0}, 1u << 20), InputError);
  EXPECT_THROW((void)gridFrameFor(b, {.resolution = 2}, 1u << 20), InputError);
  EXPECT_THROW((void)gridFrameFor(b, {.resolution = 1000000}, 1u << 30), InputError);
  EXPECT_THROW((void)gridFrameFor(b, {.resolution = 101, .voxelSize = -1.0}, 1u << 30), InputError);
  EXPECT_THROW((void)gridFrameFor(b, {.resolution = 101, .voxelSize = 1e-9}, 1u << 30), InputError);
  EXPECT_THROW((void)gridFrameFor({Vec3d(0, 0, 0), Vec3d(0, 0, 0)}, {}, 1u << 30), InputError);
}

TEST(Voxelizer, BoxAlignedWithTheGridIsExact) {
  // 0.1 x 0.06 x 0.04 at 50 voxels along x: voxel centres sit half a voxel from every face.
  const VoxelGrid g = voxelizeOne(makeBox(Vec3d(0.1, 0.06, 0.04)), 52);
  EXPECT_EQ(g.dims().x, 52);
  EXPECT_EQ(countMaterial(g, 1), 50u * 30u * 20u);
  expectLinkInvariants(g);
  // Crossings lie on the faces: t = 0.5 on every surface link.
  g.hermite().forEach([](std::uint64_t, const Hermite& h) { EXPECT_NEAR(h.t, 0.5f, 1e-5f); });
}

TEST(Voxelizer, SphereVolumeAndHermiteDataMatchTheSurface) {
  const double r = 0.05;
  const VoxelGrid g = voxelizeOne(makeSphere(r, 5), 64);
  const double expected = 4.0 / 3.0 * kPi * r * r * r / voxelVolume(g);
  EXPECT_NEAR(static_cast<double>(countMaterial(g, 1)) / expected, 1.0, 0.02);
  expectLinkInvariants(g);
  g.hermite().forEach([&](std::uint64_t id, const Hermite& h) {
    const std::size_t v = id / 3;
    const int a = static_cast<int>(id % 3);
    Vec3d p = g.position(v);
    p[a] += h.t * g.voxelSize();
    EXPECT_NEAR(p.norm(), r, 1e-3 * g.voxelSize() + 4e-4 * r);  // chord error of the icosphere
    const Vec3d n(h.n[0], h.n[1], h.n[2]);
    EXPECT_GT(std::abs(n.dot(p.normalized())), 0.99);
  });
}

TEST(Voxelizer, WatertightMeshUsesExactCrossingCount) {
  VoxelizeReport rep;
  (void)voxelizeOne(makeSphere(0.05, 3), 30, &rep);
  ASSERT_EQ(rep.usedWindingNumber.size(), 1u);
  EXPECT_FALSE(rep.usedWindingNumber[0]);
  EXPECT_TRUE(rep.repairs[0].watertight);
}

TEST(Voxelizer, ImperfectMeshGivesTheExpectedVoxels) {
  // Holes, flipped faces and duplicate faces on one sphere.
  const double r = 0.05;
  const TriangleMesh clean = makeSphere(r, 4);
  TriangleMesh broken;
  broken.vertices = clean.vertices;
  int removed = 0;
  for (std::size_t f = 0; f < clean.faces.size(); ++f) {
    auto t = clean.faces[f];
    const Vec3d c = (clean.vertices[t[0]] + clean.vertices[t[1]] + clean.vertices[t[2]]) / 3.0;
    // Two holes, away from the six extreme points so that the grid frame stays the same.
    if (c.normalized().dot(Vec3d(1, 1, 1).normalized()) > 0.97 ||
        c.normalized().dot(Vec3d(-1, 1, -1).normalized()) > 0.98) {
      ++removed;
      continue;
    }
    if (f % 7 == 3) std::swap(t[1], t[2]);  // flipped
    broken.faces.push_back(t);
    if (f % 11 == 5) broken.faces.push_back(t);                   // duplicate
    if (f % 13 == 6) broken.faces.push_back({t[0], t[2], t[1]});  // duplicate, reversed
  }
  ASSERT_GT(removed, 10);
  VoxelizeReport rep;
  const VoxelGrid g = voxelizeOne(broken, 64, &rep);
  EXPECT_TRUE(rep.usedWindingNumber[0]);
  EXPECT_GT(rep.repairs[0].duplicateFaces, 0);
  EXPECT_GT(rep.repairs[0].flippedFaces, 0);
  EXPECT_GT(rep.repairs[0].boundaryEdges, 0);
  const double expected = 4.0 / 3.0 * kPi * r * r * r / voxelVolume(g);
  EXPECT_NEAR(static_cast<double>(countMaterial(g, 1)) / expected, 1.0, 0.02);
  EXPECT_EQ(findPieces(g).count, 1);
  expectLinkInvariants(g);

  // And the same grid as the intact sphere, up to the voxels right under the holes.
  const VoxelGrid ref = voxelizeOne(clean, 64);
  ASSERT_EQ(ref.dims(), g.dims());
  ASSERT_EQ(ref.origin(), g.origin());
  std::size_t differ = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) differ += g.material(v) != ref.material(v);
  EXPECT_LT(static_cast<double>(differ), 0.01 * static_cast<double>(countMaterial(ref, 1)));
}

TEST(Voxelizer, DisjointShellsAndCavities) {
  const double r = 0.03;
  TriangleMesh two = makeSphere(r, 3);
  const TriangleMesh other = makeSphere(r, 3);
  const int off = static_cast<int>(two.vertices.size());
  for (const auto& v : other.vertices) two.vertices.push_back(v + Vec3d(0.1, 0, 0));
  for (const auto& f : other.faces) two.faces.push_back({f[0] + off, f[1] + off, f[2] + off});
  const VoxelGrid g = voxelizeOne(two, 80);
  const PieceLabels pieces = findPieces(g);
  EXPECT_EQ(pieces.count, 2);
  EXPECT_NEAR(static_cast<double>(pieces.voxels[0]) / static_cast<double>(pieces.voxels[1]), 1.0,
              0.02);

  // A hollow ball: the inner shell is inverted, so its inside stays empty.
  TriangleMesh hollow = makeSphere(0.05, 4);
  const TriangleMesh inner = makeSphere(0.03, 4);
  const int o2 = static_cast<int>(hollow.vertices.size());
  for (const auto& v : inner.vertices) hollow.vertices.push_back(v);
  for (const auto& f : inner.faces) hollow.faces.push_back({f[0] + o2, f[2] + o2, f[1] + o2});
  const VoxelGrid h = voxelizeOne(hollow, 64);
  const double shell = 4.0 / 3.0 * kPi * (std::pow(0.05, 3) - std::pow(0.03, 3)) / voxelVolume(h);
  EXPECT_NEAR(static_cast<double>(countMaterial(h, 1)) / shell, 1.0, 0.03);
  EXPECT_FALSE(h.occupied(h.index(h.dims().x / 2, h.dims().y / 2, h.dims().z / 2)));
}

TEST(Voxelizer, LaterMaterialsWinInsideThemselves) {
  const double R = 0.05, r = 0.02;
  VoxelizeParams p;
  p.resolution.resolution = 64;
  const VoxelGrid g = voxelize({{"outer", makeSphere(R, 4)}, {"inner", makeSphere(r, 4)}}, p);
  ASSERT_EQ(g.materialNames().size(), 2u);
  const double vv = voxelVolume(g);
  EXPECT_NEAR(static_cast<double>(countMaterial(g, 2)) / (4.0 / 3.0 * kPi * r * r * r / vv), 1.0,
              0.04);
  EXPECT_NEAR(static_cast<double>(countMaterial(g, 1) + countMaterial(g, 2)) /
                  (4.0 / 3.0 * kPi * R * R * R / vv),
              1.0, 0.02);
  expectLinkInvariants(g);
  // The interface carries Hermite data on the inner sphere.
  std::size_t interface = 0;
  g.hermite().forEach([&](std::uint64_t id, const Hermite& h) {
    const std::size_t v = id / 3;
    const int a = static_cast<int>(id % 3);
    if (g.material(v) == 0 || g.material(v + g.stride(a)) == 0) return;
    ++interface;
    Vec3d q = g.position(v);
    q[a] += h.t * g.voxelSize();
    EXPECT_NEAR(q.norm(), r, 1e-3 * g.voxelSize() + 2e-3 * r);  // chord error, 4 subdivisions
  });
  EXPECT_GT(interface, 100u);
  EXPECT_EQ(findPieces(g).count, 1);
}

TEST(Voxelizer, ResultDoesNotDependOnThreadCount) {
  std::vector<MaterialMesh> mats{{"a", makeSphere(0.05, 4)},
                                 {"b", makeBox(Vec3d(0.03, 0.05, 0.02))}};
  VoxelizeParams p;
  p.resolution.resolution = 70;
  VoxelGrid g1, g2;
  {
    ThreadLimit one(1);
    g1 = voxelize(mats, p);
  }
  {
    ThreadLimit two(2);
    g2 = voxelize(mats, p);
  }
  ASSERT_EQ(g1.voxelCount(), g2.voxelCount());
  for (std::size_t v = 0; v < g1.voxelCount(); ++v) {
    ASSERT_EQ(g1.material(v), g2.material(v));
    for (int a = 0; a < 3; ++a) ASSERT_EQ(g1.connected(v, a), g2.connected(v, a));
  }
  const auto links = g1.hermite().sortedLinks();
  ASSERT_EQ(links, g2.hermite().sortedLinks());
  for (std::uint64_t id : links) {
    const Hermite *a = g1.hermite().find(id), *b = g2.hermite().find(id);
    ASSERT_EQ(a->t, b->t);
    for (int i = 0; i < 3; ++i) ASSERT_EQ(a->n[i], b->n[i]);
  }
}

TEST(Voxelizer, CompactStorage) {
  const VoxelGrid g = voxelizeOne(makeSphere(0.05, 4), 101);
  EXPECT_LT(static_cast<double>(g.bytes()) / static_cast<double>(g.voxelCount()), 16.0);
}

TEST(Voxelizer, BadInputIsAnInputError) {
  VoxelizeParams p;
  EXPECT_THROW((void)voxelize({}, p), InputError);
  EXPECT_THROW((void)voxelize({{"empty", TriangleMesh{}}}, p), InputError);
  TriangleMesh nan = makeBox(Vec3d(1, 1, 1));
  nan.vertices[3].x() = std::nan("");
  EXPECT_THROW((void)voxelize({{"nan", nan}}, p), InputError);
  TriangleMesh bad = makeBox(Vec3d(1, 1, 1));
  bad.faces[0][1] = 1000;
  EXPECT_THROW((void)voxelize({{"bad", bad}}, p), InputError);
  TriangleMesh degenerate;
  degenerate.vertices = {Vec3d(0, 0, 0), Vec3d(1, 0, 0)};
  degenerate.faces = {{0, 1, 1}};
  EXPECT_THROW((void)voxelize({{"degenerate", degenerate}}, p), InputError);
  p.resolution.resolution = 100000;
  EXPECT_THROW((void)voxelize({{"box", makeBox(Vec3d(1, 1, 1))}}, p), InputError);
}

TEST(Voxelizer, ProgressCanInterrupt) {
  VoxelizeParams p;
  p.resolution.resolution = 40;
  int calls = 0;
  p.progress = [&](std::string_view, double f) {
    ++calls;
    EXPECT_GE(f, 0.0);
    EXPECT_LE(f, 1.0);
    return true;
  };
  (void)voxelize({{"s", makeSphere(0.05, 3)}}, p);
  EXPECT_GE(calls, 3);
  p.progress = [](std::string_view, double) { return false; };
  EXPECT_THROW((void)voxelize({{"s", makeSphere(0.05, 3)}}, p), Interrupted);
}

}  // namespace
}  // namespace voxcut
