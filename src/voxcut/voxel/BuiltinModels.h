#pragma once
/// @file BuiltinModels.h
/// Procedural test models: a box, an icosphere, and stand-ins for the paper's liver (with a
/// tumor) and starfish. Every mesh is closed, 2-manifold, free of self-intersections and
/// oriented outward (counter-clockwise seen from outside, positive signed volume). All
/// functions are deterministic and thread-safe (they share no state).

#include <vector>

#include "voxcut/core/TriangleMesh.h"
#include "voxcut/core/Types.h"

namespace voxcut {

/// Closed box centred at the origin with side lengths `size` (metres, each > 0): 8 vertices,
/// 12 triangles, outward.
[[nodiscard]] TriangleMesh makeBox(const Vec3d& size);

/// Closed icosphere of radius `radius` (metres, > 0) centred at the origin: an icosahedron
/// split `subdivisions` times (0..8) into four, 20*4^s faces and 10*4^s + 2 vertices, all on
/// the sphere, outward. At 5 subdivisions its volume is within 0.1% of 4/3 pi r^3.
[[nodiscard]] TriangleMesh makeSphere(double radius, int subdivisions = 5);

/// A liver-like organ with an embedded tumor, two materials in this order: {"liver", ...},
/// {"tumor", ...}. A procedural stand-in for the paper's 100x62x88-voxel model: the liver's
/// bounding box is 0.200 x 0.124 x 0.176 m centred at the origin, z up (superior), y the
/// antero-posterior depth, the thick right lobe towards -x and the thin left lobe towards +x.
/// The tumor is a smooth blob of radius about 0.018 m in the right lobe, at least 0.01 m
/// inside the liver surface. About 20k + 5k triangles.
[[nodiscard]] std::vector<MaterialMesh> makeLiver();

/// A five-armed starfish, one material {"default", ...}: a procedural stand-in for the paper's
/// 180x166x30-voxel model, bounding box 0.200 x 0.184 x 0.033 m centred at the origin, lying
/// in the xy plane (z is the thickness), one arm along +y. Arms taper towards rounded tips;
/// the body is thickest at the centre. About 20k triangles.
[[nodiscard]] std::vector<MaterialMesh> makeStarfish();

}  // namespace voxcut
