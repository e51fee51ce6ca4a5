#pragma once
/// @file VolumeFiles.h
/// Label volumes written by hand for the NRRD and MetaImage reader tests: a labelled sphere
/// and a small box in a grid, their samples in any type and byte order, gzip and zlib streams
/// (through zlib), and the headers of both formats, so that the readers are tested against
/// files they did not write.

#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/voxel/LabelVolume.h"

namespace voxcut::test {

/// Labels of a grid, i fastest: value per voxel (0 background).
struct LabelGrid {
  Index3 dims;
  std::vector<std::int64_t> values;
  [[nodiscard]] std::size_t linear(int i, int j, int k) const {
    return static_cast<std::size_t>(i + dims.x * (j + dims.y * k));
  }
};

/// The sphere's centre (voxel indices) and radius (voxels) in sphereAndBox.
inline const Vec3d kSphereCentre(8, 8, 7);
inline constexpr double kSphereRadius = 6.0;

/// A 20 x 18 x 16 grid holding a sphere of `sphere` (radius 6 voxels about kSphereCentre, so
/// that the mean index of its voxels is the centre exactly) and the box [16,18] x [1,3] x [1,4]
/// of `box`.
inline LabelGrid sphereAndBox(std::int64_t sphere = 1, std::int64_t box = 2) {
  LabelGrid g{{20, 18, 16}, {}};
  g.values.assign(static_cast<std::size_t>(g.dims.x * g.dims.y * g.dims.z), 0);
  for (int k = 0; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i) {
        if ((Vec3d(i, j, k) - kSphereCentre).norm() <= kSphereRadius)
          g.values[g.linear(i, j, k)] = sphere;
        if (i >= 16 && i <= 18 && j >= 1 && j <= 3 && k >= 1 && k <= 4)
          g.values[g.linear(i, j, k)] = box;
      }
  return g;
}

/// Voxels of `grid` holding `value`.
inline std::size_t countOf(const LabelGrid& grid, std::int64_t value) {
  return static_cast<std::size_t>(std::count(grid.values.begin(), grid.values.end(), value));
}

template <class T>
void appendSample(std::string& out, T value, bool bigEndian) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // the test machines are little-endian
  if (bigEndian) std::reverse(bytes, bytes + sizeof(T));
  out.append(bytes, sizeof(T));
}

/// `values` as samples of `type` in the given byte order.
inline std::string samplesOf(const std::vector<double>& values, SampleType type, bool bigEndian) {
  std::string out;
  for (const double v : values) {
    switch (type) {
      case SampleType::Int8:
        appendSample(out, static_cast<std::int8_t>(v), bigEndian);
        break;
      case SampleType::UInt8:
        appendSample(out, static_cast<std::uint8_t>(v), bigEndian);
        break;
      case SampleType::Int16:
        appendSample(out, static_cast<std::int16_t>(v), bigEndian);
        break;
      case SampleType::UInt16:
        appendSample(out, static_cast<std::uint16_t>(v), bigEndian);
        break;
      case SampleType::Int32:
        appendSample(out, static_cast<std::int32_t>(v), bigEndian);
        break;
      case SampleType::UInt32:
        appendSample(out, static_cast<std::uint32_t>(v), bigEndian);
        break;
      case SampleType::Int64:
        appendSample(out, static_cast<std::int64_t>(v), bigEndian);
        break;
      case SampleType::UInt64:
        appendSample(out, static_cast<std::uint64_t>(v), bigEndian);
        break;
      case SampleType::Float32:
        appendSample(out, static_cast<float>(v), bigEndian);
        break;
      case SampleType::Float64:
        appendSample(out, v, bigEndian);
        break;
    }
  }
  return out;
}

/// The labels of `grid` as samples of `type`.
inline std::string samplesOf(const LabelGrid& grid, SampleType type, bool bigEndian) {
  return samplesOf(std::vector<double>(grid.values.begin(), grid.values.end()), type, bigEndian);
}

/// `data` compressed as a gzip stream (windowBits 15 + 16) or a zlib stream.
inline std::string deflated(std::string_view data, bool gzip) {
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, 6, Z_DEFLATED, gzip ? 15 + 16 : 15, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&zs, static_cast<uLong>(data.size())) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

/// A NRRD header: magic, type, dimension, sizes, encoding, endian, the `extra` lines as they
/// are, and the empty line that ends it.
struct NrrdHeader {
  std::string type = "uint8";
  std::string sizes = "20 18 16";
  int dimension = 3;
  std::string encoding = "raw";
  std::string endian = "little";
  std::vector<std::string> extra;

  [[nodiscard]] std::string text() const {
    std::string s = "NRRD0004\n# written by the voxcut tests\ntype: " + type +
                    "\ndimension: " + std::to_string(dimension) + "\nsizes: " + sizes +
                    "\nencoding: " + encoding + "\n";
    if (!endian.empty()) s += "endian: " + endian + "\n";
    for (const std::string& line : extra) s += line + "\n";
    return s + "\n";
  }
};

/// A MetaImage header ending with its ElementDataFile line.
struct MetaHeader {
  std::string elementType = "MET_UCHAR";
  std::string dimSize = "20 18 16";
  int ndims = 3;
  bool msb = false;
  bool compressed = false;
  std::vector<std::string> extra;
  std::string dataFile = "LOCAL";

  [[nodiscard]] std::string text() const {
    std::string s = "ObjectType = Image\nNDims = " + std::to_string(ndims) +
                    "\nBinaryData = True\nBinaryDataByteOrderMSB = " + (msb ? "True" : "False") +
                    "\nCompressedData = " + (compressed ? "True" : "False") + "\n";
    for (const std::string& line : extra) s += line + "\n";
    return s + "DimSize = " + dimSize + "\nElementType = " + elementType +
           "\nElementDataFile = " + dataFile + "\n";
  }
};

/// Position in `volume.labels` of the label with `value`, or -1.
inline int labelIndex(const LabelVolume& volume, std::int64_t value) {
  for (std::size_t l = 0; l < volume.labels.size(); ++l)
    if (volume.labels[l].value == value) return static_cast<int>(l);
  return -1;
}

/// The value of the label of voxel (i, j, k), 0 for background.
inline std::int64_t valueAt(const LabelVolume& volume, int i, int j, int k) {
  const std::uint16_t slot = volume.index[volume.linear(i, j, k)];
  return slot == 0 ? 0 : volume.labels[slot - 1u].value;
}

/// Voxels of the label with `value`.
inline std::size_t voxelsOf(const LabelVolume& volume, std::int64_t value) {
  const int l = labelIndex(volume, value);
  return l < 0 ? 0 : volume.labelCounts()[static_cast<std::size_t>(l)];
}

/// World centroid (metres, RAS) of the voxels of the label with `value`: the mean of
/// origin + axes * ijk over them.
inline Vec3d worldCentroid(const LabelVolume& volume, std::int64_t value) {
  const int l = labelIndex(volume, value);
  Vec3d sum = Vec3d::Zero();
  std::size_t n = 0;
  for (int k = 0; k < volume.dims.z; ++k)
    for (int j = 0; j < volume.dims.y; ++j)
      for (int i = 0; i < volume.dims.x; ++i)
        if (l >= 0 && volume.index[volume.linear(i, j, k)] == l + 1) {
          sum += volume.world(Vec3d(i, j, k));
          ++n;
        }
  return n == 0 ? Vec3d::Constant(std::nan("")) : Vec3d(sum / static_cast<double>(n));
}

/// Every character of `message` is printable ASCII (no raw control or high bytes).
inline bool isPrintable(const std::string& message) {
  return std::all_of(message.begin(), message.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u >= 0x20 && u < 0x7f;
  });
}

}  // namespace voxcut::test
