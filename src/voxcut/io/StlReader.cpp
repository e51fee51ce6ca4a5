/// @file StlReader.cpp
/// Validating STL reader (see MeshFormats.h), binary and ASCII.

#include <bit>
#include <cmath>
#include <string>
#include <vector>

#include "voxcut/io/MeshFormats.h"

namespace voxcut::meshio {
namespace {

constexpr std::size_t kHeaderBytes = 84;  // 80 bytes of text, then the uint32 triangle count
constexpr std::size_t kFacetBytes = 50;   // normal and 3 corners as 12 floats, uint16 attribute

bool startsWithSolid(std::string_view data) {
  std::size_t i = 0;
  while (i < data.size() && (data[i] == ' ' || data[i] == '\t')) ++i;
  return data.substr(i).starts_with("solid");
}

/// Whether `data` could be ASCII STL: no control byte other than tab, line breaks, vertical
/// tab and form feed (bytes from 0x80 up may be UTF-8 in a solid's name). A binary STL holds
/// such bytes in practice: its triangle count's top byte is 0 below 16.7 million triangles.
bool looksLikeText(std::string_view data) {
  for (const char c : data) {
    const auto u = static_cast<unsigned char>(c);
    if ((u < 0x20 && (u < '\t' || u > '\r')) || u == 0x7f) return false;
  }
  return true;
}

TriangleMesh readBinary(const MeshInput& in, std::uint64_t count) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(in.data.data());
  if (count * 3 > kMaxVertices) failAtByte(in, 80, "too many triangles");
  RawMesh mesh;
  std::vector<int> corners(3);
  for (std::uint64_t f = 0; f < count; ++f) {
    const std::size_t facet = kHeaderBytes + static_cast<std::size_t>(f) * kFacetBytes;
    for (int k = 0; k < 3; ++k) {
      Vec3d p;
      for (int a = 0; a < 3; ++a) {
        const std::size_t at = facet + 12 + 12 * static_cast<std::size_t>(k) + 4 * a;
        const auto bits = static_cast<std::uint32_t>(loadUnsigned(bytes + at, 4, false));
        const float value = std::bit_cast<float>(bits);
        if (!std::isfinite(value))
          failAtByte(in, at,
                     "non-finite coordinate (NaN or infinity) in triangle " + std::to_string(f));
        p[a] = static_cast<double>(value);
      }
      corners[static_cast<std::size_t>(k)] = mesh.addVertex(p);
    }
    mesh.addPolygon(corners);
  }
  return mesh.finish(in);
}

/// ASCII STL as a sequence of statements; the grammar is
///   { solid [name] { facet normal n n n  outer loop  vertex x y z (3 times)  endloop
///   endfacet } endsolid [name] }
TriangleMesh readAscii(const MeshInput& in) {
  enum class State { Outside, InSolid, InFacet, InLoop, AfterLoop };
  State state = State::Outside;
  RawMesh mesh;
  LineReader lines(in);
  std::vector<std::string_view> tokens;
  std::vector<int> corners;
  bool anySolid = false;
  auto expect = [&](bool ok, const std::string& what) {
    if (!ok) failAtLine(in, lines.lineNumber(), what);
  };
  while (const std::optional<std::string_view> text = lines.next()) {
    const std::size_t line = lines.lineNumber();
    splitTokens(*text, tokens);
    if (tokens.empty()) continue;
    const std::string_view word = tokens[0];
    switch (state) {
      case State::Outside:
        expect(word == "solid", "expected 'solid', found " + quoted(word));
        state = State::InSolid;
        anySolid = true;
        break;
      case State::InSolid:
        if (word == "endsolid") {
          state = State::Outside;
          break;
        }
        expect(word == "facet" && tokens.size() == 5 && tokens[1] == "normal",
               "expected 'facet normal nx ny nz' or 'endsolid', found " + quoted(*text));
        // The normal is recomputed from the corners downstream; some writers put NaN in it
        // for degenerate facets, so it only has to be three numbers.
        for (int k = 2; k < 5; ++k)
          expect(parseNumber(tokens[k]).has_value(), quoted(tokens[k]) + " is not a number");
        state = State::InFacet;
        break;
      case State::InFacet:
        expect(word == "outer" && tokens.size() == 2 && tokens[1] == "loop",
               "expected 'outer loop', found " + quoted(*text));
        corners.clear();
        state = State::InLoop;
        break;
      case State::InLoop:
        if (word == "endloop") {
          expect(tokens.size() == 1, "unexpected text after 'endloop'");
          expect(corners.size() == 3,
                 "facet has " + std::to_string(corners.size()) + " vertices (3 needed)");
          mesh.addPolygon(corners);
          state = State::AfterLoop;
          break;
        }
        expect(word == "vertex" && tokens.size() == 4,
               "expected 'vertex x y z' or 'endloop', found " + quoted(*text));
        expect(corners.size() < 3, "facet has more than 3 vertices");
        expect(mesh.vertexCount() < kMaxVertices, "too many vertices");
        corners.push_back(mesh.addVertex(Vec3d(coordinateAt(in, line, tokens[1]),
                                               coordinateAt(in, line, tokens[2]),
                                               coordinateAt(in, line, tokens[3]))));
        break;
      case State::AfterLoop:
        expect(word == "endfacet" && tokens.size() == 1,
               "expected 'endfacet', found " + quoted(*text));
        state = State::InSolid;
        break;
    }
  }
  const std::size_t end = lines.lineNumber();
  if (!anySolid) failAtLine(in, end, "no 'solid' found");
  if (state != State::Outside)
    failAtLine(
        in, end,
        state == State::InSolid ? "data ends without 'endsolid'" : "data ends inside a facet");
  return mesh.finish(in);
}

}  // namespace

TriangleMesh readStl(const MeshInput& in) {
  const std::string_view data = in.data;
  // Some binary writers start the header with "solid" too; only a file that is all text is
  // read as ASCII.
  if (startsWithSolid(data) && looksLikeText(data)) return readAscii(in);
  if (data.size() < kHeaderBytes)
    failAtByte(in, data.size(),
               "data ends inside the 84-byte binary STL header (not ASCII STL either: that "
               "starts with 'solid' and holds only text)");
  const auto* bytes = reinterpret_cast<const unsigned char*>(data.data());
  const std::uint64_t count = loadUnsigned(bytes + 80, 4, false);
  if (data.size() - kHeaderBytes != count * kFacetBytes)
    failAtByte(in, 80,
               "binary STL declares " + std::to_string(count) + " triangles, which need " +
                   std::to_string(kHeaderBytes + count * kFacetBytes) +
                   " bytes, but the data has " + std::to_string(data.size()) + " bytes");
  return readBinary(in, count);
}

}  // namespace voxcut::meshio
