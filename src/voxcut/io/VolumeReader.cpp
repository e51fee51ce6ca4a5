#include "voxcut/io/VolumeReader.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "voxcut/core/Error.h"
#include "voxcut/io/StrictJson.h"
#include "voxcut/io/VolumeData.h"
#include "voxcut/io/VolumeFormats.h"

namespace voxcut {
namespace {

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Header files are small; anything larger than this is not a header (the limit only keeps a
// mistaken path from being read whole before the reader looks at it).
constexpr std::size_t kMaxHeaderFile = std::size_t{64} << 20;

}  // namespace

VolumeFormat volumeFormatOf(const std::string& path) {
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (endsWith(lower, ".nii") || endsWith(lower, ".nii.gz")) return VolumeFormat::Nifti;
  if (endsWith(lower, ".nrrd") || endsWith(lower, ".nhdr")) return VolumeFormat::Nrrd;
  if (endsWith(lower, ".mha") || endsWith(lower, ".mhd")) return VolumeFormat::MetaImage;
  return VolumeFormat::None;
}

LabelVolume readLabelVolume(const std::string& path, const VolumeReadParams& params) {
  const std::string what = detail::oneLine(path);
  const VolumeFormat format = volumeFormatOf(path);
  const std::string folder = std::filesystem::path(path).parent_path().string();
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  LabelVolume volume;
  switch (format) {
    case VolumeFormat::None:
      throw InputError(what + ": not a label volume (expected .nii, .nii.gz, .nrrd, .nhdr, "
                              ".seg.nrrd, .mha or .mhd)");
    case VolumeFormat::Nifti: volume = volumeio::readNifti(path, params); break;
    case VolumeFormat::Nrrd: {
      // An attached .nrrd holds its data: its size is bounded by the memory check below.
      const std::size_t limit =
          endsWith(lower, ".nhdr") ? kMaxHeaderFile
                                  : (params.maxMemory ? params.maxMemory + kMaxHeaderFile : 0);
      volume = volumeio::readNrrd(volumeio::readWholeFile(path, what, limit), folder, what, params);
      break;
    }
    case VolumeFormat::MetaImage: {
      const std::size_t limit =
          endsWith(lower, ".mhd") ? kMaxHeaderFile
                                 : (params.maxMemory ? params.maxMemory + kMaxHeaderFile : 0);
      volume = volumeio::readMetaImage(volumeio::readWholeFile(path, what, limit), folder, what,
                                       params);
      break;
    }
  }
  checkLabelVolumePlacement(volume, what);
  if (volume.labels.empty())
    throw InputError(what + ": holds no non-zero label (an empty segmentation)");
  return volume;
}

}  // namespace voxcut
