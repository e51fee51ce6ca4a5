#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "voxcut/core/Error.h"
#include "voxcut/surface/DualContour.h"
#include "voxcut/surface/SurfaceMesh.h"
#include "voxcut/voxel/LabelResample.h"
#include "voxcut/voxel/Pieces.h"

namespace voxcut {
namespace {

constexpr double kPi = std::numbers::pi;

// A volume of dims n^3 (or `dims`) with axes `axes` and origin `origin`, voxel (i,j,k) labelled
// by `label(world point of its centre)`.
template <class LabelFn>
LabelVolume makeVolume(const Index3& dims, const Eigen::Matrix3d& axes, const Vec3d& origin,
                       LabelFn&& label) {
  LabelVolume v;
  v.dims = dims;
  v.axes = axes;
  v.origin = origin;
  std::vector<std::int32_t> raw(v.voxelCount());
  for (int k = 0; k < dims.z; ++k)
    for (int j = 0; j < dims.y; ++j)
      for (int i = 0; i < dims.x; ++i) raw[v.linear(i, j, k)] = label(v.world(Vec3d(i, j, k)));
  setLabelsFromSamples(v, raw.data(), raw.size(), SampleType::Int32, false, "test volume");
  return v;
}

double surfaceArea(const SurfaceMesh& s) {
  double area = 0;
  for (const auto& t : s.triangles)
    area +=
        0.5 *
        (s.positions[t[1]] - s.positions[t[0]]).cross(s.positions[t[2]] - s.positions[t[0]]).norm();
  return area;
}

std::size_t countMaterial(const VoxelGrid& g, int m) {
  std::size_t n = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v) n += g.material(v) == m;
  return n;
}

Vec3d materialCentroid(const VoxelGrid& g, int m) {
  Vec3d sum = Vec3d::Zero();
  std::size_t n = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    if (g.material(v) == m) {
      sum += g.position(v);
      ++n;
    }
  return sum / static_cast<double>(n);
}

// A sphere of radius 20 mm labelled in a 1 mm volume (56^3 voxels, voxel centres at
// half-millimetres), resampled at 1 mm; returns its contoured surface's worst distance from
// the sphere (in voxels) and checks closedness, area and volume.
double sphereError(const Vec3d& centre) {
  const double r = 0.020, h = 0.001;
  const LabelVolume vol =
      makeVolume({56, 56, 56}, Eigen::Matrix3d::Identity() * h, Vec3d(-0.0275, -0.0275, -0.0275),
                 [&](const Vec3d& p) { return (p - centre).norm() <= r ? 7 : 0; });
  LabelResampleParams params;
  params.resolution.voxelSize = h;
  const VoxelGrid grid = resampleLabels(vol, params);
  EXPECT_EQ(grid.materialNames(), std::vector<std::string>{"label_7"});
  const SurfaceMesh s = dualContour(grid);
  EXPECT_FALSE(s.triangles.empty());
  EXPECT_TRUE(surfaceTopology(s).closed);
  // A staircase of voxel faces would be about 50 % over.
  EXPECT_NEAR(surfaceArea(s) / (4 * kPi * r * r), 1.0, 0.03);
  const double volume = static_cast<double>(countMaterial(grid, 1)) * h * h * h;
  EXPECT_NEAR(volume / (4.0 / 3.0 * kPi * r * r * r), 1.0, 0.02);
  double worst = 0;
  for (const Vec3d& p : s.positions) worst = std::max(worst, std::abs((p - centre).norm() - r));
  return worst / h;
}

// The known answer: the sphere contours within a quarter voxel of itself wherever its centre
// lies against the voxels: on a voxel corner, on a voxel centre (where the labels leave a
// terrace of one voxel at each pole) and in general position.
TEST(LabelResample, SphereContoursWithinAQuarterVoxelAnywhere) {
  for (const Vec3d& c :
       {Vec3d(0, 0, 0), Vec3d(0.0005, 0.0005, 0.0005), Vec3d(0.0013, -0.0021, 0.0007),
        Vec3d(0.0003, 0.0001, 0.00045), Vec3d(0.00013, 0.00037, 0.00071),
        Vec3d(0.00025, 0.00025, 0.00025), Vec3d(0.0005, 0.0, 0.00031)})
    EXPECT_LT(sphereError(c), 0.25) << c.transpose();
}

// Worst distance (in voxels) of the contoured surface of a shape labelled in a 1 mm volume
// (64^3, resampled at 1 mm) from the shape, given its signed distance `sdf` in millimetres,
// over the vertices `counted` keeps.
template <class Sdf, class Keep>
double shapeError(Sdf&& sdf, Keep&& counted) {
  const double h = 0.001;
  const LabelVolume vol =
      makeVolume({64, 64, 64}, Eigen::Matrix3d::Identity() * h, Vec3d::Constant(-0.0315),
                 [&](const Vec3d& p) { return sdf(p * 1e3) <= 0 ? 4 : 0; });
  LabelResampleParams params;
  params.resolution.voxelSize = h;
  const SurfaceMesh s = dualContour(resampleLabels(vol, params));
  EXPECT_TRUE(surfaceTopology(s).closed);
  double worst = 0;
  for (const Vec3d& p : s.positions)
    if (counted(p * 1e3)) worst = std::max(worst, std::abs(sdf(p * 1e3)));
  return worst;
}

// Other smooth shapes gain as the sphere does, in any orientation: a torus whose tube (6 mm)
// is tighter than the largest fitting window, and the flat faces of a rotated box, away from
// its edges (which any smoothing rounds).
TEST(LabelResample, TorusAndBoxFacesContourClose) {
  const Eigen::Matrix3d rot =
      Eigen::AngleAxisd(0.7, Vec3d(0.3, -1, 0.5).normalized()).toRotationMatrix();
  const Vec3d off(0.37, -0.21, 0.44);
  const double torus = shapeError(
      [&](const Vec3d& p) {
        const Vec3d q = rot.transpose() * (p - off);
        return std::hypot(std::hypot(q.x(), q.y()) - 15.0, q.z()) - 6.0;
      },
      [](const Vec3d&) { return true; });
  EXPECT_LT(torus, 0.35);
  const Vec3d half(18, 13, 9);
  const auto local = [&](const Vec3d& p) {
    return Vec3d((rot.transpose() * (p - off)).cwiseAbs() - half);
  };
  const double box = shapeError(
      [&](const Vec3d& p) {
        const Vec3d q = local(p);
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
      },
      [&](const Vec3d& p) {
        Vec3d q = local(p);
        std::sort(q.data(), q.data() + 3);
        return q[1] < -3.0;  // 3 mm or more from every edge
      });
  EXPECT_LT(box, 0.25);
}

// A rotated, anisotropic volume of the same sphere lands at the same place with the same
// volume, on a grid axis-aligned in world space.
TEST(LabelResample, RotatedAnisotropicVolumeLandsInPlace) {
  const double r = 0.015;
  const Vec3d centre(0.010, 0.020, -0.005);
  const Eigen::Matrix3d rot =
      (Eigen::AngleAxisd(0.5, Vec3d(1, 2, 3).normalized())).toRotationMatrix();
  const Eigen::Matrix3d axes = rot * Vec3d(0.0008, 0.0011, 0.0015).asDiagonal();
  const Index3 dims{50, 40, 30};
  // Place the volume's centre on the sphere's centre.
  const Vec3d origin = centre - axes * Vec3d(24.5, 19.5, 14.5);
  const LabelVolume vol = makeVolume(
      dims, axes, origin, [&](const Vec3d& p) { return (p - centre).norm() <= r ? 3 : 0; });
  LabelResampleParams params;
  params.resolution.voxelSize = 0.001;
  const VoxelGrid grid = resampleLabels(vol, params);
  EXPECT_LT((materialCentroid(grid, 1) - centre).norm(), 0.5 * 0.001);
  const double volume = static_cast<double>(countMaterial(grid, 1)) * 1e-9;
  EXPECT_NEAR(volume / (4.0 / 3.0 * kPi * r * r * r), 1.0, 0.02);
  const SurfaceMesh s = dualContour(grid);
  EXPECT_TRUE(surfaceTopology(s).closed);
  double worst = 0;
  for (const Vec3d& p : s.positions) worst = std::max(worst, std::abs((p - centre).norm() - r));
  EXPECT_LT(worst, 0.5e-3);
}

// Two labels: a lesion inside an organ stays connected to it through interface links that
// carry Hermite data; the organ-lesion boundary is an interface, not a surface.
TEST(LabelResample, TwoLabelsMeetAtAnInterface) {
  const double h = 0.001;
  const Vec3d c(0, 0, 0), lesion(0.008, 0, 0);
  const LabelVolume vol = makeVolume({40, 40, 40}, Eigen::Matrix3d::Identity() * h,
                                     Vec3d::Constant(-0.0195), [&](const Vec3d& p) {
                                       if ((p - lesion).norm() <= 0.006) return 85;
                                       return (p - c).norm() <= 0.015 ? 255 : 0;
                                     });
  LabelResampleParams params;
  params.resolution.voxelSize = h;
  params.labels = {{255, "liver"}, {85, "tumor"}};
  const VoxelGrid grid = resampleLabels(vol, params);
  EXPECT_EQ(grid.materialNames(), (std::vector<std::string>{"liver", "tumor"}));
  EXPECT_GT(countMaterial(grid, 2), 0u);
  EXPECT_EQ(findPieces(grid).count, 1);
  std::size_t interfaces = 0;
  for (std::size_t v = 0; v < grid.voxelCount(); ++v)
    for (int a = 0; a < 3; ++a) {
      if (!grid.hasLink(v, a)) continue;
      const std::size_t w = v + grid.stride(a);
      if (grid.material(v) && grid.material(w) && grid.material(v) != grid.material(w)) {
        EXPECT_TRUE(grid.connected(v, a));
        EXPECT_NE(grid.hermite().find(VoxelGrid::linkId(v, a)), nullptr);
        ++interfaces;
      }
    }
  EXPECT_GT(interfaces, 100u);
}

// Only the chosen labels become materials; others are background.
TEST(LabelResample, UnchosenLabelsAreBackground) {
  const LabelVolume vol = makeVolume({30, 30, 30}, Eigen::Matrix3d::Identity() * 0.001,
                                     Vec3d::Zero(), [](const Vec3d& p) {
                                       if (p.x() < 0.010) return 0;
                                       return p.x() < 0.020 ? 1 : 2;
                                     });
  LabelResampleParams params;
  params.resolution.voxelSize = 0.001;
  params.labels = {{2, "b"}};
  const VoxelGrid grid = resampleLabels(vol, params);
  EXPECT_EQ(grid.materialNames().size(), 1u);
  // Label 2 spans x in [20, 29] mm: its bounding box (plus padding) is the grid.
  EXPECT_NEAR(grid.origin().x(), 0.019, 0.0011);
}

TEST(LabelResample, ChoicesAreChecked) {
  const LabelVolume vol =
      makeVolume({10, 10, 10}, Eigen::Matrix3d::Identity() * 0.001, Vec3d::Zero(),
                 [](const Vec3d& p) { return p.x() < 0.005 ? 4 : 9; });
  auto refuses = [&](std::vector<LabelChoice> c, const std::string& part) {
    try {
      checkLabelChoices(vol, c, "v.nii");
      ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  refuses({{5, "x"}}, "label 5 is not in the volume (its labels: 4, 9)");
  refuses({{4, "x"}, {4, "y"}}, "label 4 is chosen twice");
  refuses({{4, "x"}, {9, "x"}}, "labels 4 and 9 have the same name 'x'");
  refuses({{4, ""}}, "empty name");
  EXPECT_NO_THROW(checkLabelChoices(vol, {{4, "a"}, {9, "b"}}, "v.nii"));
}

// A piece smaller than the island threshold is dropped with a warning; with the threshold at
// 0 it stays.
TEST(LabelResample, SmallIslandsAreDropped) {
  const LabelVolume vol = makeVolume({30, 30, 30}, Eigen::Matrix3d::Identity() * 0.001,
                                     Vec3d::Zero(), [](const Vec3d& p) {
                                       if ((p - Vec3d(0.010, 0.010, 0.010)).norm() < 0.006)
                                         return 1;
                                       // A 2 x 2 x 2 speck far away.
                                       if (p.x() >= 0.0235 && p.x() < 0.0245 && p.y() >= 0.0235 &&
                                           p.y() < 0.0255 && p.z() >= 0.0235 && p.z() < 0.0255)
                                         return 1;
                                       return 0;
                                     });
  LabelResampleParams params;
  params.resolution.voxelSize = 0.001;
  params.kernelRadius = 1.0;  // keep the speck through the smoothing
  LabelResampleReport rep;
  const VoxelGrid dropped = resampleLabels(vol, params, &rep);
  EXPECT_EQ(rep.islandsDropped, 1u);
  EXPECT_EQ(rep.warnings.size(), 1u);
  EXPECT_EQ(findPieces(dropped).count, 1);
  params.minIsland = 0;
  const VoxelGrid kept = resampleLabels(vol, params, &rep);
  EXPECT_EQ(rep.islandsDropped, 0u);
  EXPECT_EQ(findPieces(kept).count, 2);
}

TEST(LabelResample, SameResultAtAnyThreadCount) {
  const LabelVolume vol = makeVolume({40, 36, 30}, Eigen::Matrix3d::Identity() * 0.001,
                                     Vec3d::Zero(), [](const Vec3d& p) {
                                       const double d = (p - Vec3d(0.02, 0.018, 0.015)).norm();
                                       return d < 0.008 ? 2 : (d < 0.013 ? 1 : 0);
                                     });
  LabelResampleParams params;
  params.resolution.resolution = 37;
  const VoxelGrid a = resampleLabels(vol, params);
  params.threaded = false;
  const VoxelGrid b = resampleLabels(vol, params);
  ASSERT_EQ(a.voxelCount(), b.voxelCount());
  for (std::size_t v = 0; v < a.voxelCount(); ++v) {
    ASSERT_EQ(a.material(v), b.material(v));
    for (int ax = 0; ax < 3; ++ax) ASSERT_EQ(a.connected(v, ax), b.connected(v, ax));
  }
  EXPECT_EQ(a.hermite().sortedLinks(), b.hermite().sortedLinks());
}

}  // namespace
}  // namespace voxcut
