#pragma once
/// @file VolumeFuzz.h
/// What the label-volume harnesses (fuzz_volume_nrrd, fuzz_volume_mha) share: the folder that
/// detached data files resolve against, holding three small data files the seed corpora name
/// (data.raw: 24 uint8 labels of a 4 x 3 x 2 grid; data.raw.gz and data.zraw: the same as gzip
/// and zlib streams), the memory limit, and the checks a volume that reads must pass.

#include <stdlib.h>
#include <zlib.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "voxcut/core/Error.h"
#include "voxcut/io/VolumeReader.h"

namespace voxcut::fuzz {

/// The memory limit the harnesses read with: a header may ask for more and must be refused.
inline constexpr std::size_t kVolumeMaxMemory = std::size_t{256} << 20;

/// The data-file folder; created by makeVolumeFolder, removed at exit.
inline std::filesystem::path& volumeFolder() {
  static std::filesystem::path dir;
  return dir;
}

inline void removeVolumeFolder() {
  std::error_code ec;
  std::filesystem::remove_all(volumeFolder(), ec);
}

inline void writeFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out.flush()) std::abort();
}

// `data` deflated as gzip (windowBits 31) or zlib (15).
inline std::string deflated(const std::string& data, int windowBits) {
  z_stream zs{};
  if (deflateInit2(&zs, 9, Z_DEFLATED, windowBits, 8, Z_DEFAULT_STRATEGY) != Z_OK) std::abort();
  std::string out(deflateBound(&zs, static_cast<uLong>(data.size())) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  if (deflate(&zs, Z_FINISH) != Z_STREAM_END) std::abort();
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

/// Creates the data-file folder under the temporary directory (once per process).
inline void makeVolumeFolder() {
  std::string pattern =
      (std::filesystem::temp_directory_path() / "voxcut-fuzz-volume-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) std::abort();
  volumeFolder() = pattern;
  std::atexit(removeVolumeFolder);
  const std::string labels("\0\1\1\0\0\1\2\0\0\0\2\0\1\1\0\0\0\2\2\0\0\0\0\3", 24);
  writeFile(volumeFolder() / "data.raw", labels);
  writeFile(volumeFolder() / "data.raw.gz", deflated(labels, 15 + 16));
  writeFile(volumeFolder() / "data.zraw", deflated(labels, 15));
}

/// Aborts (a finding) when a volume that was read breaks LabelVolume's invariants: an index
/// per voxel within the labels, distinct label values, a usable placement.
inline void checkVolume(const LabelVolume& volume) {
  if (volume.index.size() != volume.voxelCount()) std::abort();
  for (const std::uint16_t i : volume.index)
    if (i > volume.labels.size()) std::abort();
  std::set<std::int64_t> values;
  for (const LabelInfo& l : volume.labels)
    if (!values.insert(l.value).second) std::abort();
  try {
    checkLabelVolumePlacement(volume, "fuzz");
  } catch (const InputError&) {
    std::abort();
  }
}

}  // namespace voxcut::fuzz
