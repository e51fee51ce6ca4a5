#pragma once
/// @file ModelSource.h
/// Where a model comes from: a built-in name, a primitive with its sizes, or a mesh file.

#include <string>
#include <utility>
#include <vector>

#include "voxcut/core/TriangleMesh.h"
#include "voxcut/voxel/Model.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// Settings of loadModel for label volumes.
struct ModelLoadParams {
  /// Refuse a label volume whose header asks for more memory than this (bytes; 0: no limit).
  std::size_t maxMemory = 0;
  /// A names file for a volume's labels (`--label-names`): lines `value name [more]`, as the
  /// AAL atlas's aal.nii.txt; empty: none.
  std::string labelNames;
};

/// Loads the model named by `spec`:
///   - `bunny`: the Stanford bunny compiled into the library, material "default", 101;
///   - `liver`: makeLiver(), materials "liver" and "tumor", 100;
///   - `starfish`: makeStarfish(), material "default", 180;
///   - `box:LX,LY,LZ`: makeBox of side lengths LX, LY, LZ metres, material "default", 101;
///   - `sphere:R`: makeSphere(R, 5) of radius R metres, material "default", 101;
///   - a label volume file (VolumeReader.h: .nii, .nii.gz, .nrrd, .nhdr, .seg.nrrd, .mha,
///     .mhd), read with readLabelVolume (under params.maxMemory; names from
///     params.labelNames when given), named after the file without its extensions, all its
///     labels as materials, 101;
///   - otherwise an existing mesh file, read with readMesh; model and material are named
///     after the file stem, 101.
/// Built-in names and primitives take precedence over files of the same name.
/// Throws InputError naming `spec` for bad primitive sizes (not numbers, not lengths in
/// [1e-6, 1e6] m as core/CoordinateRange.h has them, wrong count), for a spec that is neither a
/// built-in nor an existing file, and for any failure of readMesh. Thread-safe.
[[nodiscard]] Model loadModel(const std::string& spec, const ModelLoadParams& params = {});

/// Parses a label choice `VALUE=NAME[,VALUE=NAME...]` (the command line's `--labels`), or
/// `all` (an empty list: every label). Throws InputError naming `what` for an item without
/// '=', a value that is not an integer, or an empty name.
[[nodiscard]] std::vector<LabelChoice> parseLabelList(const std::string& text,
                                                      const std::string& what);

/// Names the labels of `volume` from the names file at `path` (lines `value name [more]`;
/// blank lines and lines starting with '#' skipped). Values the volume lacks are ignored;
/// throws InputError naming the file and line for a line that does not parse.
void applyLabelNames(LabelVolume& volume, const std::string& path);

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
