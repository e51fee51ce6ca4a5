/// @file ObjReader.cpp
/// Validating Wavefront OBJ reader (see MeshFormats.h): only `v` and `f` carry geometry.

#include <string>
#include <vector>

#include "voxcut/io/MeshFormats.h"

namespace voxcut::meshio {
namespace {

/// Parses the vertex part of one face corner `i`, `i/t`, `i//n` or `i/t/n` and checks the
/// texture and normal parts are integers (their targets, vt and vn, are not read). Returns
/// the 0-based vertex index, resolved against the `defined` vertices so far.
int cornerIndex(const MeshInput& in, std::size_t line, std::string_view corner,
                std::size_t defined) {
  std::string_view parts[3];
  int count = 0;
  std::size_t start = 0;
  while (true) {
    const std::size_t slash = corner.find('/', start);
    if (count == 3) failAtLine(in, line, "face corner " + quoted(corner) + " has over 2 slashes");
    parts[count++] = corner.substr(start, slash == std::string_view::npos ? slash : slash - start);
    if (slash == std::string_view::npos) break;
    start = slash + 1;
  }
  const bool badTexture = count >= 2 && !parts[1].empty() && !parseInteger(parts[1]);
  const bool badNormal = count == 3 && !parseInteger(parts[2]);
  const bool emptyTexture = count == 2 && parts[1].empty();
  if (badTexture || badNormal || emptyTexture)
    failAtLine(in, line, "face corner " + quoted(corner) + " is not i, i/t, i//n or i/t/n");
  const std::optional<std::int64_t> index = parseInteger(parts[0]);
  if (!index) failAtLine(in, line, "face corner " + quoted(corner) + " has no vertex index");
  const auto n = static_cast<std::int64_t>(defined);
  if (*index == 0) failAtLine(in, line, "vertex index 0 (OBJ indices start at 1)");
  const std::int64_t resolved = *index > 0 ? *index - 1 : n + *index;
  if (resolved < 0 || resolved >= n)
    failAtLine(in, line,
               "vertex index " + std::to_string(*index) + " out of range (" +
                   std::to_string(defined) + " vertices defined so far)");
  return static_cast<int>(resolved);
}

}  // namespace

TriangleMesh readObj(const MeshInput& in) {
  RawMesh mesh;
  LineReader lines(in);
  std::vector<std::string_view> tokens;
  std::vector<int> corners;
  while (const std::optional<std::string_view> text = lines.next()) {
    const std::size_t line = lines.lineNumber();
    splitTokens(*text, tokens, '#');
    if (tokens.empty()) continue;
    if (tokens[0] == "v") {
      if (tokens.size() < 4)
        failAtLine(in, line,
                   "vertex has " + std::to_string(tokens.size() - 1) + " values (x y z needed)");
      if (mesh.vertexCount() >= kMaxVertices) failAtLine(in, line, "too many vertices");
      for (std::size_t k = 4; k < tokens.size(); ++k)  // w or a colour: numbers, unused
        if (!parseNumber(tokens[k])) failAtLine(in, line, quoted(tokens[k]) + " is not a number");
      mesh.addVertex(Vec3d(coordinateAt(in, line, tokens[1]), coordinateAt(in, line, tokens[2]),
                           coordinateAt(in, line, tokens[3])));
    } else if (tokens[0] == "f") {
      if (tokens.size() < 4)
        failAtLine(
            in, line,
            "face has " + std::to_string(tokens.size() - 1) + " corners (at least 3 needed)");
      corners.clear();
      for (std::size_t k = 1; k < tokens.size(); ++k)
        corners.push_back(cornerIndex(in, line, tokens[k], mesh.vertexCount()));
      mesh.addPolygon(corners);
    }
    // Every other statement describes attributes, groups, materials or non-triangle
    // primitives; none of them changes the surface.
  }
  return mesh.finish(in);
}

}  // namespace voxcut::meshio
