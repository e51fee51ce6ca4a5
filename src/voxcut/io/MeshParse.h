#pragma once
/// @file MeshParse.h
/// What the validating mesh readers (ObjReader, StlReader, PlyReader, OffReader) share: the
/// one-line error naming the source and the position, line splitting, strict number parsing,
/// little/big-endian field access, and the raw polygon mesh that is welded at the end.
///
/// Internal to the io module. Every function is pure or works on its own arguments only, so
/// all of it is thread-safe.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "voxcut/core/TriangleMesh.h"

namespace voxcut::meshio {

/// The bytes of one mesh and how to name them in messages ("mesh file 'a.obj'").
struct MeshInput {
  std::string_view data;
  std::string what;
};

/// Throws InputError "<what>, line <line>: <message>" (a text format's 1-based line).
[[noreturn]] void failAtLine(const MeshInput& in, std::size_t line, const std::string& message);

/// Throws InputError "<what>, byte <offset>: <message>" (a binary format's 0-based offset).
[[noreturn]] void failAtByte(const MeshInput& in, std::size_t offset, const std::string& message);

/// `token` quoted for a message, without surrounding blanks, cut to 40 characters and with control
/// bytes as '?', so that a binary blob read as text still gives one short line.
[[nodiscard]] std::string quoted(std::string_view token);

/// Splits text into lines ('\n', '\r\n' or a lone '\r' end one), numbering them from 1.
/// A '\0' byte is refused: no text mesh format allows it, and it marks a binary file.
class LineReader {
 public:
  explicit LineReader(const MeshInput& in) : in_(in) {}
  /// The next line without its terminator, or nullopt at the end of the data.
  [[nodiscard]] std::optional<std::string_view> next();
  /// Number of the line last returned by next() (0 before the first).
  [[nodiscard]] std::size_t lineNumber() const { return line_; }
  /// Byte offset where the next line starts (data.size() at the end).
  [[nodiscard]] std::size_t offset() const { return pos_; }

 private:
  const MeshInput& in_;
  std::size_t pos_ = 0;
  std::size_t line_ = 0;
};

/// Splits `line` into whitespace-separated tokens (space, tab, vertical tab, form feed) into
/// `out` (cleared first), stopping at `comment` when it is not '\0'.
void splitTokens(std::string_view line, std::vector<std::string_view>& out, char comment = '\0');

/// Parses a whole token as a decimal floating-point number (optional sign, digits, optional
/// fraction and exponent; no hex). Values too small for a double become 0 (or a subnormal).
/// nullopt when the token is not a number; "nan", "inf" and values beyond the double range
/// parse to a non-finite value, which the caller rejects where it needs coordinates.
[[nodiscard]] std::optional<double> parseNumber(std::string_view token);

/// Parses a whole token as a decimal integer with an optional sign; nullopt when it is not
/// one or does not fit in 64 bits.
[[nodiscard]] std::optional<std::int64_t> parseInteger(std::string_view token);

/// A coordinate from a text token: throws at `line` when it is not a number or not finite.
[[nodiscard]] double coordinateAt(const MeshInput& in, std::size_t line, std::string_view token);

/// Reads an unsigned integer of `size` bytes (1, 2, 4 or 8) at `p` in the given byte order.
[[nodiscard]] std::uint64_t loadUnsigned(const unsigned char* p, std::size_t size, bool bigEndian);

/// The largest vertex count a TriangleMesh can index (its indices are int).
inline constexpr std::uint64_t kMaxVertices = 0x7fffffff;

/// Vertices and polygons as a file lists them, fan-triangulated; welded by finish().
class RawMesh {
 public:
  /// Appends a vertex (finite, checked by the caller); returns its 0-based index.
  int addVertex(const Vec3d& p);
  /// Number of vertices added so far.
  [[nodiscard]] std::size_t vertexCount() const { return vertices_.size(); }
  /// Appends the polygon `corners` (at least 3 indices, each already checked to be a valid
  /// vertex index) as the fan (c0, ck, ck+1), k = 1 .. n-2.
  void addPolygon(const std::vector<int>& corners);
  /// The triangles, with vertices of exactly equal position welded across the whole mesh
  /// (-0 equals +0) and numbered in order of first use; vertices no face uses are dropped.
  /// Throws InputError naming `in` when there is no triangle at all.
  [[nodiscard]] TriangleMesh finish(const MeshInput& in) const;

 private:
  std::vector<Vec3d> vertices_;
  std::vector<std::array<int, 3>> faces_;
};

}  // namespace voxcut::meshio
