#pragma once
/// @file ModelSource.h
/// Where a model comes from: a built-in name, a primitive with its sizes, or a mesh file.

#include <string>
#include <utility>
#include <vector>

#include "voxcut/core/TriangleMesh.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// A model ready for the voxelizer: its materials' surfaces in order (metres) and the grid
/// resolution (voxels along the longest side) it is meant to be voxelized at by default.
struct Model {
  std::string name;
  std::vector<MaterialMesh> materials;
  int defaultResolution = 101;
};

/// Loads the model named by `spec`:
///   - `bunny`: the Stanford bunny compiled into the library, material "default", 101;
///   - `liver`: makeLiver(), materials "liver" and "tumor", 100;
///   - `starfish`: makeStarfish(), material "default", 180;
///   - `box:LX,LY,LZ`: makeBox of side lengths LX, LY, LZ metres, material "default", 101;
///   - `sphere:R`: makeSphere(R, 5) of radius R metres, material "default", 101;
///   - otherwise an existing mesh file, read with readMesh; model and material are named
///     after the file stem, 101.
/// Built-in names and primitives take precedence over files of the same name.
/// Throws InputError naming `spec` for bad primitive sizes (not numbers, not lengths in
/// [1e-6, 1e6] m as core/CoordinateRange.h has them, wrong count), for a spec that is neither a
/// built-in nor an existing file, and for any failure of readMesh. Thread-safe.
[[nodiscard]] Model loadModel(const std::string& spec);

/// Builds a model from named materials, one per (name, spec) pair in order, as given by the
/// command line's repeatable `--material NAME=MESH`. Each spec is loaded with loadModel and
/// must yield a single material, which is renamed `name`. The model is named by the material
/// names joined with '+', and its default resolution is the largest of its parts'.
/// Throws InputError for an empty list, an empty or repeated name, a spec with several
/// materials, and whatever loadModel throws. Thread-safe.
[[nodiscard]] Model loadMaterials(
    const std::vector<std::pair<std::string, std::string>>& nameAndMesh);

/// Throws InputError "<subject>: voxelizes to no voxels at resolution N (voxel size H m): ..."
/// when `grid` holds no voxel of any material: a model that encloses no voxel centre (an open
/// or flat surface, a sliver thinner than a voxel) cannot be simulated or cut. `subject` names
/// the model for the user, e.g. "model 'plate.obj'" or "scene.json: bodies[1] (model ...)".
/// Linear in the grid's voxels. Thread-safe.
void requireVoxels(const VoxelGrid& grid, const std::string& subject);

/// The built-in models loadModel accepts by name: {"bunny", "liver", "starfish"}. The
/// primitives `box:LX,LY,LZ` and `sphere:R` take parameters and are not listed.
[[nodiscard]] std::vector<std::string> builtinModelNames();

}  // namespace voxcut
