#pragma once
/// @file NiftiFiles.h
/// NIfTI-1 and NIfTI-2 files written by hand, byte by byte from the layouts in nifti1.h and
/// nifti2.h (not through nifticlib), so that the reader is tested against files it did not
/// write; plus gzip compression for .nii.gz, and the labelled sphere the tests place.

#include <zlib.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace voxcut::test {

/// NIfTI datatype codes (nifti1.h, NIFTI_TYPE_*).
enum NiftiType : int {
  kNiftiUInt8 = 2,
  kNiftiInt16 = 4,
  kNiftiInt32 = 8,
  kNiftiFloat32 = 16,
  kNiftiComplex64 = 32,
  kNiftiFloat64 = 64,
  kNiftiRgb24 = 128,
  kNiftiInt8 = 256,
  kNiftiUInt16 = 512,
  kNiftiUInt32 = 768,
  kNiftiInt64 = 1024,
  kNiftiUInt64 = 1280,
};

/// Bytes per sample of the label datatypes (and of complex64 and RGB24).
inline int niftiTypeBytes(int datatype) {
  switch (datatype) {
    case kNiftiInt8:
    case kNiftiUInt8:
      return 1;
    case kNiftiInt16:
    case kNiftiUInt16:
      return 2;
    case kNiftiRgb24:
      return 3;
    case kNiftiInt32:
    case kNiftiUInt32:
    case kNiftiFloat32:
      return 4;
    default:
      return 8;
  }
}

/// What a hand-made file holds: the header fields the reader looks at, by their nifti1.h
/// names, and the voxel bytes. NIfTI-1 stores the floating-point fields as float32.
struct NiftiSpec {
  int version = 1;         ///< 1 (348-byte header) or 2 (540-byte header)
  bool bigEndian = false;  ///< byte order of the header and the data
  std::array<std::int64_t, 8> dim = {3, 1, 1, 1, 1, 1, 1, 1};
  std::array<double, 8> pixdim = {1, 1, 1, 1, 0, 0, 0, 0};  ///< pixdim[0] is qfac
  int datatype = kNiftiUInt8;
  double voxOffset = -1;  ///< -1: 352 (NIfTI-1) or 544 (NIfTI-2)
  double sclSlope = 0;
  double sclInter = 0;
  int qformCode = 0;
  int sformCode = 0;
  std::array<double, 6> quatern{};  ///< quatern_b, c, d, qoffset_x, y, z
  std::array<std::array<double, 4>, 3> srow{};
  int xyztUnits = 2;  ///< NIFTI_UNITS_MM
  std::string magic;  ///< empty: "n+1\0" or "n+2\0\r\n\x1a\n"
  std::string data;   ///< the voxel bytes as stored (in the file's byte order)
};

/// Writes `value` at `offset` of `out` in the given byte order.
template <class T>
void putAt(std::string& out, std::size_t offset, T value, bool bigEndian) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // the test machines are little-endian
  if (bigEndian)
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  out.replace(offset, sizeof(T), bytes, sizeof(T));
}

/// The file `spec` describes: header, 4-byte extender (zero: no extensions), padding up to
/// vox_offset, data.
inline std::string niftiBytes(const NiftiSpec& s) {
  const bool be = s.bigEndian;
  std::string h;
  if (s.version == 1) {
    h.assign(348, '\0');
    putAt(h, 0, std::int32_t{348}, be);
    for (int a = 0; a < 8; ++a)
      putAt(h, 40 + 2 * static_cast<std::size_t>(a), static_cast<std::int16_t>(s.dim[a]), be);
    putAt(h, 70, static_cast<std::int16_t>(s.datatype), be);
    putAt(h, 72, static_cast<std::int16_t>(8 * niftiTypeBytes(s.datatype)), be);
    for (int a = 0; a < 8; ++a)
      putAt(h, 76 + 4 * static_cast<std::size_t>(a), static_cast<float>(s.pixdim[a]), be);
    putAt(h, 108, static_cast<float>(s.voxOffset < 0 ? 352 : s.voxOffset), be);
    putAt(h, 112, static_cast<float>(s.sclSlope), be);
    putAt(h, 116, static_cast<float>(s.sclInter), be);
    h[123] = static_cast<char>(s.xyztUnits);
    std::memcpy(h.data() + 148, "voxcut test", 11);  // descrip
    putAt(h, 252, static_cast<std::int16_t>(s.qformCode), be);
    putAt(h, 254, static_cast<std::int16_t>(s.sformCode), be);
    for (int q = 0; q < 6; ++q)
      putAt(h, 256 + 4 * static_cast<std::size_t>(q), static_cast<float>(s.quatern[q]), be);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        putAt(h, 280 + 16 * static_cast<std::size_t>(r) + 4 * static_cast<std::size_t>(c),
              static_cast<float>(s.srow[r][c]), be);
    const std::string magic = s.magic.empty() ? std::string("n+1\0", 4) : s.magic;
    h.replace(344, magic.size(), magic);
  } else {
    h.assign(540, '\0');
    putAt(h, 0, std::int32_t{540}, be);
    const std::string magic = s.magic.empty() ? std::string("n+2\0\r\n\x1a\n", 8) : s.magic;
    h.replace(4, magic.size(), magic);
    putAt(h, 12, static_cast<std::int16_t>(s.datatype), be);
    putAt(h, 14, static_cast<std::int16_t>(8 * niftiTypeBytes(s.datatype)), be);
    for (int a = 0; a < 8; ++a) putAt(h, 16 + 8 * static_cast<std::size_t>(a), s.dim[a], be);
    for (int a = 0; a < 8; ++a) putAt(h, 104 + 8 * static_cast<std::size_t>(a), s.pixdim[a], be);
    putAt(h, 168, static_cast<std::int64_t>(s.voxOffset < 0 ? 544 : s.voxOffset), be);
    putAt(h, 176, s.sclSlope, be);
    putAt(h, 184, s.sclInter, be);
    std::memcpy(h.data() + 240, "voxcut test", 11);  // descrip
    putAt(h, 344, std::int32_t{s.qformCode}, be);
    putAt(h, 348, std::int32_t{s.sformCode}, be);
    for (int q = 0; q < 6; ++q) putAt(h, 352 + 8 * static_cast<std::size_t>(q), s.quatern[q], be);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        putAt(h, 400 + 32 * static_cast<std::size_t>(r) + 8 * static_cast<std::size_t>(c),
              s.srow[r][c], be);
    putAt(h, 500, std::int32_t{s.xyztUnits}, be);
  }
  // The data start at vox_offset, or where they normally do when vox_offset lies inside the
  // header (files made to be refused).
  const std::size_t standard = s.version == 1 ? 352 : 544;
  const std::size_t declared = s.voxOffset < 0 ? standard : static_cast<std::size_t>(s.voxOffset);
  h.resize(declared >= h.size() ? declared : standard, '\0');  // extender of zeros
  return h + s.data;
}

/// `bytes` compressed as one gzip member.
inline std::string gzipped(std::string_view bytes) {
  z_stream zs{};
  if (deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("deflateInit2");
  std::string out(deflateBound(&zs, static_cast<uLong>(bytes.size())) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  zs.avail_in = static_cast<uInt>(bytes.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  if (rc != Z_STREAM_END) throw std::runtime_error("deflate");
  return out;
}

/// `values` stored as `datatype` samples in the given byte order.
inline std::string niftiSamples(const std::vector<std::int64_t>& values, int datatype,
                                bool bigEndian) {
  std::string out(values.size() * static_cast<std::size_t>(niftiTypeBytes(datatype)), '\0');
  const std::size_t n = static_cast<std::size_t>(niftiTypeBytes(datatype));
  for (std::size_t k = 0; k < values.size(); ++k) {
    const std::int64_t v = values[k];
    switch (datatype) {
      case kNiftiInt8:
        putAt(out, k * n, static_cast<std::int8_t>(v), bigEndian);
        break;
      case kNiftiUInt8:
        putAt(out, k * n, static_cast<std::uint8_t>(v), bigEndian);
        break;
      case kNiftiInt16:
        putAt(out, k * n, static_cast<std::int16_t>(v), bigEndian);
        break;
      case kNiftiUInt16:
        putAt(out, k * n, static_cast<std::uint16_t>(v), bigEndian);
        break;
      case kNiftiInt32:
        putAt(out, k * n, static_cast<std::int32_t>(v), bigEndian);
        break;
      case kNiftiUInt32:
        putAt(out, k * n, static_cast<std::uint32_t>(v), bigEndian);
        break;
      case kNiftiInt64:
        putAt(out, k * n, v, bigEndian);
        break;
      case kNiftiUInt64:
        putAt(out, k * n, static_cast<std::uint64_t>(v), bigEndian);
        break;
      case kNiftiFloat32:
        putAt(out, k * n, static_cast<float>(v), bigEndian);
        break;
      case kNiftiFloat64:
        putAt(out, k * n, static_cast<double>(v), bigEndian);
        break;
      default:
        throw std::runtime_error("niftiSamples: not a label type");
    }
  }
  return out;
}

/// A labelled grid: a ball of `sphereLabel` of radius `radius` voxels around `centre` (voxel
/// indices), and a 2x2x2 block of `blockLabel` at voxels 1..2 on each axis; 0 elsewhere.
struct SphereGrid {
  std::array<std::int64_t, 3> dims{};
  std::vector<std::int64_t> values;  ///< per voxel i + nx*(j + ny*k)
};

inline SphereGrid sphereGrid(std::array<std::int64_t, 3> dims, std::array<double, 3> centre,
                             double radius, std::int64_t sphereLabel, std::int64_t blockLabel) {
  SphereGrid g;
  g.dims = dims;
  g.values.assign(static_cast<std::size_t>(dims[0] * dims[1] * dims[2]), 0);
  for (std::int64_t k = 0; k < dims[2]; ++k)
    for (std::int64_t j = 0; j < dims[1]; ++j)
      for (std::int64_t i = 0; i < dims[0]; ++i) {
        const double di = static_cast<double>(i) - centre[0];
        const double dj = static_cast<double>(j) - centre[1];
        const double dk = static_cast<double>(k) - centre[2];
        std::int64_t v = 0;
        if (di * di + dj * dj + dk * dk <= radius * radius) v = sphereLabel;
        if (i >= 1 && i <= 2 && j >= 1 && j <= 2 && k >= 1 && k <= 2) v = blockLabel;
        g.values[static_cast<std::size_t>(i + dims[0] * (j + dims[1] * k))] = v;
      }
  return g;
}

}  // namespace voxcut::test
