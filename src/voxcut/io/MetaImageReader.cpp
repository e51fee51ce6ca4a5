// The MetaImage reader (ITK's MetaIO format: .mha with the data after the header, .mhd with a
// detached data file), for 3-D label volumes. The rules it chose where the format leaves room
// are stated at readMetaImage in VolumeFormats.h.
//
// Orientation. MetaIO's TransformMatrix (alias Rotation, Orientation) holds NDims x NDims
// numbers; numbers a*NDims .. a*NDims + NDims-1 are the direction of index axis a. ITK reads
// them so: itkMetaImageIO.cxx, MetaImageIO::ReadImageInformation, sets
// `directionAxis[jj] = transformMatrix[ii * nDims + jj]` and then `SetDirection(ii,
// directionAxis)`, i.e. the ii-th run of numbers is the direction of axis ii (a column of
// itk::Image's direction matrix; the file lists that matrix transposed, row by row). A point's
// physical position is Offset + sum_a direction_a * ElementSpacing_a * index_a, in ITK's
// physical space: LPS, millimetres.

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
#include "voxcut/io/VolumeData.h"
#include "voxcut/io/VolumeFormats.h"

namespace voxcut::volumeio {
namespace {

// A data file read whole (compressed data) is bounded like an attached file: its samples
// plus this much.
constexpr std::size_t kDataFileSlack = std::size_t{64} << 20;

struct Entry {
  std::string key;  // as the file spells it
  std::string value;
  std::size_t line = 0;
};

struct MetaHeader {
  std::map<std::string, Entry, std::less<>> entries;  // by lower-case key
  std::size_t dataStart = 0;                          // after the ElementDataFile line
};

MetaHeader parseHeader(std::string_view bytes, const std::string& what) {
  MetaHeader h;
  std::size_t pos = 0;
  std::size_t lineNumber = 0;
  while (const std::optional<std::string_view> line = nextHeaderLine(bytes, pos)) {
    ++lineNumber;
    if (trimmed(*line).empty()) continue;
    const std::string at = "header line " + std::to_string(lineNumber);
    const std::size_t eq = line->find('=');
    const std::string_view key = trimmed(line->substr(0, eq));
    if (eq == std::string_view::npos || key.empty())
      throw InputError(what + ": " + at + " '" + escaped(*line) + "' is not 'Key = Value'" +
                       (lineNumber == 1 ? " (is this a MetaImage file?)" : ""));
    const std::string lower = lowerCase(key);
    const Entry entry{std::string(key), std::string(trimmed(line->substr(eq + 1))), lineNumber};
    if (!h.entries.emplace(lower, entry).second)
      throw InputError(what + ": key '" + escaped(key) + "' (" + at + ") is given twice");
    if (lower == "elementdatafile") {
      h.dataStart = pos;
      return h;
    }
  }
  throw InputError(what + ": the header has no ElementDataFile line (which ends it)");
}

// Reads the values of one header, naming the keys in messages.
class Keys {
 public:
  Keys(const MetaHeader& h, const std::string& what) : h_(h), what_(what) {}

  // The first of `names` (lower case) the header has.
  [[nodiscard]] const Entry* find(std::initializer_list<std::string_view> names) const {
    for (const std::string_view name : names) {
      const auto it = h_.entries.find(name);
      if (it != h_.entries.end()) return &it->second;
    }
    return nullptr;
  }
  [[nodiscard]] const Entry& required(std::string_view name, std::string_view spelled) const {
    const Entry* e = find({name});
    if (e == nullptr) throw InputError(what_ + ": key '" + std::string(spelled) + "' is missing");
    return *e;
  }
  [[noreturn]] void fail(const Entry& e, const std::string& message) const {
    throw InputError(what_ + ": key '" + escaped(e.key) + "' (header line " +
                     std::to_string(e.line) + "): " + message);
  }
  [[nodiscard]] static std::string quoted(const Entry& e) { return "'" + escaped(e.value) + "'"; }

  [[nodiscard]] std::int64_t integer(const Entry& e) const {
    const std::optional<std::int64_t> v = meshio::parseInteger(e.value);
    if (!v) fail(e, quoted(e) + " is not an integer");
    return *v;
  }
  [[nodiscard]] bool boolean(std::initializer_list<std::string_view> names, bool fallback) const {
    const Entry* e = find(names);
    if (e == nullptr) return fallback;
    const std::string v = lowerCase(e->value);
    if (v == "true" || v == "1") return true;
    if (v == "false" || v == "0") return false;
    fail(*e, quoted(*e) + " is neither True nor False");
  }
  // Exactly `count` numbers, each finite.
  [[nodiscard]] std::vector<double> numbers(const Entry& e, std::size_t count) const {
    std::vector<std::string_view> tokens;
    meshio::splitTokens(e.value, tokens);
    if (tokens.size() != count)
      fail(e, std::to_string(tokens.size()) + " values where " + std::to_string(count) +
                  " are needed");
    std::vector<double> out;
    for (const std::string_view t : tokens) {
      const std::optional<double> v = meshio::parseNumber(t);
      if (!v || !std::isfinite(*v)) fail(e, "'" + escaped(t) + "' is not a finite number");
      out.push_back(*v);
    }
    return out;
  }

 private:
  const MetaHeader& h_;
  const std::string& what_;
};

std::optional<SampleType> sampleTypeOf(const std::string& name) {
  // MetaIO's sizes (metaTypes.h, MET_ValueTypeSize): MET_LONG and MET_ULONG are 4 bytes.
  static const std::map<std::string, SampleType, std::less<>> kTypes = {
      {"MET_CHAR", SampleType::Int8},         {"MET_ASCII_CHAR", SampleType::Int8},
      {"MET_UCHAR", SampleType::UInt8},       {"MET_SHORT", SampleType::Int16},
      {"MET_USHORT", SampleType::UInt16},     {"MET_INT", SampleType::Int32},
      {"MET_UINT", SampleType::UInt32},       {"MET_LONG", SampleType::Int32},
      {"MET_ULONG", SampleType::UInt32},      {"MET_LONG_LONG", SampleType::Int64},
      {"MET_ULONG_LONG", SampleType::UInt64}, {"MET_FLOAT", SampleType::Float32},
      {"MET_DOUBLE", SampleType::Float64},
  };
  const auto it = kTypes.find(name);
  if (it == kTypes.end()) return std::nullopt;
  return it->second;
}

// Metres per DistanceUnits unit; nullopt for an unknown unit.
std::optional<double> metresPer(const std::string& unit) {
  const std::string u = lowerCase(unit);
  if (u == "mm" || u == "?" || u.empty()) return 1e-3;
  if (u == "m") return 1.0;
  if (u == "cm") return 1e-2;
  if (u == "um") return 1e-6;
  return std::nullopt;
}

// The samples of compressed data `blob`: at most CompressedDataSize bytes of it, inflated.
std::string inflated(std::string_view blob, const Entry* compressedSize, const Keys& keys,
                     std::size_t needed, const std::string& blobWhat) {
  if (compressedSize != nullptr) {
    const std::int64_t size = keys.integer(*compressedSize);
    if (size < 0) keys.fail(*compressedSize, "must not be negative");
    if (static_cast<std::uint64_t>(size) > blob.size())
      keys.fail(*compressedSize, std::to_string(size) + " bytes, but the data hold only " +
                                     std::to_string(blob.size()));
    blob = blob.substr(0, static_cast<std::size_t>(size));
  }
  return inflateExactly(blob, needed, blobWhat);
}

}  // namespace

LabelVolume readMetaImage(std::string_view bytes, const std::string& folder,
                          const std::string& what, const VolumeReadParams& params) {
  const MetaHeader header = parseHeader(bytes, what);
  const Keys keys(header, what);
  std::vector<std::string> warnings;

  if (const Entry* e = keys.find({"objecttype"}); e && lowerCase(e->value) != "image")
    keys.fail(*e, "object type " + Keys::quoted(*e) + " is not Image");
  const Entry& ndimsEntry = keys.required("ndims", "NDims");
  const std::int64_t ndims = keys.integer(ndimsEntry);
  if (ndims != 3 && ndims != 4)
    keys.fail(ndimsEntry, std::to_string(ndims) + "-D data: label volumes are 3-D");
  const auto n = static_cast<std::size_t>(ndims);

  const Entry& dimEntry = keys.required("dimsize", "DimSize");
  std::vector<std::string_view> dimTokens;
  meshio::splitTokens(dimEntry.value, dimTokens);
  if (dimTokens.size() != n)
    keys.fail(dimEntry,
              std::to_string(dimTokens.size()) + " sizes for NDims " + std::to_string(ndims));
  std::array<std::int64_t, 4> dims{1, 1, 1, 1};
  for (std::size_t a = 0; a < n; ++a) {
    const std::optional<std::int64_t> d = meshio::parseInteger(dimTokens[a]);
    if (!d) keys.fail(dimEntry, "'" + escaped(dimTokens[a]) + "' is not an integer");
    if (*d <= 0) keys.fail(dimEntry, "size " + std::to_string(*d) + " must be positive");
    if (*d > INT_MAX) keys.fail(dimEntry, "size " + std::to_string(*d) + " is too large");
    dims[a] = *d;
  }
  if (dims[3] != 1)
    keys.fail(dimEntry, "the 4th dimension holds " + std::to_string(dims[3]) +
                            " samples (a time series?); only 3-D volumes are read");

  const Entry& typeEntry = keys.required("elementtype", "ElementType");
  const std::optional<SampleType> type = sampleTypeOf(typeEntry.value);
  if (!type)
    keys.fail(typeEntry, "element type " + Keys::quoted(typeEntry) +
                             " is not supported (integer or floating-point scalars)");
  if (const Entry* e = keys.find({"elementnumberofchannels"}); e && keys.integer(*e) != 1)
    keys.fail(*e, "images with several channels are not label volumes");
  if (!keys.boolean({"binarydata"}, true))
    keys.fail(*keys.find({"binarydata"}),
              "ASCII voxel data (BinaryData = False) are not "
              "supported");
  const bool bigEndian = keys.boolean({"binarydatabyteordermsb", "elementbyteordermsb"}, false);
  const bool compressed = keys.boolean({"compresseddata"}, false);
  const Entry* compressedSize = keys.find({"compresseddatasize"});

  // Placement, in ITK's LPS millimetres first.
  Eigen::Matrix3d lps = Eigen::Matrix3d::Identity();
  Vec3d spacing = Vec3d::Ones();
  if (const Entry* e = keys.find({"elementspacing", "elementsize"})) {
    const std::vector<double> s = keys.numbers(*e, n);
    for (int a = 0; a < 3; ++a) {
      if (!(s[static_cast<std::size_t>(a)] > 0))
        keys.fail(
            *e, "spacing " + std::to_string(s[static_cast<std::size_t>(a)]) + " must be positive");
      spacing[a] = s[static_cast<std::size_t>(a)];
    }
  } else {
    warnings.push_back("no ElementSpacing: 1 mm voxels assumed");
  }
  const Entry* matrixEntry = keys.find({"transformmatrix", "rotation", "orientation"});
  if (matrixEntry != nullptr) {
    const std::vector<double> m = keys.numbers(*matrixEntry, n * n);
    for (std::size_t a = 0; a < 3; ++a)
      for (std::size_t c = 0; c < 3; ++c)
        lps(static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(a)) = m[a * n + c];
  }
  Vec3d offset = Vec3d::Zero();
  if (const Entry* e = keys.find({"offset", "origin", "position"})) {
    const std::vector<double> o = keys.numbers(*e, n);
    offset = Vec3d(o[0], o[1], o[2]);
  }
  double metres = 1e-3;
  if (const Entry* e = keys.find({"distanceunits"})) {
    const std::optional<double> m = metresPer(e->value);
    if (!m) keys.fail(*e, "unit " + Keys::quoted(*e) + " is not supported (m, cm, mm, um)");
    metres = *m;
  }

  const Entry& dataEntry = keys.required("elementdatafile", "ElementDataFile");
  std::vector<std::string_view> dataTokens;
  meshio::splitTokens(dataEntry.value, dataTokens);
  const bool local = lowerCase(dataEntry.value) == "local";
  if (!dataTokens.empty() && lowerCase(dataTokens[0]) == "list")
    keys.fail(dataEntry, "lists of data files (LIST) are not supported");
  if (dataTokens.size() >= 4 && dataTokens[0].find('%') != std::string_view::npos)
    keys.fail(dataEntry, "numbered data files ('" + escaped(dataTokens[0]) +
                             " min max step') are not supported");
  if (dataEntry.value.empty()) keys.fail(dataEntry, "no data file named");

  LabelVolume volume;
  volume.dims = {static_cast<int>(dims[0]), static_cast<int>(dims[1]), static_cast<int>(dims[2])};
  const std::size_t count =
      checkVolumeSize(what, dims[0], dims[1], dims[2], 1, sampleBytes(*type), params.maxMemory);
  const std::size_t needed = count * sampleBytes(*type);

  std::string storage;
  std::string_view samples;
  if (local) {
    // HeaderSize is not used with LOCAL data: they start after the ElementDataFile line.
    const std::string_view blob = bytes.substr(header.dataStart);
    if (compressed) {
      storage = inflated(blob, compressedSize, keys, needed, what);
      samples = storage;
    } else if (blob.size() < needed) {
      throw InputError(what + ": the data hold " + std::to_string(blob.size()) +
                       " bytes, fewer than the " + std::to_string(needed) + " the header declares");
    } else if (blob.size() > needed) {
      throw InputError(what + ": the data hold " + std::to_string(blob.size()) +
                       " bytes, more than the " + std::to_string(needed) +
                       " the header declares (does DimSize or ElementType lie?)");
    } else {
      samples = blob;
    }
  } else {
    const std::string path = resolveDataFile(folder, dataEntry.value, what);
    const std::string fileWhat = what + ": data file '" + escaped(dataEntry.value) + "'";
    std::int64_t skip = 0;
    const Entry* headerSize = keys.find({"headersize"});
    if (headerSize != nullptr) {
      skip = keys.integer(*headerSize);
      if (skip < -1) keys.fail(*headerSize, "must be -1 (data at the end) or more");
    }
    if (compressed) {
      if (skip < 0) keys.fail(*headerSize, "HeaderSize -1 is not allowed with compressed data");
      const std::string fileBytes =
          readWholeFile(path, fileWhat, params.maxMemory ? params.maxMemory + kDataFileSlack : 0);
      if (static_cast<std::uint64_t>(skip) > fileBytes.size())
        keys.fail(*headerSize, "skips past the end of the " + std::to_string(fileBytes.size()) +
                                   "-byte data file");
      storage = inflated(std::string_view(fileBytes).substr(static_cast<std::size_t>(skip)),
                         compressedSize, keys, needed, fileWhat);
    } else {
      const std::size_t size = regularFileSize(path, fileWhat);
      std::size_t start = size >= needed ? size - needed : 0;
      if (skip >= 0) start = static_cast<std::size_t>(skip);
      if (start > size || size - start < needed)
        throw InputError(fileWhat + ": holds " + std::to_string(size) + " bytes, fewer than the " +
                         std::to_string(skip >= 0 ? start : 0) + " + " + std::to_string(needed) +
                         " the header declares");
      if (size - start > needed)
        throw InputError(fileWhat + ": holds " + std::to_string(size) + " bytes, more than the " +
                         std::to_string(start) + " + " + std::to_string(needed) +
                         " the header declares (does DimSize or ElementType lie?)");
      storage = readFileRange(path, fileWhat, start, needed);
    }
    samples = storage;
  }

  setLabelsFromSamples(volume, samples.data(), count, *type, bigEndian, what);

  // LPS millimetres to RAS metres: negate x and y, scale.
  for (int a = 0; a < 3; ++a) lps.col(a) *= spacing[a];
  const Vec3d toRas = Vec3d(-1, -1, 1) * metres;
  volume.axes = toRas.asDiagonal() * lps;
  volume.origin = toRas.cwiseProduct(offset);
  volume.placement = std::string("MetaImage LPS space, converted to RAS") +
                     (matrixEntry ? " (with TransformMatrix)" : " (no TransformMatrix)");
  if (const Entry* e = keys.find({"anatomicalorientation"}))
    volume.placement += ", AnatomicalOrientation '" + escaped(e->value, 20) + "' (informational)";
  volume.warnings.insert(volume.warnings.begin(), warnings.begin(), warnings.end());
  checkLabelVolumePlacement(volume, what);
  return volume;
}

}  // namespace voxcut::volumeio
