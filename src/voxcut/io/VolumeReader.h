#pragma once
/// @file VolumeReader.h
/// Reads segmented label volumes: NIfTI-1 and NIfTI-2 (.nii, .nii.gz, through nifticlib), NRRD
/// (.nrrd, .nhdr with a detached data file, 3D Slicer's .seg.nrrd) and MetaImage (.mha, .mhd
/// with a detached data file) (docs/algorithms.md, "Label volumes").
///
/// Every reader places the volume in world space by one rule: the file's physical space in
/// metres, RAS (LPS spaces converted by negating x and y); see LabelVolume.h.
///
/// Validation is that of the mesh readers: a malformed file is one InputError line naming the
/// file and the field or byte; bytes quoted from a file are escaped to printable ASCII. The
/// header is read and the memory the volume needs estimated (volumeMemoryBytes) before any
/// voxel is read, and refused when over `maxMemory`; after that, time and memory are linear
/// in the bytes the file actually holds, whatever its header claims (data that stop short
/// are an error, never a large allocation). Thread-safe: no shared state except nifticlib's
/// message level, which is set (to silent) once.

#include <cstddef>
#include <string>

#include "voxcut/voxel/LabelVolume.h"

namespace voxcut {

/// Settings of readLabelVolume.
struct VolumeReadParams {
  /// Refuse (InputError) when the memory estimated from the header exceeds this many bytes;
  /// 0: no limit.
  std::size_t maxMemory = 0;
};

/// The volume formats readLabelVolume knows.
enum class VolumeFormat { None, Nifti, Nrrd, MetaImage };

/// The format a path names by its extension (case-insensitive): .nii and .nii.gz are NIfTI,
/// .nrrd, .nhdr and .seg.nrrd NRRD, .mha and .mhd MetaImage; None for anything else.
[[nodiscard]] VolumeFormat volumeFormatOf(const std::string& path);

/// Whether `path` names a label volume by its extension.
[[nodiscard]] inline bool isVolumePath(const std::string& path) {
  return volumeFormatOf(path) != VolumeFormat::None;
}

/// Bytes a volume of `voxels` voxels stored as `sampleBytes`-byte samples needs while it is
/// read: the samples plus the compact two-byte index.
[[nodiscard]] std::size_t volumeMemoryBytes(std::size_t voxels, std::size_t sampleBytes);

/// Reads the label volume at `path`. Throws InputError (one line naming `path`) for a missing
/// or unreadable file, an unknown extension, and anything the format's reader refuses:
/// dimensions that are zero, negative, huge or not 3D (a 4th dimension of size 1 is fine;
/// .seg.nrrd layers are the only 4D data read), spacings that are zero, negative or not
/// finite, unsupported sample types (labels are 8, 16, 32 or 64-bit integers, signed or not;
/// floats only where every value is a whole number), encodings other than raw and gzip,
/// truncated or oversized data, a detached data file that is missing or outside the header's
/// folder, and a volume with no non-zero label.
[[nodiscard]] LabelVolume readLabelVolume(const std::string& path,
                                          const VolumeReadParams& params = {});

}  // namespace voxcut
