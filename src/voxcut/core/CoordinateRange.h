#pragma once
/// @file CoordinateRange.h
/// The range of positions and lengths voxcut accepts from its input: every coordinate (scene
/// offsets, fixed boxes, blade ends, command-line blade poses) within [-1e6, 1e6] m, every
/// length (primitive sizes) in [1e-6, 1e6] m.
///
/// Why a range: the exact orientation predicates (core/Predicates.h) are exact only when the
/// magnitudes passed to one call lie within a factor 2^300 of each other, and coordinate
/// differences must not overflow; a blade end at 1e155 m next to voxels at 0.1 m breaks the
/// first, one at 1e308 m the second. A kilometre-sized world of millimetre voxels stays far
/// inside the range. Lengths have a lower bound too: a body micrometres across already needs
/// voxels of nanometres, and at far smaller scales its masses and volumes underflow and the
/// simulation goes silently wrong. Thread-safety: pure functions.

#include <string>

#include "voxcut/core/Types.h"

namespace voxcut {

/// The largest coordinate magnitude and length accepted from input, metres.
inline constexpr double kMaxCoordinate = 1e6;

/// "[-1e6, 1e6] m": the coordinate range as messages and documents write it.
inline constexpr const char* kCoordinateRangeText = "[-1e6, 1e6] m";

/// Whether x is finite and |x| <= kMaxCoordinate (false for NaN and infinities).
[[nodiscard]] constexpr bool isCoordinate(double x) {
  return x >= -kMaxCoordinate && x <= kMaxCoordinate;
}

/// Whether every component of p is a coordinate (isCoordinate).
[[nodiscard]] inline bool isCoordinate(const Vec3d& p) {
  return isCoordinate(p.x()) && isCoordinate(p.y()) && isCoordinate(p.z());
}

/// The largest coordinate magnitude the geometric kernels accept (they assert it): twice the
/// input range, so that points derived from input, such as blade poses interpolated between
/// keys (rounding) or cut fronts carried with a deforming body, stay inside.
inline constexpr double kMaxKernelCoordinate = 2.0 * kMaxCoordinate;

/// Whether every component of p is finite and at most kMaxKernelCoordinate in magnitude.
[[nodiscard]] inline bool isKernelCoordinate(const Vec3d& p) {
  return (p.array().abs() <= kMaxKernelCoordinate).all();
}

/// The smallest length accepted from input, metres.
inline constexpr double kMinLength = 1e-6;

/// "[1e-6, 1e6] m": the length range as messages and documents write it.
inline constexpr const char* kLengthRangeText = "[1e-6, 1e6] m";

/// Whether x is a length voxcut accepts: kMinLength <= x <= kMaxCoordinate (false for NaN).
[[nodiscard]] constexpr bool isLength(double x) {
  return x >= kMinLength && x <= kMaxCoordinate;
}

/// Throws InputError "<context>: must be in [-1e6, 1e6] m, got <x>" unless isCoordinate(x);
/// x is written in its shortest round-trip form. For the input boundary (readers, command
/// line); inside the library a coordinate out of range is a programming error.
void requireCoordinate(double x, const std::string& context);

}  // namespace voxcut
