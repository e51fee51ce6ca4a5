#pragma once
/// @file Types.h
/// Small shared types: vectors (Eigen), grid indices.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>

namespace voxcut {

using Vec3d = Eigen::Vector3d;
using Vec3f = Eigen::Vector3f;
using Vec3i = Eigen::Vector3i;

/// Integer index triple of a voxel or a dual cell.
struct Index3 {
  int x = 0, y = 0, z = 0;
  int& operator[](int a) { return a == 0 ? x : (a == 1 ? y : z); }
  int operator[](int a) const { return a == 0 ? x : (a == 1 ? y : z); }
  friend bool operator==(const Index3&, const Index3&) = default;
};

}  // namespace voxcut
