#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "OctreeChecks.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/ModelSource.h"
#include "voxcut/topology/DeformationOctree.h"
#include "voxcut/topology/PrescribedDeformation.h"
#include "voxcut/voxel/Voxelizer.h"

namespace voxcut {
namespace {

const VoxelGrid& bunnyGrid() {
  static const VoxelGrid grid = [] {
    VoxelizeParams p;
    p.resolution.resolution = 101;
    return voxelize(loadModel("bunny").materials, p);
  }();
  return grid;
}

const DeformationOctree& bunnyOctree() {
  static const DeformationOctree oc = buildDeformationOctree(bunnyGrid());
  return oc;
}

std::vector<std::size_t> occupiedVoxels(const VoxelGrid& g) {
  std::vector<std::size_t> out;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    if (g.occupied(v)) out.push_back(v);
  return out;
}

/// Smallest Jacobian determinant of the element's trilinear map over its 8 corners, divided
/// by its rest value (1 at rest; > 0 means not inverted there).
double minCornerJacobian(const DeformationOctree& oc, std::uint32_t e) {
  const auto& n = oc.element(e).nodes;
  const auto& p = oc.positions();
  const double rest = std::pow(oc.voxelSize() * oc.element(e).size(), 3);
  double lo = 1e300;
  for (int c = 0; c < 8; ++c) {
    Eigen::Matrix3d J;
    for (int a = 0; a < 3; ++a) {
      const int c0 = c & ~(1 << a), c1 = c | (1 << a);
      J.col(a) = p[n[static_cast<std::size_t>(c1)]] - p[n[static_cast<std::size_t>(c0)]];
    }
    lo = std::min(lo, J.determinant() / rest);
  }
  return lo;
}

TEST(PrescribedDeformation, Parse) {
  EXPECT_EQ(parseDeformation("rigid"), Deformation::Rigid);
  EXPECT_EQ(parseDeformation("bend"), Deformation::Bend);
  EXPECT_EQ(parseDeformation("twist"), Deformation::Twist);
  EXPECT_EQ(parseDeformation("none"), Deformation::None);
  for (const char* bad : {"", "Rigid", "bend ", "shear"}) {
    try {
      (void)parseDeformation(bad);
      ADD_FAILURE() << "no InputError for '" << bad << "'";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos);
    }
  }
  for (Deformation d :
       {Deformation::None, Deformation::Rigid, Deformation::Bend, Deformation::Twist})
    EXPECT_EQ(parseDeformation(deformationName(d)), d);
}

TEST(PrescribedDeformation, NoneAndZeroAmountKeepRest) {
  DeformationOctree oc = bunnyOctree();
  applyDeformation(oc, Deformation::None);
  EXPECT_EQ(oc.positions(), oc.restPositions());
  applyDeformation(oc, Deformation::Twist, 0.0);
  EXPECT_EQ(oc.positions(), oc.restPositions());
}

TEST(PrescribedDeformation, RigidRotatesEveryVoxelExactly) {
  const VoxelGrid& g = bunnyGrid();
  DeformationOctree oc = bunnyOctree();
  applyDeformation(oc, Deformation::Rigid);
  const double scale =
      oc.restVoxelBounds().diagonal().norm() + oc.restVoxelBounds().center().norm();
  const std::vector<std::size_t> voxels = occupiedVoxels(g);
  double moved = 0;
  for (std::size_t v : voxels) {
    const Vec3d want = deformedPoint(oc, Deformation::Rigid, 1.0, g.position(v));
    ASSERT_LE((oc.voxelPosition(v) - want).norm(), 1e-12 * scale) << "voxel " << v;
    moved = std::max(moved, (want - g.position(v)).norm());
  }
  EXPECT_GT(moved, 0.1 * oc.restVoxelBounds().diagonal().norm());  // it did rotate
  // Distances are preserved.
  std::mt19937 rng(5);
  std::uniform_int_distribution<std::size_t> pick(0, voxels.size() - 1);
  for (int i = 0; i < 2000; ++i) {
    const std::size_t a = voxels[pick(rng)], b = voxels[pick(rng)];
    const double rest = (g.position(a) - g.position(b)).norm();
    const double now = (oc.voxelPosition(a) - oc.voxelPosition(b)).norm();
    ASSERT_NEAR(now, rest, 1e-12 * scale);
  }
  // The centre of the bounding box stays put.
  const Vec3d c = oc.restVoxelBounds().center();
  EXPECT_LE((deformedPoint(oc, Deformation::Rigid, 1.0, c) - c).norm(), 1e-15 * scale);
  test::expectConforming(oc, 1e-12 * scale);
}

class SmoothDeformation : public ::testing::TestWithParam<Deformation> {};

TEST_P(SmoothDeformation, StaysNearRestBoxAndNotInverted) {
  const VoxelGrid& g = bunnyGrid();
  DeformationOctree oc = bunnyOctree();
  applyDeformation(oc, GetParam());
  const Eigen::AlignedBox3d rest = oc.restVoxelBounds();
  const Eigen::AlignedBox3d allowed(rest.center() - 0.75 * rest.sizes(),
                                    rest.center() + 0.75 * rest.sizes());
  Eigen::AlignedBox3d now;
  double moved = 0;
  for (std::size_t v : occupiedVoxels(g)) {
    const Vec3d p = oc.voxelPosition(v);
    now.extend(p);
    ASSERT_TRUE(allowed.contains(p)) << "voxel " << v;
    moved = std::max(moved, (p - g.position(v)).norm());
  }
  double worst = 1e300;
  for (std::uint32_t e = 0; e < oc.elementCount(); ++e)
    worst = std::min(worst, minCornerJacobian(oc, e));
  std::printf(
      "%s: max voxel displacement %.3f of the rest diagonal, deformed box %.3f x %.3f x "
      "%.3f of rest, min corner Jacobian / rest %.3f\n",
      std::string(deformationName(GetParam())).c_str(), moved / rest.diagonal().norm(),
      now.sizes().x() / rest.sizes().x(), now.sizes().y() / rest.sizes().y(),
      now.sizes().z() / rest.sizes().z(), worst);
  EXPECT_GT(worst, 0.0);
  EXPECT_GT(moved, 0.05 * rest.diagonal().norm());  // visibly deformed
  // Hanging nodes follow their masters: positions continuous across fine/coarse faces.
  test::expectConforming(oc, 1e-12 * (rest.diagonal().norm() + rest.center().norm()));
  // Free nodes sit exactly on the map.
  for (std::uint32_t n = 0; n < oc.nodeCount(); ++n)
    if (!oc.isHanging(n)) {
      ASSERT_EQ(oc.positions()[n], deformedPoint(oc, GetParam(), 1.0, oc.restPositions()[n]));
    }
}

TEST_P(SmoothDeformation, SmoothInAmount) {
  // Half the amount moves voxels about half as far (the maps are smooth in the amount).
  const VoxelGrid& g = bunnyGrid();
  DeformationOctree full = bunnyOctree(), half = bunnyOctree();
  applyDeformation(full, GetParam(), 1.0);
  applyDeformation(half, GetParam(), 0.5);
  double dFull = 0, dHalf = 0;
  for (std::size_t v : occupiedVoxels(g)) {
    dFull = std::max(dFull, (full.voxelPosition(v) - g.position(v)).norm());
    dHalf = std::max(dHalf, (half.voxelPosition(v) - g.position(v)).norm());
  }
  EXPECT_GT(dHalf, 0.3 * dFull);
  EXPECT_LT(dHalf, 0.7 * dFull);
}

INSTANTIATE_TEST_SUITE_P(BendAndTwist, SmoothDeformation,
                         ::testing::Values(Deformation::Bend, Deformation::Twist),
                         [](const auto& param) {
                           return std::string(deformationName(param.param));
                         });

}  // namespace
}  // namespace voxcut
