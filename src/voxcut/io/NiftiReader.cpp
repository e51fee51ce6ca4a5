/// @file NiftiReader.cpp
/// volumeio::readNifti: NIfTI-1 and NIfTI-2 label volumes, single files (.nii, .nii.gz).
///
/// The header is read here (the first 348 or 540 bytes, inflated first for .nii.gz), checked
/// field by field against the raw values, and then converted by nifticlib
/// (nifti_convert_n1hdr2nim / nifti_convert_n2hdr2nim: byte swapping, the qform's quaternion
/// to a matrix with qfac, the sform's rows). The raw fields are checked here because nifticlib
/// silently repairs what a label volume must not accept (a zero or non-finite pixdim becomes
/// 1, a non-positive dim becomes 1, a non-finite quaternion becomes 0), and it prints to
/// stderr on some failures whatever the debug level: the checks make those failures
/// unreachable. nifti_image_read is not used: it would open the file a second time (trying
/// other names when the one given is missing), parse ASCII ".nia" headers and extensions from
/// untrusted bytes, and allocate extensions as large as vox_offset says before this reader has
/// seen the data.
///
/// Rules:
///  - Placement: the sform when sform_code > 0, else the qform when qform_code > 0, else the
///    voxel sizes (pixdim) with the origin at zero. When both forms are set and the world
///    positions of the volume's 8 corner voxels differ by more than 1e-3 of the smallest voxel
///    size, one warning names both. Units from xyzt_units: metres, micrometres, or millimetres
///    (also when unknown); world space is RAS in metres.
///  - Scaling: scl_slope 0 or NaN means no scaling (the standard's rule, as nibabel reads it);
///    any other scaling (slope not 1, or intercept not 0) is refused, since labels are the
///    stored integers themselves.
///  - vox_offset must be a whole number not below the header's size (348 or 540), and the file
///    (after inflation for .nii.gz) must hold exactly vox_offset + nx*ny*nz*bytes-per-voxel
///    bytes.

#include <nifti2_io.h>  // nifticlib, NIfTI-2 API (reads NIfTI-1 too)
#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include "voxcut/core/Error.h"
#include "voxcut/io/StrictJson.h"
#include "voxcut/io/VolumeData.h"
#include "voxcut/io/VolumeFormats.h"

namespace voxcut::volumeio {
namespace {

constexpr std::size_t kNifti1HeaderBytes = 348;
constexpr std::size_t kNifti2HeaderBytes = 540;
// vox_offset beyond this cannot be a real file (and keeps vox_offset + data from overflowing).
constexpr std::int64_t kMaxVoxOffset = std::int64_t{1} << 50;
// A compressed file larger than the memory limit by more than this is refused unread (the
// compressed bytes of a volume that fits the limit are about as many as its data, plus the
// header, extensions and gzip framing).
constexpr std::size_t kCompressedSlack = std::size_t{64} << 20;

std::string num(double v, int digits = 6) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

bool endsWithNoCase(const std::string& s, std::string_view suffix) {
  if (s.size() < suffix.size()) return false;
  for (std::size_t k = 0; k < suffix.size(); ++k)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + k])) !=
        std::tolower(static_cast<unsigned char>(suffix[k])))
      return false;
  return true;
}

// nifticlib prints diagnostics to stderr at its default level; the reader reports failures
// itself. The level is global to the library, so it is set once.
void silenceNifticlib() {
  static std::once_flag once;
  std::call_once(once, [] { nifti_set_debug_level(0); });
}

struct NiftiImageFree {
  void operator()(nifti_image* image) const { nifti_image_free(image); }
};
using NiftiImagePtr = std::unique_ptr<nifti_image, NiftiImageFree>;

// The header fields the reader checks, in the machine's byte order, for either version.
struct Header {
  int version = 0;        // 1 or 2
  std::size_t bytes = 0;  // 348 or 540
  bool swapped = false;   // the file's byte order is not the machine's
  std::array<std::int64_t, 8> dim{};
  std::array<double, 8> pixdim{};
  int datatype = 0;
  double voxOffset = 0;  // a float in NIfTI-1, an int64 in NIfTI-2 (exact below 2^53)
  double sclSlope = 0;
  double sclInter = 0;
  int qformCode = 0;
  int sformCode = 0;
  std::array<double, 6> quatern{};  // quatern_b, c, d, qoffset_x, y, z
  std::array<std::array<double, 4>, 3> srow{};
  int xyzUnits = 0;
  std::string magic;  // the magic bytes, for messages
};

template <class H>
void copyFields(const H& h, Header& out) {
  for (int a = 0; a < 8; ++a) {
    out.dim[a] = static_cast<std::int64_t>(h.dim[a]);
    out.pixdim[a] = static_cast<double>(h.pixdim[a]);
  }
  out.datatype = h.datatype;
  out.voxOffset = static_cast<double>(h.vox_offset);
  out.sclSlope = static_cast<double>(h.scl_slope);
  out.sclInter = static_cast<double>(h.scl_inter);
  out.qformCode = h.qform_code;
  out.sformCode = h.sform_code;
  out.quatern = {static_cast<double>(h.quatern_b), static_cast<double>(h.quatern_c),
                 static_cast<double>(h.quatern_d), static_cast<double>(h.qoffset_x),
                 static_cast<double>(h.qoffset_y), static_cast<double>(h.qoffset_z)};
  for (int c = 0; c < 4; ++c) {
    out.srow[0][c] = static_cast<double>(h.srow_x[c]);
    out.srow[1][c] = static_cast<double>(h.srow_y[c]);
    out.srow[2][c] = static_cast<double>(h.srow_z[c]);
  }
  out.xyzUnits = XYZT_TO_SPACE(static_cast<int>(h.xyzt_units));
}

std::int32_t byteSwapped(std::int32_t v) {
  std::uint32_t u;
  std::memcpy(&u, &v, 4);
  u = (u >> 24) | ((u >> 8) & 0xff00u) | ((u << 8) & 0xff0000u) | (u << 24);
  std::memcpy(&v, &u, 4);
  return v;
}

// Reads the header at the start of `head` (the file's first bytes) into `header`, and converts
// it with nifticlib once every field nifticlib would repair or fail on has been checked.
NiftiImagePtr parseHeader(const std::string& head, const std::string& what, Header& header) {
  if (head.empty()) throw InputError(what + ": the file is empty (no NIfTI header)");
  if (head.size() >= 2 && static_cast<unsigned char>(head[0]) == 0x1f &&
      static_cast<unsigned char>(head[1]) == 0x8b)
    throw InputError(what + ": is gzip-compressed; name it .nii.gz");
  if (head.size() < kNifti1HeaderBytes)
    throw InputError(what + ": " + std::to_string(head.size()) +
                     " bytes are too short for a NIfTI header (348 bytes at least)");
  std::int32_t sizeofHdr;
  std::memcpy(&sizeofHdr, head.data(), 4);
  const std::int32_t swappedSize = byteSwapped(sizeofHdr);
  if (sizeofHdr == 348 || swappedSize == 348) {
    header.version = 1;
    header.bytes = kNifti1HeaderBytes;
    header.swapped = sizeofHdr != 348;
  } else if (sizeofHdr == 540 || swappedSize == 540) {
    header.version = 2;
    header.bytes = kNifti2HeaderBytes;
    header.swapped = sizeofHdr != 540;
    if (head.size() < kNifti2HeaderBytes)
      throw InputError(what + ": " + std::to_string(head.size()) +
                       " bytes are too short for a NIfTI-2 header (540 bytes)");
  } else {
    throw InputError(what + ": not a NIfTI file: sizeof_hdr is " + std::to_string(sizeofHdr) +
                     " (NIfTI-1 has 348, NIfTI-2 540; first bytes \"" +
                     escaped(std::string_view(head).substr(0, 16)) + "\")");
  }

  nifti_1_header raw1{};
  nifti_2_header raw2{};
  const std::size_t magicAt = header.version == 1 ? 344 : 4;
  header.magic = head.substr(magicAt, header.version == 1 ? 4 : 8);
  const std::string_view magic(header.magic);
  const std::string expected =
      header.version == 1 ? std::string("n+1\0", 4) : std::string("n+2\0\r\n\x1a\n", 8);
  if (magic != expected) {
    if (magic.substr(0, 4) == std::string_view(header.version == 1 ? "ni1\0" : "ni2\0", 4))
      throw InputError(what + ": magic \"" + escaped(magic) +
                       "\" marks a header with its data in a separate .img file; only single "
                       "files (.nii, .nii.gz) are read");
    if (header.version == 2 && magic.substr(0, 4) == std::string_view("n+2\0", 4))
      throw InputError(what + ": magic \"" + escaped(magic) +
                       "\" of NIfTI-2 is damaged after its first 4 bytes (expected "
                       "\"n+2\\x00\\r\\n\\x1A\\n\"; was the file transferred as text?)");
    throw InputError(what + ": magic \"" + escaped(magic) + "\" is not NIfTI-" +
                     std::to_string(header.version) + "'s \"" + escaped(expected) +
                     "\" (ANALYZE 7.5 and other formats are not read)");
  }
  if (header.version == 1) {
    std::memcpy(&raw1, head.data(), kNifti1HeaderBytes);
    nifti_1_header native = raw1;
    if (header.swapped) swap_nifti_header(&native, 1);
    copyFields(native, header);
  } else {
    std::memcpy(&raw2, head.data(), kNifti2HeaderBytes);
    nifti_2_header native = raw2;
    if (header.swapped) swap_nifti_header(&native, 2);
    copyFields(native, header);
  }

  // Dimensions: 3, or more with every extra one 1.
  const std::int64_t ndim = header.dim[0];
  if (ndim < 1 || ndim > 7)
    throw InputError(what + ": dim[0] is " + std::to_string(ndim) + " (must be 1 to 7)");
  if (ndim < 3)
    throw InputError(what + ": dim[0] is " + std::to_string(ndim) + ": " + std::to_string(ndim) +
                     "-D data (a label volume has 3 dimensions)");
  for (int a = 1; a <= 3; ++a)
    if (header.dim[a] <= 0 || header.dim[a] > INT_MAX)
      throw InputError(what + ": dim[" + std::to_string(a) + "] is " +
                       std::to_string(header.dim[a]) + " (dimensions must be from 1 to " +
                       std::to_string(INT_MAX) + ")");
  for (std::int64_t a = ndim; a >= 4; --a) {
    const std::int64_t d = header.dim[a];
    if (d > 1)
      throw InputError(what + ": dim[" + std::to_string(a) + "] is " + std::to_string(d) + ": " +
                       std::to_string(a) +
                       "-D data are not supported (a label volume has 3 "
                       "dimensions; extra dimensions must be 1)");
    if (d < 1)
      throw InputError(what + ": dim[" + std::to_string(a) + "] is " + std::to_string(d) +
                       " (dimensions must be positive)");
  }
  for (int a = 1; a <= 3; ++a) {
    const double p = header.pixdim[a];
    if (!(std::isfinite(p) && p > 0))
      throw InputError(what + ": pixdim[" + std::to_string(a) + "] is " + num(p) +
                       " (voxel sizes must be positive and finite)");
  }

  // vox_offset: where the voxels start, after the header and its extensions.
  // NIfTI-1's limit is nifticlib's: it converts the float to an int.
  const double off = header.voxOffset;
  const double maxOffset =
      header.version == 1 ? static_cast<double>(INT_MAX) : static_cast<double>(kMaxVoxOffset);
  if (!std::isfinite(off) || off != std::floor(off) || off < 0 || off > maxOffset)
    throw InputError(what + ": vox_offset " + num(off) + " is not a byte offset (0 to " +
                     num(maxOffset, 16) + ")");
  if (off < static_cast<double>(header.bytes))
    throw InputError(what + ": vox_offset " + num(off) + " lies inside the " +
                     std::to_string(header.bytes) + "-byte header (the data of a .nii start at " +
                     (header.version == 1 ? "352" : "544") + " or later)");

  // Scaling: a zero or NaN slope means none (NIfTI's rule); labels are the stored values.
  const bool scaled = header.sclSlope != 0 && !std::isnan(header.sclSlope) &&
                      (header.sclSlope != 1 || header.sclInter != 0);
  if (scaled)
    throw InputError(what + ": scl_slope " + num(header.sclSlope) + " and scl_inter " +
                     num(header.sclInter) +
                     " scale the stored values; label volumes must store the labels "
                     "themselves (scaled data are not read)");

  if (header.qformCode < 0 || header.sformCode < 0)
    throw InputError(what + ": " + (header.qformCode < 0 ? "qform_code " : "sform_code ") +
                     std::to_string(std::min(header.qformCode, header.sformCode)) +
                     " is negative (codes are 0 for none, or positive)");
  if (header.sformCode > 0)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        if (!std::isfinite(header.srow[r][c]))
          throw InputError(what + ": srow_" + "xyz"[r] + "[" + std::to_string(c) + "] is " +
                           num(header.srow[r][c]) + " (the sform must be finite)");

  // Data types nifticlib knows but a label volume cannot hold are named in the message.
  switch (header.datatype) {
    case NIFTI_TYPE_INT8:
    case NIFTI_TYPE_UINT8:
    case NIFTI_TYPE_INT16:
    case NIFTI_TYPE_UINT16:
    case NIFTI_TYPE_INT32:
    case NIFTI_TYPE_UINT32:
    case NIFTI_TYPE_INT64:
    case NIFTI_TYPE_UINT64:
    case NIFTI_TYPE_FLOAT32:
    case NIFTI_TYPE_FLOAT64:
      break;
    default: {
      const std::string name = nifti_datatype_string(header.datatype);
      throw InputError(
          what + ": datatype " + std::to_string(header.datatype) +
          (name == "**ILLEGAL**" ? std::string(" (not a NIfTI type)") : " (" + name + ")") +
          " is not a label type (labels are 8- to 64-bit integers, or floats "
          "holding whole numbers)");
    }
  }

  // No file name: nifticlib would otherwise derive and check image file names.
  NiftiImagePtr image(header.version == 1 ? nifti_convert_n1hdr2nim(raw1, nullptr)
                                          : nifti_convert_n2hdr2nim(raw2, nullptr));
  if (!image) throw InputError(what + ": nifticlib could not convert the header");
  const bool nifticlibSwapped = image->byteorder != nifti_short_order();
  if (nifticlibSwapped != header.swapped || image->datatype != header.datatype)
    throw InputError(what +
                     ": the header's byte order is ambiguous (sizeof_hdr and dim[0] "
                     "disagree)");
  return image;
}

SampleType sampleTypeOf(int datatype) {
  switch (datatype) {
    case NIFTI_TYPE_INT8:
      return SampleType::Int8;
    case NIFTI_TYPE_UINT8:
      return SampleType::UInt8;
    case NIFTI_TYPE_INT16:
      return SampleType::Int16;
    case NIFTI_TYPE_UINT16:
      return SampleType::UInt16;
    case NIFTI_TYPE_INT32:
      return SampleType::Int32;
    case NIFTI_TYPE_UINT32:
      return SampleType::UInt32;
    case NIFTI_TYPE_INT64:
      return SampleType::Int64;
    case NIFTI_TYPE_UINT64:
      return SampleType::UInt64;
    case NIFTI_TYPE_FLOAT32:
      return SampleType::Float32;
    default:
      return SampleType::Float64;
  }
}

// The first (up to) `maxBytes` bytes the gzip or zlib stream `compressed` inflates to; fewer
// when the stream ends or is cut short sooner. Throws for a stream that is not gzip or is
// corrupt within those bytes.
std::string inflatePrefix(std::string_view compressed, std::size_t maxBytes,
                          const std::string& what) {
  if (compressed.empty()) throw InputError(what + ": the file is empty (no NIfTI header)");
  if (compressed.size() < 2 || static_cast<unsigned char>(compressed[0]) != 0x1f ||
      static_cast<unsigned char>(compressed[1]) != 0x8b)
    throw InputError(what + ": is not gzip-compressed (first bytes \"" +
                     escaped(compressed.substr(0, 16)) + "\"); name an uncompressed file .nii");
  z_stream zs{};
  // 15 + 32: zlib or gzip, detected from the stream's header.
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw InputError(what + ": zlib could not start");
  std::string out(maxBytes, '\0');
  const std::size_t in = std::min<std::size_t>(compressed.size(), std::size_t{1} << 30);
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data()));
  zs.avail_in = static_cast<uInt>(in);
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(maxBytes);
  int rc = Z_OK;
  while (zs.avail_out > 0) {
    const uInt before = zs.avail_in + zs.avail_out;
    rc = inflate(&zs, Z_NO_FLUSH);
    if (rc != Z_OK || zs.avail_in + zs.avail_out == before) break;
  }
  const std::size_t produced = maxBytes - zs.avail_out;
  const std::string message = zs.msg ? std::string(" (") + zs.msg + ")" : std::string();
  inflateEnd(&zs);
  if (rc != Z_OK && rc != Z_STREAM_END && rc != Z_BUF_ERROR)
    throw InputError(what + ": corrupt gzip data in the header" + message);
  out.resize(produced);
  return out;
}

// An uncompressed file opened for reading, with its size.
struct PlainFile {
  std::ifstream in;
  std::uint64_t size = 0;
};

PlainFile openPlain(const std::string& path, const std::string& what) {
  PlainFile file;
  file.in = openRegularFile(path, what, file.size);
  return file;
}

// The voxel-to-world map of a nifticlib matrix: rows 0..2 of the 4x4.
Eigen::Matrix<double, 3, 4> affineOf(const nifti_dmat44& m) {
  Eigen::Matrix<double, 3, 4> a;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) a(r, c) = m.m[r][c];
  return a;
}

// The largest distance between the positions two affines give the volume's corner voxels.
double largestCornerGap(const Eigen::Matrix<double, 3, 4>& a, const Eigen::Matrix<double, 3, 4>& b,
                        const Index3& dims) {
  double gap = 0;
  for (int corner = 0; corner < 8; ++corner) {
    Eigen::Vector4d ijk(0, 0, 0, 1);
    for (int axis = 0; axis < 3; ++axis)
      if (corner & (1 << axis)) ijk[axis] = dims[axis] - 1;
    gap = std::max(gap, (a * ijk - b * ijk).norm());
  }
  return gap;
}

// Why the qform's quaternion cannot be used, or empty. nifticlib would replace non-finite
// values by 0 and rescale a (b, c, d) longer than 1; nibabel refuses the latter.
std::string qformProblem(const Header& header) {
  for (double q : header.quatern)
    if (!std::isfinite(q)) return "its quaternion or offset is not finite";
  const double b = header.quatern[0], c = header.quatern[1], d = header.quatern[2];
  const double length2 = b * b + c * c + d * d;
  if (length2 > 1 + 1e-6)
    return "its quaternion (b, c, d) = (" + num(b) + ", " + num(c) + ", " + num(d) +
           ") is longer than 1";
  return {};
}

// Places `volume` (dims set) by the sform, the qform or the voxel sizes, in metres.
void place(LabelVolume& volume, const nifti_image& image, const Header& header,
           const std::string& what) {
  const double metres = header.xyzUnits == NIFTI_UNITS_METER    ? 1.0
                        : header.xyzUnits == NIFTI_UNITS_MICRON ? 1e-6
                                                                : 1e-3;
  const std::string sformName = "sform (code " + std::to_string(header.sformCode) + ")";
  const std::string qformName = "qform (code " + std::to_string(header.qformCode) + ")";
  const std::string qformBad = header.qformCode > 0 ? qformProblem(header) : std::string();
  Eigen::Matrix<double, 3, 4> affine = Eigen::Matrix<double, 3, 4>::Zero();
  if (header.sformCode > 0) {
    affine = affineOf(image.sto_xyz);
    volume.placement = sformName;
    if (header.qformCode > 0) {
      if (!qformBad.empty()) {
        volume.warnings.push_back("the " + qformName + " is unusable (" + qformBad +
                                  "); using the " + sformName);
      } else {
        const Eigen::Matrix<double, 3, 4> qform = affineOf(image.qto_xyz);
        const double voxel = affine.leftCols<3>().colwise().norm().minCoeff();
        const double gap = largestCornerGap(affine, qform, volume.dims);
        if (gap > 1e-3 * voxel)
          volume.warnings.push_back(sformName + " and " + qformName + " disagree by " +
                                    num(gap * metres * 1e3, 3) + " mm; using the sform");
      }
    }
  } else if (header.qformCode > 0) {
    if (!qformBad.empty())
      throw InputError(what + ": the " + qformName + " is unusable: " + qformBad);
    affine = affineOf(image.qto_xyz);
    volume.placement = qformName;
  } else {
    for (int a = 0; a < 3; ++a) affine(a, a) = header.pixdim[a + 1];
    volume.placement = "voxel sizes only (no sform or qform)";
  }
  volume.axes = affine.leftCols<3>() * metres;
  volume.origin = affine.col(3) * metres;
}

}  // namespace

LabelVolume readNifti(const std::string& path, const VolumeReadParams& params) {
  silenceNifticlib();
  const std::string what = detail::oneLine(path);
  const bool gz = endsWithNoCase(path, ".gz");

  // The header: the file's first bytes, inflated for .nii.gz.
  std::optional<PlainFile> plain;
  std::string compressed;
  std::string head;
  if (gz) {
    compressed =
        readWholeFile(path, what, params.maxMemory ? params.maxMemory + kCompressedSlack : 0);
    head = inflatePrefix(compressed, kNifti2HeaderBytes, what);
  } else {
    plain = openPlain(path, what);
    head.resize(static_cast<std::size_t>(std::min<std::uint64_t>(plain->size, kNifti2HeaderBytes)));
    if (!head.empty() && !plain->in.read(head.data(), static_cast<std::streamsize>(head.size())))
      throw InputError(what + ": read error in the header");
  }
  Header header;
  const NiftiImagePtr image = parseHeader(head, what, header);
  const SampleType type = sampleTypeOf(header.datatype);

  // The memory check comes before any voxel is read.
  const std::size_t voxels = checkVolumeSize(what, header.dim[1], header.dim[2], header.dim[3], 1,
                                             sampleBytes(type), params.maxMemory);
  const std::size_t dataBytes = voxels * sampleBytes(type);
  const auto offset = static_cast<std::size_t>(header.voxOffset);
  const std::size_t total = offset + dataBytes;
  const std::string voxelData = std::to_string(dataBytes) + " bytes of voxel data (" +
                                std::to_string(header.dim[1]) + " x " +
                                std::to_string(header.dim[2]) + " x " +
                                std::to_string(header.dim[3]) + " " + sampleTypeName(type) + ")";
  const std::string declared = voxelData + " from byte " + std::to_string(offset);

  LabelVolume volume;
  volume.dims = {static_cast<int>(header.dim[1]), static_cast<int>(header.dim[2]),
                 static_cast<int>(header.dim[3])};
  place(volume, *image, header, what);
  try {
    checkLabelVolumePlacement(volume, what);
  } catch (const InputError& e) {
    throw InputError(std::string(e.what()) + " (from the " + volume.placement + ")");
  }

  // The file's byte order: the machine's unless the header was swapped (nifticlib agrees, as
  // parseHeader checked).
  const bool bigEndian = (std::endian::native == std::endian::big) != header.swapped;
  if (gz) {
    if (params.maxMemory != 0 && offset > params.maxMemory)
      throw InputError(what + ": vox_offset " + std::to_string(offset) +
                       " (header and extensions) is over the memory limit of " +
                       std::to_string(params.maxMemory >> 20) + " MiB (--max-memory)");
    std::string inflated;
    try {
      inflated = inflateExactly(compressed, total, what);
    } catch (const InputError& e) {
      // The byte counts in the message include the header: say what they are made of.
      throw InputError(std::string(e.what()) + " (" + std::to_string(offset) +
                       " bytes of header and extensions, then " + voxelData + ")");
    }
    std::string().swap(compressed);
    setLabelsFromSamples(volume, inflated.data() + offset, voxels, type, bigEndian, what);
  } else {
    if (plain->size < total)
      throw InputError(what + ": truncated: the header declares " + declared +
                       ", the file ends at byte " + std::to_string(plain->size));
    if (plain->size > total)
      throw InputError(what + ": the file holds " + std::to_string(plain->size - total) +
                       " bytes after the " + declared + " that the header declares");
    std::string samples(dataBytes, '\0');
    plain->in.clear();
    plain->in.seekg(static_cast<std::streamoff>(offset), std::ios::beg);
    if (!plain->in.read(samples.data(), static_cast<std::streamsize>(dataBytes)))
      throw InputError(what + ": read error in the voxel data");
    setLabelsFromSamples(volume, samples.data(), voxels, type, bigEndian, what);
  }
  return volume;
}

}  // namespace voxcut::volumeio
