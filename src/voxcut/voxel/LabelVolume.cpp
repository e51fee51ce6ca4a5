#include "voxcut/voxel/LabelVolume.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "voxcut/core/Error.h"

namespace voxcut {
namespace {

constexpr std::size_t kMaxLabels = 65535;

// Sample k of `data` as a label value; `integral` false when it is not a whole number (or out
// of the int64 range).
template <class T>
std::int64_t sampleAt(const unsigned char* data, std::size_t k, bool bigEndian, bool& integral) {
  T value;
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, data + k * sizeof(T), sizeof(T));
  if (bigEndian != (std::endian::native == std::endian::big))
    std::reverse(bytes, bytes + sizeof(T));
  std::memcpy(&value, bytes, sizeof(T));
  integral = true;
  if constexpr (std::is_floating_point_v<T>) {
    // 2^63 is exactly representable; values at or beyond it do not fit an int64.
    if (!(std::abs(value) < 9.2233720368547758e18) || std::floor(value) != value) {
      integral = false;
      return 0;
    }
    return static_cast<std::int64_t>(value);
  } else if constexpr (std::is_same_v<T, std::uint64_t>) {
    if (value > static_cast<std::uint64_t>(INT64_MAX)) {
      integral = false;
      return 0;
    }
    return static_cast<std::int64_t>(value);
  } else {
    return static_cast<std::int64_t>(value);
  }
}

template <class T>
void compact(LabelVolume& volume, const unsigned char* data, std::size_t count, bool bigEndian,
             const std::string& source) {
  auto fail = [&](std::size_t k) {
    const std::size_t nx = static_cast<std::size_t>(volume.dims.x);
    const std::size_t ny = static_cast<std::size_t>(volume.dims.y);
    throw InputError(source + ": voxel (" + std::to_string(k % nx) + ", " +
                     std::to_string((k / nx) % ny) + ", " + std::to_string(k / (nx * ny)) +
                     ") holds a value that is not an integer label (label data must be whole "
                     "numbers)");
  };
  // Pass 1: the distinct non-zero values (runs of one value are the common case).
  std::unordered_map<std::int64_t, std::uint16_t> slot;
  std::vector<std::int64_t> values;
  std::int64_t last = 0;
  for (std::size_t k = 0; k < count; ++k) {
    bool integral = true;
    const std::int64_t v = sampleAt<T>(data, k, bigEndian, integral);
    if (!integral) fail(k);
    if (v == 0 || v == last) continue;
    last = v;
    if (slot.emplace(v, 0).second) {
      values.push_back(v);
      if (values.size() > kMaxLabels)
        throw InputError(source + ": more than " + std::to_string(kMaxLabels) +
                         " distinct labels (is this an intensity image rather than a "
                         "segmentation?)");
    }
  }
  std::sort(values.begin(), values.end());
  volume.labels.clear();
  for (std::size_t l = 0; l < values.size(); ++l) {
    slot[values[l]] = static_cast<std::uint16_t>(l + 1);
    volume.labels.push_back({values[l], {}, std::nullopt});
  }
  // Pass 2: the compact index per voxel.
  volume.index.assign(count, 0);
  last = 0;
  std::uint16_t lastSlot = 0;
  for (std::size_t k = 0; k < count; ++k) {
    bool integral = true;
    const std::int64_t v = sampleAt<T>(data, k, bigEndian, integral);
    if (v == 0) continue;
    if (v != last) {
      last = v;
      lastSlot = slot.at(v);
    }
    volume.index[k] = lastSlot;
  }
}

}  // namespace

std::vector<std::size_t> LabelVolume::labelCounts() const {
  std::vector<std::size_t> counts(labels.size(), 0);
  for (std::uint16_t i : index)
    if (i != 0 && i <= counts.size()) ++counts[i - 1];
  return counts;
}

std::size_t sampleBytes(SampleType type) {
  switch (type) {
    case SampleType::Int8:
    case SampleType::UInt8: return 1;
    case SampleType::Int16:
    case SampleType::UInt16: return 2;
    case SampleType::Int32:
    case SampleType::UInt32:
    case SampleType::Float32: return 4;
    case SampleType::Int64:
    case SampleType::UInt64:
    case SampleType::Float64: return 8;
  }
  return 1;
}

const char* sampleTypeName(SampleType type) {
  switch (type) {
    case SampleType::Int8: return "int8";
    case SampleType::UInt8: return "uint8";
    case SampleType::Int16: return "int16";
    case SampleType::UInt16: return "uint16";
    case SampleType::Int32: return "int32";
    case SampleType::UInt32: return "uint32";
    case SampleType::Int64: return "int64";
    case SampleType::UInt64: return "uint64";
    case SampleType::Float32: return "float32";
    case SampleType::Float64: return "float64";
  }
  return "?";
}

void setLabelsFromSamples(LabelVolume& volume, const void* data, std::size_t count,
                          SampleType type, bool bigEndian, const std::string& source) {
  VOXCUT_ASSERT(count == volume.voxelCount(), "sample count must match the volume's dims");
  const auto* bytes = static_cast<const unsigned char*>(data);
  switch (type) {
    case SampleType::Int8: compact<std::int8_t>(volume, bytes, count, bigEndian, source); break;
    case SampleType::UInt8: compact<std::uint8_t>(volume, bytes, count, bigEndian, source); break;
    case SampleType::Int16: compact<std::int16_t>(volume, bytes, count, bigEndian, source); break;
    case SampleType::UInt16:
      compact<std::uint16_t>(volume, bytes, count, bigEndian, source);
      break;
    case SampleType::Int32: compact<std::int32_t>(volume, bytes, count, bigEndian, source); break;
    case SampleType::UInt32:
      compact<std::uint32_t>(volume, bytes, count, bigEndian, source);
      break;
    case SampleType::Int64: compact<std::int64_t>(volume, bytes, count, bigEndian, source); break;
    case SampleType::UInt64:
      compact<std::uint64_t>(volume, bytes, count, bigEndian, source);
      break;
    case SampleType::Float32: compact<float>(volume, bytes, count, bigEndian, source); break;
    case SampleType::Float64: compact<double>(volume, bytes, count, bigEndian, source); break;
  }
}

void checkLabelVolumePlacement(const LabelVolume& volume, const std::string& source) {
  for (int a = 0; a < 3; ++a)
    if (volume.dims[a] <= 0)
      throw InputError(source + ": dimension " + std::to_string(a) + " is " +
                       std::to_string(volume.dims[a]) + " (must be positive)");
  if (!volume.axes.allFinite() || !volume.origin.allFinite())
    throw InputError(source + ": the voxel-to-world transform is not finite");
  const Vec3d spacing = volume.spacing();
  for (int a = 0; a < 3; ++a)
    if (!(spacing[a] >= 1e-9 && spacing[a] <= 1e3))
      throw InputError(source + ": voxel spacing along axis " + std::to_string(a) + " is " +
                       std::to_string(spacing[a]) + " m (must be in [1e-9, 1e3] m)");
  // The axes must span space: |det| well above zero relative to the spacings.
  const double det = volume.axes.determinant();
  if (!(std::abs(det) > 1e-6 * spacing.prod()))
    throw InputError(source + ": the voxel axes are degenerate (they do not span 3D space)");
  if (!(volume.origin.cwiseAbs().maxCoeff() <= 1e6))
    throw InputError(source + ": the volume's origin lies more than 1e6 m from zero");
}

}  // namespace voxcut
