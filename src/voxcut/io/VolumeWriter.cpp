#include "voxcut/io/VolumeWriter.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "voxcut/core/Error.h"
#include "voxcut/io/StrictJson.h"

namespace voxcut {
namespace {

/// The NRRD sample type of the file: its name and bytes per sample.
struct SampleFormat {
  const char* name = "uint8";
  int bytes = 1;
};

/// The smallest integer type holding every value in [lo, hi] (lo <= 0 <= hi): unsigned where
/// lo is 0.
SampleFormat sampleFormat(std::int64_t lo, std::int64_t hi) {
  if (lo >= 0) {
    if (hi <= std::numeric_limits<std::uint8_t>::max()) return {"uint8", 1};
    if (hi <= std::numeric_limits<std::uint16_t>::max()) return {"uint16", 2};
    if (hi <= std::numeric_limits<std::uint32_t>::max()) return {"uint32", 4};
    return {"uint64", 8};
  }
  const auto within = [&](auto type) {
    using T = decltype(type);
    return lo >= std::numeric_limits<T>::min() && hi <= std::numeric_limits<T>::max();
  };
  if (within(std::int8_t{})) return {"int8", 1};
  if (within(std::int16_t{})) return {"int16", 2};
  if (within(std::int32_t{})) return {"int32", 4};
  return {"int64", 8};
}

/// `x` in the shortest form that reads back to the same double.
std::string shortest(double x) {
  char buffer[32];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, x);
  return std::string(buffer, ec == std::errc() ? end : buffer);
}

std::string vector3(const Vec3d& v) {
  return "(" + shortest(v.x()) + "," + shortest(v.y()) + "," + shortest(v.z()) + ")";
}

/// The header, up to and including the empty line that starts the data.
std::string header(const LabelVolume& volume, const SampleFormat& format) {
  std::string h = "NRRD0004\n# written by voxcut (io/VolumeWriter.h)\n";
  h += std::string("type: ") + format.name + "\n";
  h += "dimension: 3\n";
  h += "space: right-anterior-superior\n";
  h += "sizes: " + std::to_string(volume.dims.x) + " " + std::to_string(volume.dims.y) + " " +
       std::to_string(volume.dims.z) + "\n";
  h += "space directions: " + vector3(volume.axes.col(0)) + " " + vector3(volume.axes.col(1)) +
       " " + vector3(volume.axes.col(2)) + "\n";
  h += "kinds: domain domain domain\n";
  h += "endian: little\n";
  h += "encoding: raw\n";
  h += "space units: \"m\" \"m\" \"m\"\n";
  h += "space origin: " + vector3(volume.origin) + "\n\n";
  return h;
}

/// Removes the temporary file unless released.
class TemporaryFile {
 public:
  explicit TemporaryFile(std::string path) : path_(std::move(path)) {}
  ~TemporaryFile() {
    if (path_.empty()) return;
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
  TemporaryFile(const TemporaryFile&) = delete;
  TemporaryFile& operator=(const TemporaryFile&) = delete;
  void release() { path_.clear(); }

 private:
  std::string path_;
};

}  // namespace

void writeNrrd(const LabelVolume& volume, const std::string& path) {
  const std::string what = detail::oneLine("cannot write label volume '" + path + "'");
  try {
    checkLabelVolumePlacement(volume, what);
  } catch (const InputError& e) {
    throw InputError(detail::oneLine(e.what()));
  }
  if (volume.index.size() != volume.voxelCount())
    throw InputError(what + ": the index holds " + std::to_string(volume.index.size()) +
                     " voxels, the dims " + std::to_string(volume.voxelCount()));
  const auto labelCount = volume.labels.size();
  if (std::any_of(volume.index.begin(), volume.index.end(),
                  [&](std::uint16_t i) { return i > labelCount; }))
    throw InputError(what + ": a voxel's index names no label (there are " +
                     std::to_string(labelCount) + ")");

  // The value of each index (0: background), and the type that holds them all.
  std::vector<std::int64_t> values{0};
  std::int64_t lo = 0, hi = 0;
  for (const LabelInfo& l : volume.labels) {
    values.push_back(l.value);
    lo = std::min(lo, l.value);
    hi = std::max(hi, l.value);
  }
  const SampleFormat format = sampleFormat(lo, hi);

  const std::string temporary = path + ".tmp";
  std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
  if (!out)
    throw InputError(what + ": cannot create '" + detail::oneLine(temporary) + "' (" +
                     std::generic_category().message(errno) + ")");
  TemporaryFile guard(temporary);
  const std::string head = header(volume, format);
  out.write(head.data(), static_cast<std::streamsize>(head.size()));

  // One slice at a time, each sample little endian (two's complement for negative values).
  const auto bytes = static_cast<std::size_t>(format.bytes);
  const std::size_t sliceVoxels =
      static_cast<std::size_t>(volume.dims.x) * static_cast<std::size_t>(volume.dims.y);
  std::vector<char> slice(sliceVoxels * bytes);
  for (int k = 0; k < volume.dims.z && out; ++k) {
    const std::size_t first = sliceVoxels * static_cast<std::size_t>(k);
    for (std::size_t v = 0; v < sliceVoxels; ++v) {
      const auto sample = static_cast<std::uint64_t>(values[volume.index[first + v]]);
      for (std::size_t b = 0; b < bytes; ++b)
        slice[v * bytes + b] = static_cast<char>((sample >> (8 * b)) & 0xffu);
    }
    out.write(slice.data(), static_cast<std::streamsize>(slice.size()));
  }
  out.close();
  if (!out)
    throw InputError(what + ": writing '" + detail::oneLine(temporary) +
                     "' failed (disk full?)");
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec)
    throw InputError(what + ": cannot rename '" + detail::oneLine(temporary) + "' to it (" +
                     ec.message() + ")");
  guard.release();
}

}  // namespace voxcut
