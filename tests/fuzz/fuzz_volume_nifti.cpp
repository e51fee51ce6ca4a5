/// @file fuzz_volume_nifti.cpp
/// libFuzzer harness of the NIfTI reader: the input is written to a temporary .nii file and
/// read with volumeio::readNifti under a 256 MiB memory limit, and the volume it returns is
/// checked as readLabelVolume checks it. The input is also read gzip-compressed as a .nii.gz
/// (the header and data paths through zlib), and as a .nii.gz as it stands when it already is
/// gzip data (mutations of the compressed stream itself). InputError is the expected answer to
/// bad input; any other exception, a crash, a sanitizer report, a leak, a timeout or an
/// allocation over the limit is a finding.

#include <unistd.h>
#include <zlib.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "voxcut/core/Error.h"
#include "voxcut/io/VolumeFormats.h"

namespace {

constexpr std::size_t kMaxMemory = std::size_t{256} << 20;

// A folder of this process's own (libFuzzer's -jobs and -fork run several processes).
const std::filesystem::path& folder() {
  static const std::filesystem::path path = [] {
    std::filesystem::path p = std::filesystem::temp_directory_path() /
                              ("voxcut-fuzz-nifti-" + std::to_string(::getpid()));
    std::filesystem::create_directories(p);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(folder(), ec);
    });
    return p;
  }();
  return path;
}

std::string write(const std::string& name, std::string_view bytes) {
  const std::string path = (folder() / name).string();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

std::string gzipped(std::string_view bytes) {
  z_stream zs{};
  if (deflateInit2(&zs, 1, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) std::abort();
  std::string out(deflateBound(&zs, static_cast<uLong>(bytes.size())) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  zs.avail_in = static_cast<uInt>(bytes.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  if (deflate(&zs, Z_FINISH) != Z_STREAM_END) std::abort();
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

void read(const std::string& path) {
  try {
    voxcut::VolumeReadParams params;
    params.maxMemory = kMaxMemory;
    const voxcut::LabelVolume volume = voxcut::volumeio::readNifti(path, params);
    voxcut::checkLabelVolumePlacement(volume, path);
  } catch (const voxcut::InputError&) {
    // Bad input, reported as the library promises.
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  read(write("input.nii", bytes));
  read(write("compressed.nii.gz", gzipped(bytes)));
  if (size >= 2 && data[0] == 0x1f && data[1] == 0x8b) read(write("input.nii.gz", bytes));
  return 0;
}
