#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "TempDir.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/VolumeReader.h"
#include "voxcut/io/VolumeWriter.h"
#include "voxcut/voxel/LabelVolume.h"

namespace voxcut {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

/// A volume of `dims` whose voxel n (in voxel order) holds values[n % values.size()], placed
/// by `axes` and `origin`.
LabelVolume volumeOf(const Index3& dims, const Eigen::Matrix3d& axes, const Vec3d& origin,
                     const std::vector<std::int64_t>& values) {
  LabelVolume v;
  v.dims = dims;
  v.axes = axes;
  v.origin = origin;
  std::vector<std::int64_t> samples(v.voxelCount());
  for (std::size_t n = 0; n < samples.size(); ++n) samples[n] = values[n % values.size()];
  setLabelsFromSamples(v, samples.data(), samples.size(), SampleType::Int64, false, "test");
  return v;
}

/// Voxels of 0.1 x 0.25 x 1/3 mm, turned about a slanted axis: no axis-aligned or decimal
/// entry.
Eigen::Matrix3d slantedAxes() {
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(0.7, Vec3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  return turn * Vec3d(1e-4, 2.5e-4, 1e-3 / 3.0).asDiagonal();
}

bool sameBits(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * 9) == 0;
}

bool sameBits(const Vec3d& a, const Vec3d& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * 3) == 0;
}

/// The label value of voxel n (0 for background).
std::int64_t valueAt(const LabelVolume& v, std::size_t n) {
  return v.index[n] == 0 ? 0 : v.labels[v.index[n] - 1u].value;
}

std::string fileText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Writes `volume`, reads it back and expects it equal; returns the file's header line
/// "type: ...".
std::string roundTrip(const LabelVolume& volume, const TempDir& dir) {
  const std::string path = dir.file("volume.nrrd");
  writeNrrd(volume, path);
  EXPECT_FALSE(fs::exists(path + ".tmp"));
  const LabelVolume back = readLabelVolume(path);
  EXPECT_EQ(back.dims, volume.dims);
  EXPECT_TRUE(sameBits(back.axes, volume.axes)) << back.axes << "\nvs\n" << volume.axes;
  EXPECT_TRUE(sameBits(back.origin, volume.origin))
      << back.origin.transpose() << " vs " << volume.origin.transpose();
  std::vector<std::int64_t> values, backValues;
  for (const LabelInfo& l : volume.labels) values.push_back(l.value);
  for (const LabelInfo& l : back.labels) backValues.push_back(l.value);
  EXPECT_EQ(backValues, values);
  EXPECT_EQ(back.index, volume.index);  // labels in the same order: the same compact index
  std::size_t different = 0;
  for (std::size_t n = 0; n < volume.voxelCount(); ++n)
    different += valueAt(back, n) == valueAt(volume, n) ? 0 : 1;
  EXPECT_EQ(different, 0u);
  const std::string text = fileText(path);
  const std::size_t at = text.find("\ntype: ");
  return text.substr(at + 1, text.find('\n', at + 1) - at - 1);
}

TEST(VolumeWriter, Uint8LabelsReadBackExactly) {
  TempDir dir;
  std::vector<std::int64_t> values;
  for (int v = 0; v <= 255; v += 3) values.push_back(v);
  values.push_back(255);
  const LabelVolume volume =
      volumeOf({7, 5, 4}, slantedAxes(), Vec3d(0.1, -0.2, 1.0 / 3.0), values);
  EXPECT_EQ(roundTrip(volume, dir), "type: uint8");
}

TEST(VolumeWriter, ManyAndNegativeLabelsReadBackExactly) {
  TempDir dir;
  std::vector<std::int64_t> values{0};
  for (int v = 1; v <= 300; ++v) values.push_back(v);
  // Unsigned up to 300: two bytes.
  const LabelVolume wide = volumeOf({11, 9, 5}, slantedAxes(), Vec3d(-0.3, 0.7, 1e-7), values);
  EXPECT_EQ(wide.labels.size(), 300u);
  EXPECT_EQ(roundTrip(wide, dir), "type: uint16");
  // With negative values: signed.
  values.push_back(-5);
  values.push_back(-128);
  const LabelVolume negative =
      volumeOf({13, 6, 4}, slantedAxes().transpose(), Vec3d(1.0 / 7.0, 0.0, -0.1), values);
  EXPECT_EQ(roundTrip(negative, dir), "type: int16");
  const LabelVolume small =
      volumeOf({3, 4, 5}, slantedAxes(), Vec3d::Zero(), {0, -128, 127, 1, -1});
  EXPECT_EQ(roundTrip(small, dir), "type: int8");
}

TEST(VolumeWriter, WideLabelsReadBackExactly) {
  TempDir dir;
  constexpr std::int64_t kMin32 = std::numeric_limits<std::int32_t>::min();
  constexpr std::int64_t kMax32 = std::numeric_limits<std::int32_t>::max();
  const Eigen::Matrix3d anisotropic = Vec3d(1e-3, 0.1 / 3.0, 2e-9).asDiagonal();
  EXPECT_EQ(roundTrip(volumeOf({4, 3, 2}, anisotropic, Vec3d(0.1, 0.2, 0.3),
                               {0, kMin32, kMax32, 7, 0, -70000}),
                      dir),
            "type: int32");
  EXPECT_EQ(roundTrip(volumeOf({4, 3, 2}, anisotropic, Vec3d(0.1, 0.2, 0.3),
                               {0, 4000000000LL, 65536, 1}),
                      dir),
            "type: uint32");
  EXPECT_EQ(roundTrip(volumeOf({4, 3, 2}, anisotropic, Vec3d(0.1, 0.2, 0.3),
                               {0, std::int64_t{1} << 40, -(std::int64_t{1} << 50), 1}),
                      dir),
            "type: int64");
}

TEST(VolumeWriter, OverwritesAndLeavesNoTemporary) {
  TempDir dir;
  const std::string path = dir.file("labels.nrrd");
  writeNrrd(volumeOf({2, 2, 2}, slantedAxes(), Vec3d::Zero(), {0, 1}), path);
  writeNrrd(volumeOf({3, 2, 2}, slantedAxes(), Vec3d::Zero(), {0, 9}), path);
  EXPECT_EQ(readLabelVolume(path).dims, (Index3{3, 2, 2}));
  EXPECT_EQ(readLabelVolume(path).labels.at(0).value, 9);
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir.path()))
    names.push_back(entry.path().filename().string());
  EXPECT_EQ(names, std::vector<std::string>{"labels.nrrd"});
}

TEST(VolumeWriter, UnwritablePathIsAnInputError) {
  TempDir dir;
  const LabelVolume volume = volumeOf({2, 2, 2}, slantedAxes(), Vec3d::Zero(), {0, 1});
  const std::string missing = dir.file("no-such-folder/labels.nrrd");
  try {
    writeNrrd(volume, missing);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  fs::create_directories(dir.path() / "folder.nrrd");  // a folder where the file would go
  EXPECT_THROW(writeNrrd(volume, dir.file("folder.nrrd")), InputError);
  EXPECT_FALSE(fs::exists(dir.file("folder.nrrd.tmp")));
  EXPECT_TRUE(fs::is_directory(dir.file("folder.nrrd")));

  LabelVolume flat = volume;  // a placement the reader would refuse
  flat.axes.col(2) = flat.axes.col(1);
  EXPECT_THROW(writeNrrd(flat, dir.file("flat.nrrd")), InputError);
  LabelVolume broken = volume;
  broken.index.pop_back();
  EXPECT_THROW(writeNrrd(broken, dir.file("broken.nrrd")), InputError);
  EXPECT_FALSE(fs::exists(dir.file("flat.nrrd")));
  EXPECT_FALSE(fs::exists(dir.file("broken.nrrd")));
}

}  // namespace
}  // namespace voxcut
