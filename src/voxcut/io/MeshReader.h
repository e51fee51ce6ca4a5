#pragma once
/// @file MeshReader.h
/// Reads a triangle mesh from a file or a memory buffer. OBJ, STL (ASCII and binary), PLY
/// (ASCII, binary little and big endian) and OFF are read in double precision by validating
/// readers of our own (MeshFormats.h); every other format goes through assimp (32-bit floats)
/// (docs/algorithms.md, "Mesh reading").

#include <string>
#include <string_view>

#include "voxcut/core/TriangleMesh.h"

namespace voxcut {

/// Reads the mesh file at `path` (coordinates taken as metres, as written). The format is
/// chosen by the extension, in any case: .obj, .stl, .ply and .off by our readers, anything
/// else by assimp.
///
/// All meshes or objects of the file are merged (with assimp, their node transforms applied);
/// polygons are fan-triangulated; points and lines are dropped. Vertices with exactly equal
/// positions are welded across the whole file (so an STL triangle soup comes back indexed),
/// and vertices no face uses are dropped; nothing else is changed: orientation and degenerate
/// triangles are left as in the file (repairMesh deals with them), normals are not read.
///
/// Throws InputError with one line naming `path` when the file is missing, a directory, not a
/// regular file, unreadable or empty; when it holds no triangle or a coordinate that is not
/// finite; for our formats, with the line (text) or byte offset (binary) and what is wrong,
/// when anything does not parse or does not match a declared count (including truncated
/// data); for other formats, when assimp cannot parse it (with assimp's reason). No input makes
/// our readers hang or allocate beyond a constant times the file size; they run in time linear
/// in it. Thread-safe (no shared state; one importer per call).
[[nodiscard]] TriangleMesh readMesh(const std::string& path);

/// Reads a mesh from the bytes `data`, as readMesh does for a file. `formatHint` is the file
/// extension without the dot ("obj", "stl", "ply", "off", or one assimp knows) that picks the
/// parser; messages name the source "in-memory mesh (<hint>)".
/// Throws InputError as readMesh does. Thread-safe.
[[nodiscard]] TriangleMesh readMeshFromMemory(std::string_view data, const char* formatHint);

}  // namespace voxcut
