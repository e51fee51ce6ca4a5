/// @file OffReader.cpp
/// Validating OFF reader (see MeshFormats.h).

#include <string>
#include <vector>

#include "voxcut/io/MeshFormats.h"

namespace voxcut::meshio {
namespace {

/// Values a face line may carry after its indices: a colour (index, RGB or RGBA).
constexpr std::size_t kMaxFaceColour = 4;

/// The next line with tokens (comments after '#' removed) into `tokens`; false at the end.
bool nextTokens(LineReader& lines, std::vector<std::string_view>& tokens) {
  while (const std::optional<std::string_view> text = lines.next()) {
    splitTokens(*text, tokens, '#');
    if (!tokens.empty()) return true;
  }
  return false;
}

/// Whether `word` is an OFF keyword: "OFF" after optional prefixes ST, C, N, 4, n (in that
/// order). Sets `unsupported` for the 4D and n-dimensional variants.
bool isKeyword(std::string_view word, bool& unsupported) {
  if (!word.ends_with("OFF")) return false;
  std::string_view prefix = word.substr(0, word.size() - 3);
  unsupported = false;
  for (const std::string_view part : {"ST", "C", "N", "4", "n"})
    if (prefix.starts_with(part)) {
      if (part == "4" || part == "n") unsupported = true;
      prefix.remove_prefix(part.size());
    }
  return prefix.empty();
}

/// A count token: a non-negative integer.
std::uint64_t countAt(const MeshInput& in, std::size_t line, std::string_view token) {
  const std::optional<std::int64_t> n = parseInteger(token);
  if (!n || *n < 0) failAtLine(in, line, "count " + quoted(token) + " is not a count");
  return static_cast<std::uint64_t>(*n);
}

}  // namespace

TriangleMesh readOff(const MeshInput& in) {
  LineReader lines(in);
  std::vector<std::string_view> tokens;
  if (!nextTokens(lines, tokens)) failAtLine(in, lines.lineNumber(), "no OFF header or counts");
  bool unsupported = false;
  if (isKeyword(tokens[0], unsupported)) {
    if (unsupported)
      failAtLine(in, lines.lineNumber(),
                 "OFF variant " + quoted(tokens[0]) +
                     " not supported "
                     "(only 3D vertices are)");
    if (tokens.size() > 1 && tokens[1] == "BINARY")
      failAtLine(in, lines.lineNumber(), "binary OFF is not supported");
    tokens.erase(tokens.begin());
    // The counts usually follow on their own line, but may share the keyword's.
    if (tokens.empty() && !nextTokens(lines, tokens))
      failAtLine(in, lines.lineNumber(), "data ends before the counts line");
  }
  std::size_t line = lines.lineNumber();
  if (tokens.size() < 2 || tokens.size() > 3)
    failAtLine(in, line, "expected the counts 'vertices faces [edges]'");
  const std::uint64_t nv = countAt(in, line, tokens[0]);
  const std::uint64_t nf = countAt(in, line, tokens[1]);
  if (tokens.size() == 3) (void)countAt(in, line, tokens[2]);  // edges: unused
  if (nv > kMaxVertices) failAtLine(in, line, "too many vertices (" + std::to_string(nv) + ")");
  const std::uint64_t bytesLeft = in.data.size() - lines.offset();
  if (nf > bytesLeft || nv + nf > bytesLeft)
    failAtLine(in, line,
               "declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                   " faces, more lines than the " + std::to_string(bytesLeft) +
                   " bytes after it can hold");

  RawMesh mesh;
  for (std::uint64_t i = 0; i < nv; ++i) {
    if (!nextTokens(lines, tokens))
      failAtLine(
          in, lines.lineNumber(),
          "data ends after " + std::to_string(i) + " of " + std::to_string(nv) + " vertices");
    line = lines.lineNumber();
    if (tokens.size() < 3)
      failAtLine(in, line,
                 "vertex has " + std::to_string(tokens.size()) + " values (x y z needed)");
    for (std::size_t k = 3; k < tokens.size(); ++k)  // normal, colour or texture: unused
      if (!parseNumber(tokens[k])) failAtLine(in, line, quoted(tokens[k]) + " is not a number");
    mesh.addVertex(Vec3d(coordinateAt(in, line, tokens[0]), coordinateAt(in, line, tokens[1]),
                         coordinateAt(in, line, tokens[2])));
  }
  std::vector<int> corners;
  for (std::uint64_t i = 0; i < nf; ++i) {
    if (!nextTokens(lines, tokens))
      failAtLine(in, lines.lineNumber(),
                 "data ends after " + std::to_string(i) + " of " + std::to_string(nf) + " faces");
    line = lines.lineNumber();
    const std::uint64_t n = countAt(in, line, tokens[0]);
    if (n < 3)
      failAtLine(in, line, "face has " + std::to_string(n) + " vertex indices (at least 3 needed)");
    if (n > tokens.size() - 1)
      failAtLine(in, line,
                 "face declares " + std::to_string(n) + " vertex indices but lists " +
                     std::to_string(tokens.size() - 1) + " values");
    if (tokens.size() - 1 - n > kMaxFaceColour)
      failAtLine(in, line,
                 "face has " + std::to_string(tokens.size() - 1 - n) +
                     " values after its indices (at most a colour of 4)");
    corners.clear();
    for (std::size_t k = 1; k <= n; ++k) {
      const std::optional<std::int64_t> index = parseInteger(tokens[k]);
      if (!index) failAtLine(in, line, "vertex index " + quoted(tokens[k]) + " is not an integer");
      if (*index < 0 || static_cast<std::uint64_t>(*index) >= nv)
        failAtLine(in, line,
                   "vertex index " + std::to_string(*index) + " out of range (" +
                       std::to_string(nv) + " vertices)");
      corners.push_back(static_cast<int>(*index));
    }
    for (std::size_t k = n + 1; k < tokens.size(); ++k)
      if (!parseNumber(tokens[k])) failAtLine(in, line, quoted(tokens[k]) + " is not a number");
    mesh.addPolygon(corners);
  }
  if (nextTokens(lines, tokens))
    failAtLine(in, lines.lineNumber(),
               "data beyond the " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                   " faces declared");
  return mesh.finish(in);
}

}  // namespace voxcut::meshio
