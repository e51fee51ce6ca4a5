#include "voxcut/sim/WorldChecks.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/CoordinateRange.h"
#include "voxcut/core/Error.h"
#include "voxcut/sim/Scene.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

namespace {

[[noreturn]] void fail(const std::string& argument, const std::string& rule) {
  throw InputError(argument + ": " + rule);
}

std::string shown(double x) {
  std::ostringstream s;
  s.precision(17);
  s << x;
  return s.str();
}

void checkFinite(double x, double lo, double hi, const std::string& argument,
                 const std::string& range) {
  if (!(x >= lo && x <= hi)) fail(argument, "must be in " + range + ", got " + shown(x));
}

void checkLevel(int level, int lo, int hi, const std::string& argument) {
  if (level < lo || level > hi)
    fail(argument, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                       std::to_string(level));
}

void checkPoint(const Vec3d& p, const std::string& argument) {
  if (!isCoordinate(p))
    fail(argument, std::string("coordinates must be finite and within ") + kCoordinateRangeText);
}

}  // namespace

void checkWorldSettings(const WorldSettings& s) {
  if (!(s.timeStep > 0.0 && s.timeStep <= kMaxTimeStep))
    fail("settings.timeStep", "must be in (0, 1e3] s, got " + shown(s.timeStep));
  if (!(s.gravity.array().abs() <= kMaxGravity).all())
    fail("settings.gravity", "components must be finite and within [-1e4, 1e4] m/s^2");
  if (!(s.solver.tolerance > 0.0 && s.solver.tolerance <= 1.0))
    fail("settings.solver.tolerance", "must be in (0, 1], got " + shown(s.solver.tolerance));
  if (s.solver.maxIterations < 1)
    fail("settings.solver.maxIterations", "must be >= 1, got " +
                                              std::to_string(s.solver.maxIterations));
  checkLevel(s.solver.projectionHistory, 0, kMaxProjectionHistory,
             "settings.solver.projectionHistory");
  checkFinite(s.contact.stiffness, 0.0, kMaxContactStiffness, "settings.contact.stiffness",
              "[0, 1e12] N/m");
  checkFriction(s.contact.friction, "settings.contact.friction", false);
  if (s.bladeSegments < 0)
    fail("settings.bladeSegments", "must be >= 0, got " + std::to_string(s.bladeSegments));
}

void checkMaterial(const SceneMaterial& m, const std::string& argument) {
  if (!(m.youngModulus > 0.0 && m.youngModulus <= kMaxYoungModulus))
    fail(argument + ".youngModulus", "must be in (0, 1e12] Pa, got " + shown(m.youngModulus));
  checkFinite(m.poissonRatio, 0.0, std::nextafter(0.5, 0.0), argument + ".poissonRatio",
              "[0, 0.5)");
  if (!(m.density > 0.0 && m.density <= kMaxDensity))
    fail(argument + ".density", "must be in (0, 1e5] kg/m^3, got " + shown(m.density));
  checkFinite(m.massDamping, 0.0, kMaxDamping, argument + ".massDamping", "[0, 1e6] 1/s");
  checkFinite(m.stiffnessDamping, 0.0, kMaxDamping, argument + ".stiffnessDamping",
              "[0, 1e6] s");
  checkLevel(m.maxInternalLevel, 0, kMaxOctreeLevel, argument + ".maxInternalLevel");
  checkLevel(m.maxBoundaryLevel, 0, kMaxOctreeLevel, argument + ".maxBoundaryLevel");
}

void checkFixedBoxes(const std::vector<FixedBox>& boxes, const std::string& argument) {
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const std::string at = argument + "[" + std::to_string(i) + "]";
    checkPoint(boxes[i].lo, at + ".lo");
    checkPoint(boxes[i].hi, at + ".hi");
    if (!(boxes[i].lo.array() <= boxes[i].hi.array()).all())
      fail(at, "lo must be <= hi on every axis");
  }
}

void checkBodySettings(const BodySettings& s) {
  checkLevel(s.elementLevel, 0, kMaxElementLevel, "settings.elementLevel");
  checkLevel(s.finestLevel, -1, s.elementLevel, "settings.finestLevel");
  checkLevel(s.frontLevel, -1, s.elementLevel, "settings.frontLevel");
  // The finest level refinement reaches: as set, or its default two below the element level.
  const int finest = s.finestLevel >= 0 ? s.finestLevel : std::max(s.elementLevel - 2, 0);
  if (s.frontLevel >= 0 && s.frontLevel < finest)
    fail("settings.frontLevel", "must be >= the finest level (" + std::to_string(finest) +
                                    "), got " + std::to_string(s.frontLevel));
  checkLevel(s.surfaceLevel, -1, s.elementLevel, "settings.surfaceLevel");
  for (std::size_t i = 0; i < s.materials.size(); ++i)
    checkMaterial(s.materials[i], "settings.materials[" + std::to_string(i) + "]");
  checkFixedBoxes(s.fixed, "settings.fixed");
}

void checkPose(const BladePose& pose, const std::string& argument) {
  checkPoint(pose.a, argument + ".a");
  checkPoint(pose.b, argument + ".b");
}

void checkRadius(double radius, const std::string& argument) {
  if (!(radius > 0.0 && radius <= kMaxProbeRadius))
    fail(argument, "must be in (0, 1e3] m, got " + shown(radius));
}

void checkBladePose(const BladePose& pose, const std::string& argument) {
  checkPose(pose, argument);
  if (pose.a == pose.b) fail(argument, "a blade's ends a and b must differ");
}

void checkFriction(double friction, const std::string& argument, bool defaultAllowed) {
  if (defaultAllowed && friction < 0.0 && std::isfinite(friction)) return;
  checkFinite(friction, 0.0, kMaxFriction, argument,
              defaultAllowed ? "[0, 100] (or negative for the default)" : "[0, 100]");
}

void checkKeys(const std::vector<ToolKey>& keys, const std::string& argument) {
  if (keys.empty()) fail(argument, "needs at least one key");
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const std::string at = argument + "[" + std::to_string(i) + "]";
    checkFinite(keys[i].t, -kMaxKeyTime, kMaxKeyTime, at + ".t", "[-1e9, 1e9] s");
    checkPose(keys[i].pose, at + ".pose");
  }
  if (!keysInOrder(keys))
    fail(argument,
         "key times must increase (a jump key may share the time of the key before it)");
}

void checkObstacle(const Obstacle& o, const std::string& argument) {
  checkFriction(o.friction, argument + ".friction", true);
  switch (o.type) {
    case ObstacleType::Plane:
      checkPoint(o.point, argument + ".point");
      if (!o.normal.allFinite() || std::abs(o.normal.norm() - 1.0) > 1e-6)
        fail(argument + ".normal", "must be a unit vector");
      break;
    case ObstacleType::Box:
      checkPoint(o.lo, argument + ".lo");
      checkPoint(o.hi, argument + ".hi");
      if (!(o.lo.array() < o.hi.array()).all()) fail(argument, "lo must be < hi on every axis");
      break;
    case ObstacleType::Mesh:
      if (o.mesh == nullptr) fail(argument + ".mesh", "a mesh obstacle needs its mesh");
      break;
  }
}

void checkGrid(const VoxelGrid& grid, const std::string& argument) {
  if (!(grid.voxelSize() > 0.0) || !std::isfinite(grid.voxelSize()) || !grid.origin().allFinite())
    throw InputError(argument + ": needs a finite origin and a positive voxel size");
  for (std::size_t v = 0; v < grid.voxelCount(); ++v)
    if (grid.occupied(v)) return;
  throw InputError(argument + ": no occupied voxel (an empty body)");
}

}  // namespace voxcut
