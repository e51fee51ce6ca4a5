/// @file PlyReader.cpp
/// Validating PLY reader (see MeshFormats.h): the header is parsed into elements with typed
/// properties, the body is then read element by element (ASCII: one line per item; binary:
/// fixed-size scalars and counted lists), every value checked as it is read.

#include <bit>
#include <cmath>
#include <string>
#include <vector>

#include "voxcut/io/MeshFormats.h"

namespace voxcut::meshio {
namespace {

/// A PLY scalar type: its size in bytes and how its bits are read.
struct ScalarType {
  std::size_t size = 0;
  bool isFloat = false;
  bool isSigned = false;
};

std::optional<ScalarType> scalarType(std::string_view name) {
  if (name == "char" || name == "int8") return ScalarType{1, false, true};
  if (name == "uchar" || name == "uint8") return ScalarType{1, false, false};
  if (name == "short" || name == "int16") return ScalarType{2, false, true};
  if (name == "ushort" || name == "uint16") return ScalarType{2, false, false};
  if (name == "int" || name == "int32") return ScalarType{4, false, true};
  if (name == "uint" || name == "uint32") return ScalarType{4, false, false};
  if (name == "float" || name == "float32") return ScalarType{4, true, true};
  if (name == "double" || name == "float64") return ScalarType{8, true, true};
  return std::nullopt;
}

/// What a property means to us.
enum class Role { Skip, X, Y, Z, Indices };

struct Property {
  std::string name;
  bool isList = false;
  ScalarType countType;  // lists only
  ScalarType valueType;
  Role role = Role::Skip;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
  std::size_t headerLine = 0;
  /// Bytes of one item with every list empty (binary); 0 for an element without properties.
  [[nodiscard]] std::uint64_t minBytes() const {
    std::uint64_t n = 0;
    for (const Property& p : properties) n += p.isList ? p.countType.size : p.valueType.size;
    return n;
  }
};

enum class Format { Ascii, LittleEndian, BigEndian };

struct Header {
  Format format = Format::Ascii;
  std::vector<Element> elements;
  std::uint64_t vertexCount = 0;
};

/// Parses the header up to end_header; `lines` is left at the first body line.
Header parseHeader(const MeshInput& in, LineReader& lines) {
  Header header;
  bool haveFormat = false, haveVertex = false, haveFace = false;
  std::vector<std::string_view> tokens;
  auto fail = [&](const std::string& what) { failAtLine(in, lines.lineNumber(), what); };
  const std::optional<std::string_view> first = lines.next();
  splitTokens(first.value_or(""), tokens);
  if (tokens.size() != 1 || tokens[0] != "ply") fail("not a PLY file (no 'ply' first line)");
  while (true) {
    const std::optional<std::string_view> text = lines.next();
    if (!text) failAtLine(in, lines.lineNumber(), "the header has no end_header");
    splitTokens(*text, tokens);
    if (tokens.empty() || tokens[0] == "comment" || tokens[0] == "obj_info") continue;
    const std::string_view word = tokens[0];
    if (word == "end_header") break;
    if (word == "format") {
      if (haveFormat) fail("a second format line");
      if (tokens.size() != 3) fail("expected 'format <type> 1.0'");
      if (tokens[1] == "ascii")
        header.format = Format::Ascii;
      else if (tokens[1] == "binary_little_endian")
        header.format = Format::LittleEndian;
      else if (tokens[1] == "binary_big_endian")
        header.format = Format::BigEndian;
      else
        fail("unknown PLY format " + quoted(tokens[1]));
      if (!tokens[2].starts_with("1.")) fail("unsupported PLY version " + quoted(tokens[2]));
      haveFormat = true;
    } else if (word == "element") {
      if (!haveFormat) fail("element declared before the format line");
      if (tokens.size() != 3) fail("expected 'element <name> <count>'");
      const std::optional<std::int64_t> count = parseInteger(tokens[2]);
      if (!count || *count < 0) fail("element count " + quoted(tokens[2]) + " is not a count");
      Element e{std::string(tokens[1]), static_cast<std::uint64_t>(*count), {}, lines.lineNumber()};
      if (e.name == "vertex") {
        if (haveVertex) fail("a second 'vertex' element");
        if (e.count > kMaxVertices) fail("too many vertices (" + std::to_string(e.count) + ")");
        header.vertexCount = e.count;
        haveVertex = true;
      }
      if (e.name == "face") {
        if (haveFace) fail("a second 'face' element");
        haveFace = true;
      }
      header.elements.push_back(std::move(e));
    } else if (word == "property") {
      if (header.elements.empty()) fail("property declared before any element");
      Element& e = header.elements.back();
      Property p;
      if (tokens.size() == 5 && tokens[1] == "list") {
        const auto countType = scalarType(tokens[2]), valueType = scalarType(tokens[3]);
        if (!countType || !valueType) fail("unknown property type in " + quoted(*text));
        if (countType->isFloat) fail("list count type must be an integer type");
        p = {std::string(tokens[4]), true, *countType, *valueType, Role::Skip};
      } else if (tokens.size() == 3) {
        const auto type = scalarType(tokens[1]);
        if (!type) fail("unknown property type " + quoted(tokens[1]));
        p = {std::string(tokens[2]), false, {}, *type, Role::Skip};
      } else {
        fail("expected 'property <type> <name>' or 'property list <type> <type> <name>'");
      }
      for (const Property& q : e.properties)
        if (q.name == p.name) fail("property '" + p.name + "' declared twice");
      if (e.name == "vertex" && (p.name == "x" || p.name == "y" || p.name == "z")) {
        if (p.isList) fail("vertex property " + p.name + " must be a scalar, not a list");
        p.role = p.name == "x" ? Role::X : p.name == "y" ? Role::Y : Role::Z;
      }
      if (e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index")) {
        for (const Property& q : e.properties)
          if (q.role == Role::Indices) fail("face has both vertex_indices and vertex_index");
        if (!p.isList) fail("face property " + p.name + " must be a list");
        if (p.valueType.isFloat) fail("vertex indices must have an integer type");
        p.role = Role::Indices;
      }
      e.properties.push_back(std::move(p));
    } else {
      fail("unknown header line " + quoted(*text));
    }
  }
  for (const Element& e : header.elements) {
    auto has = [&](Role r) {
      for (const Property& p : e.properties)
        if (p.role == r) return true;
      return false;
    };
    if (e.name == "vertex" && !(has(Role::X) && has(Role::Y) && has(Role::Z)))
      failAtLine(in, e.headerLine, "the vertex element lacks one of the properties x, y, z");
    if (e.name == "face" && !has(Role::Indices))
      failAtLine(in, e.headerLine, "the face element has no vertex_indices list");
  }
  if (!haveVertex) failAtLine(in, lines.lineNumber(), "the header declares no vertex element");
  return header;
}

/// Collects the geometry of the body as it is read, whatever the encoding.
class Collector {
 public:
  explicit Collector(std::uint64_t vertexCount) : vertexCount_(vertexCount) {}
  RawMesh mesh;
  Vec3d position = Vec3d::Zero();
  std::vector<int> corners;

  /// Checks a vertex index; returns an error text, empty when fine.
  [[nodiscard]] std::string badIndex(std::int64_t index) const {
    if (index >= 0 && static_cast<std::uint64_t>(index) < vertexCount_) return {};
    return "vertex index " + std::to_string(index) + " out of range (" +
           std::to_string(vertexCount_) + " vertices)";
  }
  static std::string badCornerCount(std::uint64_t n) {
    return n >= 3 ? std::string()
                  : "face has " + std::to_string(n) + " vertex indices (at least 3 needed)";
  }

 private:
  std::uint64_t vertexCount_;
};

/// The ASCII body: every item of an element with properties is one line.
void readAsciiBody(const MeshInput& in, LineReader& lines, const Header& header, Collector& c) {
  const std::uint64_t bytesLeft = in.data.size() - lines.offset();
  std::uint64_t items = 0;
  for (const Element& e : header.elements)
    if (!e.properties.empty()) items += e.count;
  if (items > bytesLeft)
    failAtLine(in, lines.lineNumber(),
               "the header declares " + std::to_string(items) + " lines of data but only " +
                   std::to_string(bytesLeft) + " bytes follow end_header");
  std::vector<std::string_view> tokens;
  for (const Element& e : header.elements) {
    if (e.properties.empty()) continue;
    for (std::uint64_t i = 0; i < e.count; ++i) {
      std::optional<std::string_view> text;
      do {
        text = lines.next();
        if (text) splitTokens(*text, tokens);
      } while (text && tokens.empty());
      const std::size_t line = lines.lineNumber();
      if (!text)
        failAtLine(in, line,
                   "data ends after " + std::to_string(i) + " of " + std::to_string(e.count) +
                       " '" + e.name + "' elements");
      std::size_t t = 0;
      auto take = [&]() -> std::string_view {
        if (t == tokens.size())
          failAtLine(in, line, "'" + e.name + "' element has fewer values than declared");
        return tokens[t++];
      };
      for (const Property& p : e.properties) {
        if (!p.isList) {
          const std::string_view token = take();
          if (p.role == Role::Skip) {
            if (!parseNumber(token)) failAtLine(in, line, quoted(token) + " is not a number");
          } else {
            c.position[static_cast<int>(p.role) - static_cast<int>(Role::X)] =
                coordinateAt(in, line, token);
          }
          continue;
        }
        const std::string_view countToken = take();
        const std::optional<std::int64_t> n = parseInteger(countToken);
        if (!n || *n < 0)
          failAtLine(in, line, "list count " + quoted(countToken) + " is not a count");
        const auto count = static_cast<std::uint64_t>(*n);
        if (count > tokens.size() - t)
          failAtLine(in, line,
                     "list declares " + std::to_string(count) +
                         " values but the line "
                         "has " +
                         std::to_string(tokens.size() - t) + " left");
        if (p.role == Role::Indices) {
          if (const std::string bad = Collector::badCornerCount(count); !bad.empty())
            failAtLine(in, line, bad);
          c.corners.clear();
        }
        for (std::uint64_t k = 0; k < count; ++k) {
          const std::string_view token = take();
          if (p.role != Role::Indices) {
            if (!parseNumber(token)) failAtLine(in, line, quoted(token) + " is not a number");
            continue;
          }
          const std::optional<std::int64_t> index = parseInteger(token);
          if (!index) failAtLine(in, line, "vertex index " + quoted(token) + " is not an integer");
          if (const std::string bad = c.badIndex(*index); !bad.empty()) failAtLine(in, line, bad);
          c.corners.push_back(static_cast<int>(*index));
        }
        if (p.role == Role::Indices) c.mesh.addPolygon(c.corners);
      }
      if (t != tokens.size())
        failAtLine(in, line,
                   "'" + e.name + "' element has " + std::to_string(tokens.size()) +
                       " values, more than declared");
      if (e.name == "vertex") c.mesh.addVertex(c.position);
    }
  }
  while (const std::optional<std::string_view> text = lines.next()) {
    splitTokens(*text, tokens);
    if (!tokens.empty())
      failAtLine(in, lines.lineNumber(), "data beyond the elements the header declares");
  }
}

/// Reads binary fields with bounds checks; every failure names the byte offset.
class BinaryCursor {
 public:
  BinaryCursor(const MeshInput& in, std::size_t offset, bool bigEndian)
      : in_(in), pos_(offset), bigEndian_(bigEndian) {}
  [[nodiscard]] std::size_t offset() const { return pos_; }
  [[nodiscard]] std::size_t left() const { return in_.data.size() - pos_; }
  /// Fails unless `bytes` more bytes exist; `where` says what was being read.
  void need(std::uint64_t bytes, const std::string& where) const {
    if (bytes > left()) failAtByte(in_, pos_, "data ends inside " + where);
  }
  void skip(std::uint64_t bytes) { pos_ += static_cast<std::size_t>(bytes); }
  /// The next value of `type` (whose bytes were checked by need()), as a double.
  double number(const ScalarType& type) {
    const std::uint64_t bits = load(type.size);
    if (type.isFloat)
      return type.size == 4
                 ? static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(bits)))
                 : std::bit_cast<double>(bits);
    return static_cast<double>(integerOf(bits, type));
  }
  /// The next value of integer `type`, as an integer.
  std::int64_t integer(const ScalarType& type) { return integerOf(load(type.size), type); }

 private:
  std::uint64_t load(std::size_t size) {
    const auto* p = reinterpret_cast<const unsigned char*>(in_.data.data()) + pos_;
    pos_ += size;
    return loadUnsigned(p, size, bigEndian_);
  }
  static std::int64_t integerOf(std::uint64_t bits, const ScalarType& type) {
    const unsigned shift = 64 - 8 * static_cast<unsigned>(type.size);
    if (!type.isSigned) return static_cast<std::int64_t>(bits);
    return static_cast<std::int64_t>(bits << shift) >> shift;  // sign extension
  }
  const MeshInput& in_;
  std::size_t pos_;
  bool bigEndian_;
};

void readBinaryBody(const MeshInput& in, std::size_t bodyOffset, const Header& header,
                    Collector& c) {
  BinaryCursor cur(in, bodyOffset, header.format == Format::BigEndian);
  // The smallest body the header allows, before anything is read: an absurd count fails here.
  std::uint64_t minimum = 0;
  for (const Element& e : header.elements) {
    const std::uint64_t size = e.minBytes();
    if (size != 0 && e.count > (cur.left() - minimum) / size)
      failAtByte(in, bodyOffset,
                 "element '" + e.name + "' declares " + std::to_string(e.count) + " items of at " +
                     "least " + std::to_string(size) + " bytes, more than the " +
                     std::to_string(cur.left()) + " bytes after end_header hold");
    minimum += e.count * size;
  }
  for (const Element& e : header.elements) {
    if (e.properties.empty()) continue;
    for (std::uint64_t i = 0; i < e.count; ++i) {
      const std::string where =
          "'" + e.name + "' element " + std::to_string(i) + " of " + std::to_string(e.count);
      for (const Property& p : e.properties) {
        const std::size_t at = cur.offset();
        if (!p.isList) {
          cur.need(p.valueType.size, where);
          if (p.role == Role::Skip) {
            cur.skip(p.valueType.size);
            continue;
          }
          const double value = cur.number(p.valueType);
          if (!std::isfinite(value))
            failAtByte(in, at, "non-finite coordinate (NaN or infinity) in " + where);
          c.position[static_cast<int>(p.role) - static_cast<int>(Role::X)] = value;
          continue;
        }
        cur.need(p.countType.size, where);
        const std::int64_t n = cur.integer(p.countType);
        if (n < 0) failAtByte(in, at, "negative list count " + std::to_string(n) + " in " + where);
        const auto count = static_cast<std::uint64_t>(n);
        if (count > cur.left() / p.valueType.size)
          failAtByte(in, at,
                     "list of " + std::to_string(count) +
                         " values runs past the end "
                         "of the data in " +
                         where);
        if (p.role != Role::Indices) {
          cur.skip(count * p.valueType.size);
          continue;
        }
        if (const std::string bad = Collector::badCornerCount(count); !bad.empty())
          failAtByte(in, at, bad + " in " + where);
        c.corners.clear();
        for (std::uint64_t k = 0; k < count; ++k) {
          const std::size_t indexAt = cur.offset();
          const std::int64_t index = cur.integer(p.valueType);
          if (const std::string bad = c.badIndex(index); !bad.empty())
            failAtByte(in, indexAt, bad + " in " + where);
          c.corners.push_back(static_cast<int>(index));
        }
        c.mesh.addPolygon(c.corners);
      }
      if (e.name == "vertex") c.mesh.addVertex(c.position);
    }
  }
  if (cur.left() != 0)
    failAtByte(in, cur.offset(),
               std::to_string(cur.left()) +
                   " bytes beyond the elements the "
                   "header declares");
}

}  // namespace

TriangleMesh readPly(const MeshInput& in) {
  LineReader lines(in);
  const Header header = parseHeader(in, lines);
  Collector collector(header.vertexCount);
  if (header.format == Format::Ascii)
    readAsciiBody(in, lines, header, collector);
  else
    readBinaryBody(in, lines.offset(), header, collector);
  return collector.mesh.finish(in);
}

}  // namespace voxcut::meshio
