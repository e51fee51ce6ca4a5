#pragma once
/// @file WorldChecks.h
/// The argument checks of the world API (sim/World.h, "Errors"): each throws
/// voxcut::InputError naming the argument and the rule it breaks, and changes nothing, so a
/// call that fails leaves the world as it was. The bounds are those of the scene reader
/// (docs/scenes.md), so a world built in code accepts what a scene file may say.

#include <string>
#include <vector>

#include "voxcut/sim/WorldTypes.h"

namespace voxcut {

class VoxelGrid;

struct Obstacle;

/// The ranges of the physical parameters, shared with io/SceneReader.cpp: wide enough for any
/// material and setting a simulation of soft or stiff solids needs, narrow enough that products
/// in the solver stay far from overflow.
inline constexpr double kMaxTimeStep = 1e3;         ///< s
inline constexpr double kMaxKeyTime = 1e9;          ///< s, |t| of a tool key
inline constexpr double kMaxGravity = 1e4;          ///< m/s^2, per component
inline constexpr double kMaxYoungModulus = 1e12;    ///< Pa
inline constexpr double kMaxDensity = 1e5;          ///< kg/m^3
inline constexpr double kMaxDamping = 1e6;          ///< 1/s (mass), s (stiffness)
inline constexpr double kMaxFriction = 100.0;       ///< Coulomb coefficient
inline constexpr double kMaxContactStiffness = 1e12;  ///< N/m
inline constexpr int kMaxElementLevel = 6;          ///< deformation octree levels
inline constexpr int kMaxOctreeLevel = 7;           ///< voxel octree cube levels
inline constexpr int kMaxProjectionHistory = 64;
inline constexpr double kMaxProbeRadius = 1e3;      ///< m

void checkWorldSettings(const WorldSettings& s);
void checkBodySettings(const BodySettings& s);
void checkMaterial(const SceneMaterial& m, const std::string& argument);
void checkFixedBoxes(const std::vector<FixedBox>& boxes, const std::string& argument);
/// Every coordinate finite and within core/CoordinateRange.h's range.
void checkPose(const BladePose& pose, const std::string& argument);
void checkRadius(double radius, const std::string& argument);
/// checkPose's, and a != b (a blade is a segment).
void checkBladePose(const BladePose& pose, const std::string& argument);
/// A Coulomb coefficient: finite and >= 0, or negative for "the world's default" when
/// `defaultAllowed`.
void checkFriction(double friction, const std::string& argument, bool defaultAllowed);
/// At least one key, in order (keysInOrder), every time finite and every pose checkPose's.
void checkKeys(const std::vector<ToolKey>& keys, const std::string& argument);
void checkObstacle(const Obstacle& o, const std::string& argument);
/// A body's grid: at least one occupied voxel, a finite origin and a positive voxel size.
void checkGrid(const VoxelGrid& grid, const std::string& argument);

}  // namespace voxcut
