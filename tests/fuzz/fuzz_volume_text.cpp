/// @file fuzz_volume_text.cpp
/// libFuzzer harness of the label-volume readers with text headers, one per format picked at
/// compile time (VOXCUT_FUZZ_VOLUME_NRRD: NRRD .nrrd, .nhdr, .seg.nrrd with volumeio::readNrrd;
/// otherwise MetaImage .mha, .mhd with volumeio::readMetaImage): the input is a header with or
/// without attached data. Detached data
/// files resolve against a folder holding data.raw, data.raw.gz and data.zraw
/// (VolumeFuzz.h); the memory limit is 256 MiB, so a header that claims a huge volume
/// must be refused before anything is allocated. A volume that reads must keep
/// LabelVolume's invariants. InputError is the expected answer to bad input; any other
/// exception, a crash, a sanitizer report, a leak, a timeout or running out of memory
/// is a finding.

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "VolumeFuzz.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/VolumeFormats.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  voxcut::fuzz::makeVolumeFolder();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  voxcut::VolumeReadParams params;
  params.maxMemory = voxcut::fuzz::kVolumeMaxMemory;
  try {
#ifdef VOXCUT_FUZZ_VOLUME_NRRD
    const voxcut::LabelVolume volume = voxcut::volumeio::readNrrd(
        bytes, voxcut::fuzz::volumeFolder().string(), "fuzz.nrrd", params);
#else
    const voxcut::LabelVolume volume = voxcut::volumeio::readMetaImage(
        bytes, voxcut::fuzz::volumeFolder().string(), "fuzz.mha", params);
#endif
    voxcut::fuzz::checkVolume(volume);
  } catch (const voxcut::InputError&) {
    // Bad input, reported as the library promises.
  }
  return 0;
}
