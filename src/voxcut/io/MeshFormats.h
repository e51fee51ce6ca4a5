#pragma once
/// @file MeshFormats.h
/// The validating readers of the mesh formats users have: OBJ, STL (ASCII and binary), PLY
/// (ASCII, binary little and big endian) and OFF, each in double precision.
///
/// Each reads the whole of `in.data` in time linear in its size, allocating memory bounded by
/// a constant times that size (a declared count is checked against the bytes that follow
/// before anything is reserved for it), and returns the triangles with vertices of exactly
/// equal position welded (RawMesh::finish). Polygons are fan-triangulated; degenerate
/// triangles are kept as written. Anything that does not parse, a count that does not match
/// the data, an index out of range, a face with fewer than 3 corners, a number that is not
/// finite, truncated data: InputError with one line "<in.what>, line N: ..." (text) or
/// "<in.what>, byte N: ..." (binary). Internal to the io module; thread-safe (pure).

#include "voxcut/core/TriangleMesh.h"
#include "voxcut/io/MeshParse.h"

namespace voxcut::meshio {

/// Wavefront OBJ: `v x y z [w | r g b]` and `f` with corners `i`, `i/t`, `i//n`, `i/t/n`
/// (1-based; negative indices count back from the last vertex defined so far). Every other
/// statement (vt, vn, g, o, s, usemtl, mtllib, l, p, ...) and `#` comments are ignored.
[[nodiscard]] TriangleMesh readObj(const MeshInput& in);

/// STL: ASCII when the data starts with "solid" and holds only text (`solid` ... `endsolid`,
/// several solids allowed; facet normals must be numbers and are otherwise ignored); binary
/// otherwise, whose size must then be exactly 84 + 50 n for the count n stored at byte 80.
[[nodiscard]] TriangleMesh readStl(const MeshInput& in);

/// PLY: ascii, binary_little_endian or binary_big_endian 1.0. Element `vertex` with scalar
/// properties x, y, z of any numeric type; element `face` with a list property named
/// vertex_indices or vertex_index of integer count and index types. Other elements and
/// properties are skipped by their declared types; comment and obj_info lines are ignored.
[[nodiscard]] TriangleMesh readPly(const MeshInput& in);

/// OFF: an optional `OFF` keyword (or COFF, NOFF, CNOFF, STOFF, ...), the counts line
/// `nv nf [ne]`, nv vertex lines `x y z [extra values]`, nf face lines `n i1 .. in [color]`
/// (0-based). `#` starts a comment; blank lines are ignored.
[[nodiscard]] TriangleMesh readOff(const MeshInput& in);

}  // namespace voxcut::meshio
