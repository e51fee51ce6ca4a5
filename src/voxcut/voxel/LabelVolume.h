#pragma once
/// @file LabelVolume.h
/// A segmented image as read from a file: a grid of integer labels (0 background, one label
/// per organ, lesion or region) placed in world space by an affine map (docs/algorithms.md,
/// "Label volumes"). The readers of io/VolumeReader.h produce it; resampleLabels
/// (LabelResample.h) turns it into a linked voxel model.
///
/// World space is the file's physical space in metres, in RAS (+x towards the subject's right,
/// +y anterior, +z superior). Readers convert LPS spaces (NRRD's left-posterior-superior,
/// MetaImage's ITK convention) by negating x and y.
///
/// Labels are stored compactly: per voxel an index into `labels` plus one (0 = background),
/// so that 8-, 16- and 32-bit label values all take two bytes a voxel.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

/// One non-zero label of a volume.
struct LabelInfo {
  std::int64_t value = 0;  ///< the value stored in the file
  std::string name;        ///< from the file (segment name) or a names file; may be empty
  std::optional<std::array<float, 3>> colour;  ///< RGB in [0, 1], from the file when it has one
};

/// A label volume in world space.
struct LabelVolume {
  Index3 dims;  ///< voxels along i, j, k
  /// Column a: the world displacement (metres, RAS) of one voxel step along index axis a, i.e.
  /// direction times spacing. Invertible.
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Vec3d origin = Vec3d::Zero();  ///< world position (metres, RAS) of the centre of voxel (0,0,0)
  /// Per voxel i + nx*(j + ny*k): 0 for background, else 1 + its label's position in `labels`.
  std::vector<std::uint16_t> index;
  std::vector<LabelInfo> labels;  ///< the distinct non-zero labels present (or declared)
  /// How the placement was found, for `voxcut info`: e.g. "sform (code 4)",
  /// "space left-posterior-superior, converted to RAS", "spacing only".
  std::string placement;
  std::vector<std::string> warnings;  ///< things the user should know (one line each)

  [[nodiscard]] std::size_t voxelCount() const {
    return static_cast<std::size_t>(dims.x) * static_cast<std::size_t>(dims.y) *
           static_cast<std::size_t>(dims.z);
  }
  [[nodiscard]] std::size_t linear(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(dims.x) *
               (static_cast<std::size_t>(j) + static_cast<std::size_t>(dims.y) *
                                                  static_cast<std::size_t>(k));
  }
  /// World position of the centre of voxel (i, j, k) (continuous indices allowed).
  [[nodiscard]] Vec3d world(const Vec3d& ijk) const { return origin + axes * ijk; }
  /// Spacing along each index axis (metres): the lengths of the columns of `axes`.
  [[nodiscard]] Vec3d spacing() const { return axes.colwise().norm().transpose(); }
  /// Voxels per label: counts[l] for labels[l] (background not counted).
  [[nodiscard]] std::vector<std::size_t> labelCounts() const;
};

/// The scalar types label data may come in.
enum class SampleType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64 };

/// Bytes per sample of `type`.
[[nodiscard]] std::size_t sampleBytes(SampleType type);
/// A short name of `type` ("uint8", "float32", ...).
[[nodiscard]] const char* sampleTypeName(SampleType type);

/// Builds the compact labels of `volume` (index and labels) from `count` samples of `type` at
/// `data`, stored in the byte order given by `bigEndian`, in the volume's voxel order; the
/// volume's dims must already be set and count must equal voxelCount(). Floating-point data
/// are accepted only where every value is an integer (else InputError naming the first voxel
/// that is not, with `source`); more than 65,535 distinct non-zero values is an InputError.
/// Labels come out sorted by value, with empty names. Linear in count.
void setLabelsFromSamples(LabelVolume& volume, const void* data, std::size_t count,
                          SampleType type, bool bigEndian, const std::string& source);

/// Checks the placement of `volume` (finite, invertible axes and origin, positive dims) and
/// throws InputError naming `source` when it is unusable.
void checkLabelVolumePlacement(const LabelVolume& volume, const std::string& source);

}  // namespace voxcut
