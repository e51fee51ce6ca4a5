#pragma once
/// @file DrawData.h
/// What the renderer draws of a world, built on the simulation's thread after a frame and
/// handed to the window's thread whole (docs/viewer.md, "Threads"): the bodies' deformed
/// surfaces coloured by material, with cut surfaces in their own colour; the tools and
/// obstacles as meshes; optionally the active links and the voxel octree's cubes as lines;
/// and the frame's figures for the panel. Plain arrays, no graphics API.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "Camera.h"
#include "voxcut/collision/Obstacle.h"
#include "voxcut/sim/World.h"

namespace voxcut::view {

/// Floats per vertex: triangles x y z, nx ny nz, r g b; lines x y z, r g b.
inline constexpr std::size_t kTriangleStride = 9;
inline constexpr std::size_t kLineStride = 6;

/// What to draw besides the surfaces.
struct DrawOptions {
  bool activeLinks = false;       ///< the links that take part in the cutting tool's collision
  bool octreeCubes = false;       ///< the voxel octree's cubes (their edges)
  std::size_t maxLinks = 300000;  ///< at most this many links drawn (every k-th beyond)
  /// Only the links and cubes in one layer of voxels through the bodies' middle, across the
  /// z axis: a section that shows the octree's inside (drawn whole, its shell hides it).
  bool slice = false;
};

/// One frame's figures, for the panel and the plots.
struct FrameFigures {
  int frame = 0;
  double time = 0.0;            ///< s
  std::vector<double> stageMs;  ///< per frameStageNames()
  double totalMs = 0.0;
  std::size_t cutLinksFrame = 0;
  std::size_t cutLinks = 0;  ///< over all bodies, so far
  int pieces = 0;            ///< over all bodies
  std::size_t contacts = 0;
  std::size_t activeLinks = 0;  ///< over all bodies
  bool octree = true;
  std::vector<Vec3d> toolForces;  ///< per tool (N)
};

/// A frame made drawable.
struct DrawData {
  /// Unique to each DrawData buildDrawData made in this process (0: none); a copy keeps it. A
  /// renderer uploads the arrays again only when it changes.
  std::uint64_t stamp = 0;
  /// The bodies' surfaces, indexed: kTriangleStride floats per vertex (two per surface vertex
  /// slot: in its material's colour and in its cut colour), 3 indices a triangle.
  std::vector<float> bodyVertices;
  std::vector<std::uint32_t> bodyIndices;
  std::vector<float> triangles;    ///< tools and obstacles: kTriangleStride floats, 3 a triangle
  std::vector<float> lines;        ///< kLineStride floats per vertex, 2 vertices a line
  std::size_t linkSegments = 0;    ///< active links among the lines
  std::size_t cubeCount = 0;       ///< octree cubes among the lines
  Eigen::AlignedBox3d bodyBounds;  ///< of the bodies' surfaces
  FrameFigures figures;
  /// FPS (1000 / frame ms) over simulated time, the latest frames, oldest first.
  std::vector<float> fpsTime, fps;
};

/// The colour of material m (1-based; cycles through a palette) and of a cut through it.
[[nodiscard]] Eigen::Vector3f materialColour(int material);
[[nodiscard]] Eigen::Vector3f cutColour(int material);
/// Background colour of the renderer (what a screenshot's empty pixels hold).
[[nodiscard]] Eigen::Vector3f backgroundColour();

/// Builds what to draw of `world` now; `obstacles` are the world's (for their shapes). Reads
/// the surfaces in place; O(surface + tools + obstacles), plus O(voxels) for the options.
[[nodiscard]] DrawData buildDrawData(World& world, const std::vector<Obstacle>& obstacles,
                                     const DrawOptions& options);

/// The nearest point where `ray` meets a body's surface in `data`, if it does.
[[nodiscard]] std::optional<Vec3d> pick(const DrawData& data, const Ray& ray);

}  // namespace voxcut::view
