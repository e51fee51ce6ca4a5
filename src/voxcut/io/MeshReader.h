#pragma once
/// @file MeshReader.h
/// Reads a triangle mesh from a file or a memory buffer through assimp (OBJ, STL ascii and
/// binary, PLY ascii and binary, OFF, and every other format assimp imports).

#include <string>
#include <string_view>

#include "voxcut/core/TriangleMesh.h"

namespace voxcut {

/// Reads the mesh file at `path` (coordinates taken as metres, as written).
///
/// All meshes of the file are merged, with their node transforms applied; polygons are
/// triangulated; points and lines are dropped. Vertices with exactly equal positions are welded
/// across the whole file (so an STL triangle soup comes back indexed); nothing else is changed:
/// orientation, normals and degenerate triangles are left as in the file.
///
/// Throws InputError (one line naming `path`) when the file is missing, a directory, not a
/// regular file, unreadable or empty; when assimp cannot parse it (with assimp's reason); when
/// it holds no triangle; or when a coordinate is not finite. Thread-safe (one importer per call).
[[nodiscard]] TriangleMesh readMesh(const std::string& path);

/// Reads a mesh from the bytes `data`, as readMesh does for a file. `formatHint` is the file
/// extension without the dot ("obj", "stl", "ply", "off") that picks the parser.
/// Throws InputError as readMesh does. Thread-safe.
[[nodiscard]] TriangleMesh readMeshFromMemory(std::string_view data, const char* formatHint);

}  // namespace voxcut
