#include "voxcut/io/MeshParse.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <tuple>

#include "voxcut/core/Error.h"

namespace voxcut::meshio {
namespace {

bool isBlank(char c) {
  return c == ' ' || c == '\t' || c == '\v' || c == '\f';
}

/// Exact position as a hash key; -0 is folded into +0 so that equal values weld.
struct PositionKey {
  std::array<std::uint64_t, 3> bits;
  friend bool operator==(const PositionKey&, const PositionKey&) = default;
};

PositionKey keyOf(const Vec3d& p) {
  return {{std::bit_cast<std::uint64_t>(p.x() + 0.0), std::bit_cast<std::uint64_t>(p.y() + 0.0),
           std::bit_cast<std::uint64_t>(p.z() + 0.0)}};
}

/// The token without one leading '+' (std::from_chars accepts only '-').
std::string_view withoutPlus(std::string_view token) {
  if (token.size() > 1 && token.front() == '+' && token[1] != '-' && token[1] != '+')
    token.remove_prefix(1);
  return token;
}

}  // namespace

void failAtLine(const MeshInput& in, std::size_t line, const std::string& message) {
  throw InputError(in.what + ", line " + std::to_string(line) + ": " + message);
}

void failAtByte(const MeshInput& in, std::size_t offset, const std::string& message) {
  throw InputError(in.what + ", byte " + std::to_string(offset) + ": " + message);
}

std::string quoted(std::string_view token) {
  constexpr std::size_t kMax = 40;
  while (!token.empty() && isBlank(token.front())) token.remove_prefix(1);
  while (!token.empty() && isBlank(token.back())) token.remove_suffix(1);
  std::string out = "'";
  for (std::size_t i = 0; i < token.size() && i < kMax; ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    out.push_back(c < 0x20 || c == 0x7f ? '?' : static_cast<char>(c));
  }
  if (token.size() > kMax) out += "...";
  return out + "'";
}

std::optional<std::string_view> LineReader::next() {
  const std::string_view data = in_.data;
  if (pos_ >= data.size()) return std::nullopt;
  ++line_;
  const std::size_t start = pos_;
  std::size_t end = start;
  while (end < data.size() && data[end] != '\n' && data[end] != '\r') {
    if (data[end] == '\0') failAtLine(in_, line_, "a NUL byte in text (a binary file?)");
    ++end;
  }
  pos_ = end;
  if (pos_ < data.size()) {
    if (data[pos_] == '\r' && pos_ + 1 < data.size() && data[pos_ + 1] == '\n') ++pos_;
    ++pos_;
  }
  return data.substr(start, end - start);
}

void splitTokens(std::string_view line, std::vector<std::string_view>& out, char comment) {
  out.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && isBlank(line[i])) ++i;
    if (i == line.size() || (comment != '\0' && line[i] == comment)) return;
    const std::size_t start = i;
    while (i < line.size() && !isBlank(line[i]) && !(comment != '\0' && line[i] == comment)) ++i;
    out.push_back(line.substr(start, i - start));
  }
}

std::optional<double> parseNumber(std::string_view token) {
  token = withoutPlus(token);
  if (token.empty()) return std::nullopt;
  double value = 0.0;
  const auto [end, ec] =
      std::from_chars(token.data(), token.data() + token.size(), value, std::chars_format::general);
  if (end != token.data() + token.size()) return std::nullopt;
  if (ec == std::errc()) return value;
  if (ec != std::errc::result_out_of_range) return std::nullopt;
  // Out of range: strtod tells overflow (+-HUGE_VAL, then rejected as non-finite) from
  // underflow (0 or a subnormal, a fine coordinate). The token is known to be a number.
  const std::string copy(token);
  return std::strtod(copy.c_str(), nullptr);
}

std::optional<std::int64_t> parseInteger(std::string_view token) {
  token = withoutPlus(token);
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (token.empty() || ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

double coordinateAt(const MeshInput& in, std::size_t line, std::string_view token) {
  const std::optional<double> value = parseNumber(token);
  if (!value) failAtLine(in, line, quoted(token) + " is not a number");
  if (!std::isfinite(*value))
    failAtLine(in, line,
               "non-finite coordinate " + quoted(token) +
                   " (NaN, infinity or beyond "
                   "the double range)");
  return *value;
}

std::uint64_t loadUnsigned(const unsigned char* p, std::size_t size, bool bigEndian) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < size; ++i) {
    const std::size_t k = bigEndian ? i : size - 1 - i;
    v = (v << 8) | p[k];
  }
  return v;
}

int RawMesh::addVertex(const Vec3d& p) {
  vertices_.push_back(p);
  return static_cast<int>(vertices_.size() - 1);
}

void RawMesh::addPolygon(const std::vector<int>& corners) {
  for (std::size_t k = 1; k + 1 < corners.size(); ++k)
    faces_.push_back({corners[0], corners[k], corners[k + 1]});
}

TriangleMesh RawMesh::finish(const MeshInput& in) const {
  if (faces_.empty()) throw InputError(in.what + " has no triangles");
  // Faces are numbered with int downstream (crossings, winding-number trees).
  if (faces_.size() > static_cast<std::size_t>(INT_MAX) / 3)
    throw InputError(in.what + " has too many triangles (" + std::to_string(faces_.size()) + ")");
  // The used vertices in order of first use; slot[v] is v's place in that order.
  std::vector<int> used;
  std::vector<int> slot(vertices_.size(), -1);
  for (const auto& face : faces_)
    for (const int v : face)
      if (slot[static_cast<std::size_t>(v)] < 0) {
        slot[static_cast<std::size_t>(v)] = static_cast<int>(used.size());
        used.push_back(v);
      }
  // Sorting by exact position (ties by first use) puts equal positions side by side; each
  // run is welded into its first-used member, and the output keeps the order of first use.
  std::vector<PositionKey> keys(used.size());
  for (std::size_t i = 0; i < used.size(); ++i)
    keys[i] = keyOf(vertices_[static_cast<std::size_t>(used[i])]);
  std::vector<int> order(used.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return std::tie(keys[a].bits, a) < std::tie(keys[b].bits, b); });
  std::vector<int> first(used.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const bool same = k > 0 && keys[order[k]] == keys[order[k - 1]];
    first[order[k]] = same ? first[order[k - 1]] : order[k];
  }
  TriangleMesh out;
  std::vector<int> id(used.size());
  for (std::size_t i = 0; i < used.size(); ++i) {
    if (first[i] == static_cast<int>(i)) {
      id[i] = static_cast<int>(out.vertices.size());
      out.vertices.push_back(vertices_[static_cast<std::size_t>(used[i])]);
    } else {
      id[i] = id[static_cast<std::size_t>(first[i])];  // an earlier slot, numbered already
    }
  }
  out.faces.reserve(faces_.size());
  for (const auto& face : faces_)
    out.faces.push_back({id[static_cast<std::size_t>(slot[static_cast<std::size_t>(face[0])])],
                         id[static_cast<std::size_t>(slot[static_cast<std::size_t>(face[1])])],
                         id[static_cast<std::size_t>(slot[static_cast<std::size_t>(face[2])])]});
  return out;
}

}  // namespace voxcut::meshio
