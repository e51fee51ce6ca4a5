// The NRRD reader (teem's format, http://teem.sourceforge.net/nrrd/format.html), for label
// volumes: 3-D data, or 4-D layered segmentations of 3D Slicer (SegmentationMetadata.h).
// The rules it chose where the format leaves room are stated at readNrrd in VolumeFormats.h.

#include <algorithm>
#include <array>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "voxcut/core/Error.h"
#include "voxcut/io/MeshParse.h"
#include "voxcut/io/SegmentationMetadata.h"
#include "voxcut/io/VolumeData.h"
#include "voxcut/io/VolumeFormats.h"

namespace voxcut::volumeio {
namespace {

using meshio::parseInteger;
using meshio::parseNumber;

// Gzip data are inflated from their start: a byte skip inside them costs memory, so it is
// bounded (it is there for a header in front of the samples, never for megabytes).
constexpr std::int64_t kMaxGzipByteSkip = std::int64_t{1} << 20;
// Header files are small; a data file read whole (gzip, line skip) is bounded like an
// attached file: its samples plus this much.
constexpr std::size_t kDataFileSlack = std::size_t{64} << 20;

struct Field {
  std::string value;
  std::size_t line = 0;
};

struct Header {
  std::map<std::string, Field, std::less<>> fields;  // by canonical name
  KeyValues keyValues;
  std::size_t dataStart = std::string_view::npos;  // after the empty line; npos: none
};

std::vector<std::string_view> tokensOf(std::string_view s) {
  std::vector<std::string_view> out;
  meshio::splitTokens(s, out);
  return out;
}

// The canonical name of a field, with the other spellings format.html allows; nullopt for a
// name that is no NRRD field.
std::optional<std::string> canonicalField(const std::string& name) {
  static const std::map<std::string, std::string, std::less<>> kNames = {
      {"dimension", "dimension"},
      {"type", "type"},
      {"encoding", "encoding"},
      {"endian", "endian"},
      {"sizes", "sizes"},
      {"spacings", "spacings"},
      {"space", "space"},
      {"space dimension", "space dimension"},
      {"space directions", "space directions"},
      {"space origin", "space origin"},
      {"space units", "space units"},
      {"kinds", "kinds"},
      {"data file", "data file"},
      {"datafile", "data file"},
      {"line skip", "line skip"},
      {"lineskip", "line skip"},
      {"byte skip", "byte skip"},
      {"byteskip", "byte skip"},
      {"centers", "centers"},
      {"centerings", "centers"},
      {"content", "content"},
      {"number", "number"},
      {"min", "min"},
      {"max", "max"},
      {"old min", "old min"},
      {"oldmin", "old min"},
      {"old max", "old max"},
      {"oldmax", "old max"},
      {"block size", "block size"},
      {"blocksize", "block size"},
      {"sample units", "sample units"},
      {"sampleunits", "sample units"},
      {"thicknesses", "thicknesses"},
      {"axis mins", "axis mins"},
      {"axismins", "axis mins"},
      {"axis maxs", "axis maxs"},
      {"axismaxs", "axis maxs"},
      {"labels", "labels"},
      {"units", "units"},
      {"measurement frame", "measurement frame"},
  };
  const auto it = kNames.find(name);
  if (it == kNames.end()) return std::nullopt;
  return it->second;
}

Header parseHeader(std::string_view bytes, const std::string& what,
                   std::vector<std::string>& warnings) {
  Header h;
  std::size_t pos = 0;
  const std::optional<std::string_view> magic = nextHeaderLine(bytes, pos);
  if (!magic || magic->substr(0, 4) != "NRRD")
    throw InputError(what + ": not a NRRD file (it does not start with NRRD000N)");
  if (magic->size() != 8 || magic->substr(0, 7) != "NRRD000" || (*magic)[7] < '1' ||
      (*magic)[7] > '5')
    throw InputError(what + ": NRRD magic '" + escaped(*magic) +
                     "' is not one of NRRD0001 to NRRD0005");
  std::size_t lineNumber = 1;
  while (const std::optional<std::string_view> line = nextHeaderLine(bytes, pos)) {
    ++lineNumber;
    if (line->empty()) {
      h.dataStart = pos;
      break;
    }
    if ((*line)[0] == '#') continue;
    const std::string at = "header line " + std::to_string(lineNumber);
    const std::size_t colon = line->find(':');
    if (colon == std::string_view::npos)
      throw InputError(what + ": " + at + " '" + escaped(*line) +
                       "' is neither 'field: value' nor 'key:=value'");
    if (colon + 1 < line->size() && (*line)[colon + 1] == '=') {
      h.keyValues.emplace_back(std::string(line->substr(0, colon)),
                               std::string(line->substr(colon + 2)));
      continue;
    }
    const std::string_view name = trimmed(line->substr(0, colon));
    const std::optional<std::string> canonical = canonicalField(lowerCase(name));
    if (!canonical) {
      warnings.push_back("NRRD field '" + escaped(name) + "' (" + at + ") is unknown; ignored");
      continue;
    }
    const std::string value(trimmed(line->substr(colon + 1)));
    if (!h.fields.emplace(*canonical, Field{value, lineNumber}).second)
      throw InputError(what + ": field '" + *canonical + "' (" + at + ") is given twice");
  }
  return h;
}

// Reads the fields of one header, naming them in messages.
class Fields {
 public:
  Fields(const Header& h, const std::string& what) : h_(h), what_(what) {}

  [[nodiscard]] const Field* find(std::string_view name) const {
    const auto it = h_.fields.find(name);
    return it == h_.fields.end() ? nullptr : &it->second;
  }
  [[nodiscard]] const Field& required(std::string_view name) const {
    const Field* f = find(name);
    if (f == nullptr) throw InputError(what_ + ": field '" + std::string(name) + "' is missing");
    return *f;
  }
  [[noreturn]] void fail(std::string_view name, const std::string& message) const {
    const Field* f = find(name);
    throw InputError(what_ + ": field '" + std::string(name) + "'" +
                     (f ? " (header line " + std::to_string(f->line) + ")" : std::string()) + ": " +
                     message);
  }
  // The field's value quoted for a message.
  [[nodiscard]] std::string quoted(std::string_view name) const {
    const Field* f = find(name);
    return "'" + escaped(f ? f->value : std::string()) + "'";
  }
  [[nodiscard]] std::int64_t integer(std::string_view name, std::int64_t fallback,
                                     std::int64_t min) const {
    const Field* f = find(name);
    if (f == nullptr) return fallback;
    const std::optional<std::int64_t> v = parseInteger(f->value);
    if (!v) fail(name, quoted(name) + " is not an integer");
    if (*v < min) fail(name, quoted(name) + " must be at least " + std::to_string(min));
    return *v;
  }
  // The field's tokens, which must be `count`.
  [[nodiscard]] std::vector<std::string_view> perAxis(std::string_view name,
                                                      std::size_t count) const {
    std::vector<std::string_view> t = tokensOf(required(name).value);
    if (t.size() != count)
      fail(name, std::to_string(t.size()) + " values for " + std::to_string(count) + " axes");
    return t;
  }

 private:
  const Header& h_;
  const std::string& what_;
};

std::optional<SampleType> sampleTypeOf(std::string_view value) {
  std::string words;  // lower case, single spaces
  for (const std::string_view t : tokensOf(value))
    words += (words.empty() ? "" : " ") + lowerCase(t);
  static const std::map<std::string, SampleType, std::less<>> kTypes = {
      {"signed char", SampleType::Int8},
      {"int8", SampleType::Int8},
      {"int8_t", SampleType::Int8},
      {"uchar", SampleType::UInt8},
      {"unsigned char", SampleType::UInt8},
      {"uint8", SampleType::UInt8},
      {"uint8_t", SampleType::UInt8},
      {"short", SampleType::Int16},
      {"short int", SampleType::Int16},
      {"signed short", SampleType::Int16},
      {"signed short int", SampleType::Int16},
      {"int16", SampleType::Int16},
      {"int16_t", SampleType::Int16},
      {"ushort", SampleType::UInt16},
      {"unsigned short", SampleType::UInt16},
      {"unsigned short int", SampleType::UInt16},
      {"uint16", SampleType::UInt16},
      {"uint16_t", SampleType::UInt16},
      {"int", SampleType::Int32},
      {"signed int", SampleType::Int32},
      {"int32", SampleType::Int32},
      {"int32_t", SampleType::Int32},
      {"uint", SampleType::UInt32},
      {"unsigned int", SampleType::UInt32},
      {"uint32", SampleType::UInt32},
      {"uint32_t", SampleType::UInt32},
      {"longlong", SampleType::Int64},
      {"long long", SampleType::Int64},
      {"long long int", SampleType::Int64},
      {"signed long long", SampleType::Int64},
      {"signed long long int", SampleType::Int64},
      {"int64", SampleType::Int64},
      {"int64_t", SampleType::Int64},
      {"ulonglong", SampleType::UInt64},
      {"unsigned long long", SampleType::UInt64},
      {"unsigned long long int", SampleType::UInt64},
      {"uint64", SampleType::UInt64},
      {"uint64_t", SampleType::UInt64},
      {"float", SampleType::Float32},
      {"double", SampleType::Float64},
  };
  const auto it = kTypes.find(words);
  if (it == kTypes.end()) return std::nullopt;
  return it->second;
}

// Vectors "(x,y,z)" or "none", `count` of them; nullopt entries for "none".
std::vector<std::optional<Vec3d>> parseVectors(const Fields& fields, std::string_view name,
                                               std::size_t count) {
  std::string_view rest = fields.required(name).value;
  std::vector<std::optional<Vec3d>> out;
  const auto skipBlanks = [&] {
    while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
  };
  for (std::size_t k = 0; k < count; ++k) {
    skipBlanks();
    if (rest.substr(0, 4) == "none") {
      rest.remove_prefix(4);
      out.emplace_back(std::nullopt);
      continue;
    }
    const std::size_t close = rest.find(')');
    if (rest.empty() || rest.front() != '(' || close == std::string_view::npos)
      fields.fail(name, "expected " + std::to_string(count) + " vectors '(x,y,z)' or 'none' in " +
                            fields.quoted(name));
    const std::string_view inner = rest.substr(1, close - 1);
    rest.remove_prefix(close + 1);
    Vec3d v;
    std::size_t start = 0;
    for (int c = 0; c < 3; ++c) {
      const std::size_t comma = c < 2 ? inner.find(',', start) : inner.size();
      if (comma == std::string_view::npos)
        fields.fail(name, "vector '(" + escaped(inner) + ")' does not have 3 components");
      const std::optional<double> x = parseNumber(trimmed(inner.substr(start, comma - start)));
      if (!x || !std::isfinite(*x))
        fields.fail(name, "vector '(" + escaped(inner) +
                              ")' holds a component that is not a "
                              "finite number");
      v[c] = *x;
      start = comma + 1;
    }
    out.emplace_back(v);
  }
  skipBlanks();
  if (!rest.empty()) fields.fail(name, "more than " + std::to_string(count) + " vectors");
  return out;
}

// `count` strings in double quotes.
std::vector<std::string> parseQuoted(const Fields& fields, std::string_view name,
                                     std::size_t count) {
  std::string_view rest = fields.required(name).value;
  std::vector<std::string> out;
  while (true) {
    while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
    if (rest.empty()) break;
    if (rest.front() != '"') fields.fail(name, "expected strings in double quotes");
    std::string s;
    std::size_t p = 1;
    for (; p < rest.size() && rest[p] != '"'; ++p) {
      if (rest[p] == '\\' && p + 1 < rest.size()) ++p;
      s += rest[p];
    }
    if (p >= rest.size()) fields.fail(name, "a string has no closing quote");
    rest.remove_prefix(p + 1);
    out.push_back(std::move(s));
  }
  if (out.size() != count)
    fields.fail(
        name, std::to_string(out.size()) + " strings for " + std::to_string(count) + " space axes");
  return out;
}

// Metres per unit of length; nullopt for a unit that is not one.
std::optional<double> metresPer(const std::string& unit) {
  const std::string u = lowerCase(unit);
  if (u == "mm" || u.empty()) return 1e-3;
  if (u == "m") return 1.0;
  if (u == "cm") return 1e-2;
  if (u == "um" || u == "micron" || u == "microns") return 1e-6;
  return std::nullopt;
}

// The layout of the samples.
struct Layout {
  int dimension = 3;
  std::vector<std::int64_t> sizes;
  std::array<int, 3> spatial{0, 1, 2};  // the file axes that are i, j and k
  int layers = 1;
  SampleType type = SampleType::UInt8;
  bool gzip = false;
  bool bigEndian = false;
};

// Which of the 4 axes holds no space: the axis whose space direction is "none", else the one
// whose kind is not a domain kind, else an axis of size 1 (the last first); nullopt when none
// is marked.
std::optional<int> nonSpatialAxis(const Fields& fields, const std::vector<std::int64_t>& sizes) {
  if (fields.find("space directions") != nullptr) {
    const auto vectors = parseVectors(fields, "space directions", 4);
    int axis = -1;
    for (int a = 0; a < 4; ++a) {
      if (vectors[static_cast<std::size_t>(a)]) continue;
      if (axis >= 0) fields.fail("space directions", "two axes are 'none' (one is allowed)");
      axis = a;
    }
    if (axis < 0) fields.fail("space directions", "4 axes with a space direction (3 are allowed)");
    return axis;
  }
  if (fields.find("kinds") != nullptr) {
    int axis = -1;
    int count = 0;
    const auto kinds = fields.perAxis("kinds", 4);
    for (int a = 0; a < 4; ++a) {
      const std::string k = lowerCase(kinds[static_cast<std::size_t>(a)]);
      if (k != "domain" && k != "space") {
        axis = a;
        ++count;
      }
    }
    if (count == 1) return axis;
  }
  if (sizes[3] == 1) return 3;
  if (sizes[0] == 1) return 0;
  return std::nullopt;
}

Layout readLayout(const Fields& fields, const std::string& what) {
  Layout layout;
  (void)fields.required("dimension");
  const std::int64_t dimension = fields.integer("dimension", 0, 1);
  if (dimension != 3 && dimension != 4)
    fields.fail("dimension", std::to_string(dimension) +
                                 "-D data: label volumes are 3-D (4-D for the layers of a "
                                 "segmentation)");
  layout.dimension = static_cast<int>(dimension);
  const auto n = static_cast<std::size_t>(dimension);
  for (const std::string_view t : fields.perAxis("sizes", n)) {
    const std::optional<std::int64_t> size = parseInteger(t);
    if (!size) fields.fail("sizes", "'" + escaped(t) + "' is not an integer");
    if (*size <= 0) fields.fail("sizes", "size " + std::to_string(*size) + " must be positive");
    if (*size > INT_MAX) fields.fail("sizes", "size " + std::to_string(*size) + " is too large");
    layout.sizes.push_back(*size);
  }
  if (dimension == 4) {
    const std::optional<int> marked = nonSpatialAxis(fields, layout.sizes);
    if (!marked)
      throw InputError(what +
                       ": 4-D data with no axis marked as layers (a 'none' space "
                       "direction, a 'list' kind or a size of 1)");
    const int axis = *marked;
    if (axis == 0) {
      layout.layers = static_cast<int>(layout.sizes[0]);
    } else if (layout.sizes[static_cast<std::size_t>(axis)] != 1) {
      throw InputError(what + ": 4-D data whose axis " + std::to_string(axis) + " holds " +
                       std::to_string(layout.sizes[static_cast<std::size_t>(axis)]) +
                       " samples (a time series or vector image?); only segmentations with "
                       "layers along the first axis are read");
    }
    int k = 0;
    for (int a = 0; a < 4; ++a)
      if (a != axis) layout.spatial[static_cast<std::size_t>(k++)] = a;
  }

  const Field& type = fields.required("type");
  if (lowerCase(trimmed(type.value)) == "block")
    fields.fail("type", "type 'block' is not supported (label volumes hold integers)");
  const std::optional<SampleType> sample = sampleTypeOf(type.value);
  if (!sample) fields.fail("type", "unknown type " + fields.quoted("type"));
  layout.type = *sample;

  const std::string encoding = lowerCase(trimmed(fields.required("encoding").value));
  if (encoding == "gzip" || encoding == "gz")
    layout.gzip = true;
  else if (encoding != "raw")
    fields.fail("encoding",
                "encoding " + fields.quoted("encoding") + " is not supported (raw and gzip are)");

  // A stated byte order must be valid even where one-byte samples do not need it.
  const Field* endian = fields.find("endian");
  if (endian != nullptr) {
    const std::string e = lowerCase(trimmed(endian->value));
    if (e != "little" && e != "big")
      fields.fail("endian", fields.quoted("endian") + " is neither 'little' nor 'big'");
    layout.bigEndian = e == "big";
  } else if (sampleBytes(layout.type) > 1) {
    throw InputError(what + ": field 'endian' is missing (it is needed for " +
                     sampleTypeName(layout.type) + " data)");
  }
  return layout;
}

struct Placement {
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // columns: file space, file units
  Vec3d origin = Vec3d::Zero();
  Vec3d sign = Vec3d::Ones();            // per world axis: -1 where the file's space is flipped
  Vec3d metres = Vec3d::Constant(1e-3);  // per world axis: metres per file unit
  std::string text;
};

Placement readPlacement(const Fields& fields, const Layout& layout,
                        std::vector<std::string>& warnings) {
  Placement p;
  const auto n = static_cast<std::size_t>(layout.dimension);
  std::string space;
  if (const Field* f = fields.find("space")) {
    const std::string name = lowerCase(trimmed(f->value));
    if (name == "right-anterior-superior" || name == "ras") {
      space = "space right-anterior-superior";
    } else if (name == "left-posterior-superior" || name == "lps") {
      p.sign = Vec3d(-1, -1, 1);
      space = "space left-posterior-superior, converted to RAS";
    } else if (name == "left-anterior-superior" || name == "las") {
      p.sign = Vec3d(-1, 1, 1);
      space = "space left-anterior-superior, converted to RAS";
    } else if (name == "scanner-xyz" || name == "3d-right-handed") {
      space = "space " + std::string(trimmed(f->value)) + ", taken as RAS";
    } else {
      fields.fail("space", "space " + fields.quoted("space") +
                               " is not supported (RAS, LPS, LAS, scanner-xyz or "
                               "3D-right-handed)");
    }
  }
  if (fields.find("space dimension") != nullptr) {
    if (fields.integer("space dimension", 3, 1) != 3)
      fields.fail("space dimension", "only 3-D spaces are supported");
    if (space.empty()) space = "space dimension 3 (no named space), taken as RAS";
  }
  if (fields.find("space units") != nullptr) {
    const std::vector<std::string> units = parseQuoted(fields, "space units", 3);
    for (int c = 0; c < 3; ++c) {
      const std::optional<double> m = metresPer(units[static_cast<std::size_t>(c)]);
      if (!m)
        fields.fail("space units", "unit '" + escaped(units[static_cast<std::size_t>(c)]) +
                                       "' is not supported (m, cm, mm, um)");
      p.metres[c] = *m;
    }
  }

  if (fields.find("space directions") != nullptr) {
    const auto vectors = parseVectors(fields, "space directions", n);
    for (int a = 0; a < 3; ++a) {
      const auto& v =
          vectors[static_cast<std::size_t>(layout.spatial[static_cast<std::size_t>(a)])];
      if (!v)
        fields.fail("space directions",
                    "axis " + std::to_string(layout.spatial[static_cast<std::size_t>(a)]) +
                        " of the volume has no direction ('none')");
      p.axes.col(a) = *v;
    }
    p.text = space.empty() ? "space directions with no space field, taken as RAS" : space;
  } else {
    if (fields.find("spacings") != nullptr) {
      const auto spacings = fields.perAxis("spacings", n);
      for (int a = 0; a < 3; ++a) {
        const std::string_view t =
            spacings[static_cast<std::size_t>(layout.spatial[static_cast<std::size_t>(a)])];
        const std::optional<double> s = parseNumber(t);
        if (!s || !std::isfinite(*s) || *s <= 0)
          fields.fail("spacings", "spacing '" + escaped(t) + "' must be a positive finite number");
        p.axes(a, a) = *s;
      }
      p.text = "spacings only (no space directions)";
    } else {
      warnings.push_back("no space directions or spacings: 1 mm voxels assumed");
      p.text = "no space directions or spacings (1 mm voxels)";
    }
    if (!space.empty()) p.text += ", " + space;
  }
  if (fields.find("space origin") != nullptr) {
    const auto origin = parseVectors(fields, "space origin", 1);
    if (!origin[0]) fields.fail("space origin", "the origin is 'none'");
    p.origin = *origin[0];
  }
  if (fields.find("space units") != nullptr && p.metres != Vec3d::Constant(1e-3))
    p.text += " (space units converted to metres)";
  return p;
}

// The samples of `blob` (attached data, or a data file read whole) after the line and byte
// skips: raw, exactly `needed` bytes; gzip, inflated into `storage`.
std::string_view samplesIn(std::string_view blob, const std::string& blobWhat, const Layout& layout,
                           std::int64_t lineSkip, std::int64_t byteSkip, std::size_t needed,
                           std::string& storage) {
  std::size_t pos = 0;
  const auto shortMessage = [&](std::size_t held) {
    return blobWhat + ": the data hold " + std::to_string(held) + " bytes, fewer than the " +
           std::to_string(needed) + " the header declares";
  };
  if (byteSkip >= 0 || layout.gzip) {
    for (std::int64_t l = 0; l < lineSkip; ++l) {
      const std::size_t end = blob.find('\n', pos);
      if (end == std::string_view::npos)
        throw InputError(blobWhat + ": line skip " + std::to_string(lineSkip) +
                         " passes the end of the data");
      pos = end + 1;
    }
  }
  if (layout.gzip) {
    const auto skip = static_cast<std::size_t>(byteSkip);
    storage = inflateExactly(blob.substr(pos), needed + skip, blobWhat);
    return std::string_view(storage).substr(skip);
  }
  if (byteSkip < 0) {  // the samples end the data
    if (blob.size() < needed) throw InputError(shortMessage(blob.size()));
    return blob.substr(blob.size() - needed);
  }
  const auto skip = static_cast<std::size_t>(byteSkip);
  if (skip > blob.size() - pos)
    throw InputError(blobWhat + ": byte skip " + std::to_string(skip) +
                     " passes the end of the data");
  pos += skip;
  const std::size_t held = blob.size() - pos;
  if (held < needed) throw InputError(shortMessage(held));
  if (held > needed)
    throw InputError(blobWhat + ": the data hold " + std::to_string(held) +
                     " bytes, more than the " + std::to_string(needed) +
                     " the header declares (do the sizes or the type lie?)");
  return blob.substr(pos);
}

}  // namespace

LabelVolume readNrrd(std::string_view bytes, const std::string& folder, const std::string& what,
                     const VolumeReadParams& params) {
  std::vector<std::string> warnings;
  const Header header = parseHeader(bytes, what, warnings);
  const Fields fields(header, what);
  const Layout layout = readLayout(fields, what);
  const Placement placement = readPlacement(fields, layout, warnings);

  const std::int64_t lineSkip = fields.integer("line skip", 0, 0);
  const std::int64_t byteSkip = fields.integer("byte skip", 0, -1);
  if (layout.gzip && byteSkip < 0)
    fields.fail("byte skip", "byte skip -1 (data at the end) is only allowed with raw encoding");
  if (layout.gzip && byteSkip > kMaxGzipByteSkip)
    fields.fail("byte skip", "byte skip " + std::to_string(byteSkip) +
                                 " into gzip data is over the 1 MiB allowed");
  std::string dataFile;
  if (const Field* f = fields.find("data file")) {
    const std::vector<std::string_view> t = tokensOf(f->value);
    if (!t.empty() && t[0] == "LIST")
      fields.fail("data file", "lists of data files (LIST) are not supported");
    if (t.size() >= 4 && t[0].find('%') != std::string_view::npos)
      fields.fail("data file",
                  "numbered data files ('" + escaped(t[0]) + " min max step') are not supported");
    dataFile = f->value;
  }

  LabelVolume volume;
  volume.dims = {static_cast<int>(layout.sizes[static_cast<std::size_t>(layout.spatial[0])]),
                 static_cast<int>(layout.sizes[static_cast<std::size_t>(layout.spatial[1])]),
                 static_cast<int>(layout.sizes[static_cast<std::size_t>(layout.spatial[2])])};
  const std::size_t count =
      checkVolumeSize(what, volume.dims.x, volume.dims.y, volume.dims.z, layout.layers,
                      sampleBytes(layout.type), params.maxMemory);
  const std::size_t needed = count * sampleBytes(layout.type);

  // The samples: a view into the file's bytes, or into `storage` (a data file, inflated data).
  std::string storage;
  std::string fileBytes;
  std::string_view samples;
  if (!dataFile.empty()) {
    const std::string path = resolveDataFile(folder, dataFile, what);
    const std::string fileWhat = what + ": data file '" + escaped(dataFile) + "'";
    if (!layout.gzip && lineSkip == 0) {
      // Raw: the size says everything; read only the samples.
      const std::size_t size = regularFileSize(path, fileWhat);
      std::size_t offset = size >= needed ? size - needed : 0;
      if (byteSkip >= 0) {
        offset = static_cast<std::size_t>(byteSkip);
        if (offset > size || size - offset < needed)
          throw InputError(fileWhat + ": holds " + std::to_string(size) +
                           " bytes, fewer than the " + std::to_string(offset) + " + " +
                           std::to_string(needed) + " the header declares");
        if (size - offset > needed)
          throw InputError(fileWhat + ": holds " + std::to_string(size) + " bytes, more than the " +
                           std::to_string(offset) + " + " + std::to_string(needed) +
                           " the header declares (do the sizes or the type lie?)");
      } else if (size < needed) {
        throw InputError(fileWhat + ": holds " + std::to_string(size) + " bytes, fewer than the " +
                         std::to_string(needed) + " the header declares");
      }
      storage = readFileRange(path, fileWhat, offset, needed);
      samples = storage;
    } else {
      fileBytes =
          readWholeFile(path, fileWhat, params.maxMemory ? params.maxMemory + kDataFileSlack : 0);
      samples = samplesIn(fileBytes, fileWhat, layout, lineSkip, byteSkip, needed, storage);
    }
  } else {
    if (header.dataStart == std::string_view::npos)
      throw InputError(what +
                       ": the header has no empty line before the data, and names no "
                       "data file");
    samples = samplesIn(bytes.substr(header.dataStart), what, layout, lineSkip, byteSkip, needed,
                        storage);
  }

  const std::vector<Segment> segments =
      parseSegments(header.keyValues, layout.layers, what, warnings);
  if (layout.layers == 1) {
    setLabelsFromSamples(volume, samples.data(), count, layout.type, layout.bigEndian, what);
    nameLabels(volume, segments);
  } else {
    setLabelsFromLayers(volume, samples.data(), layout.layers, layout.type, layout.bigEndian,
                        segments, what);
  }

  // World axis c of the file's space, in its units, is sign[c] * metres[c] metres of RAS.
  const Vec3d scale = placement.sign.cwiseProduct(placement.metres);
  volume.axes = scale.asDiagonal() * placement.axes;
  volume.origin = scale.cwiseProduct(placement.origin);
  volume.placement = placement.text;
  volume.warnings.insert(volume.warnings.begin(), warnings.begin(), warnings.end());
  checkLabelVolumePlacement(volume, what);
  return volume;
}

}  // namespace voxcut::volumeio
