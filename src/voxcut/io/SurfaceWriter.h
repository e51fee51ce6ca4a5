#pragma once
/// @file SurfaceWriter.h
/// Writes a contoured surface to a mesh file (OBJ or binary PLY), never half-written.

#include <cstdint>
#include <string>
#include <vector>

#include "voxcut/surface/SurfaceMesh.h"

namespace voxcut {

/// Writes `mesh` to `path`, in the format its extension names (case-insensitive):
///   - `.obj`: text; per vertex `v x y z` and `vn nx ny nz` (shortest decimals that read back
///     to the same doubles), per triangle `f a//a b//b c//c` (1-based);
///   - `.ply`: `binary_little_endian 1.0`; per vertex float x, y, z, nx, ny, nz; per triangle
///     a uchar 3 and three int indices.
/// Vertex i of the file is mesh.positions[i] and triangles keep their order and winding, so
/// per-vertex data (mesh.vertexVoxel) still matches the file. When mesh.normals is empty the
/// normals are left out; otherwise it must hold one normal per position (checked assertion),
/// as every triangle index must be a valid vertex.
///
/// The file is written as `path + ".tmp"` in the same directory and renamed over `path` when
/// complete; on any failure the temporary is removed and `path` is left as it was.
/// Throws InputError (one line naming `path`) for an unknown extension, a missing directory,
/// a `path` that is a directory, and any failure to create, write or rename the file.
/// Thread-safe for distinct paths.
///
/// With `materialNames` (the names of materials 1..N) and one tag per triangle
/// (mesh.triangleTags), the materials are kept: OBJ triangles come grouped by material
/// (`g NAME` before each group, each group's triangles in the mesh's order); PLY faces get a
/// `uchar material` property and the header a `comment material K NAME` line per material.
void writeSurface(const SurfaceMesh& mesh, const std::string& path,
                  const std::vector<std::string>& materialNames = {});

/// The triangles of `mesh` that show `material` (by mesh.triangleTags, which must hold one tag
/// per triangle), with the vertices they use, in order. O(V + T).
[[nodiscard]] SurfaceMesh materialPart(const SurfaceMesh& mesh, std::uint8_t material);

/// Checks, before any work, what writeSurface checks about `path` without writing anything:
/// a known extension, an existing directory this process may create files in, and `path`
/// not a directory. Throws InputError as writeSurface would.
void checkSurfacePath(const std::string& path);

}  // namespace voxcut
