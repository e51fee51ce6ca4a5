// The NIfTI reader (volumeio::readNifti through readLabelVolume) on files written by hand
// (tests/io/NiftiFiles.h): every label type in both byte orders, NIfTI-1 and NIfTI-2, .nii and
// .nii.gz; placement by sform, qform (with qfac -1) or voxel sizes in every unit, checked
// against the standard's formulas and against nibabel (tests/io/nibabel_orientation.py), also
// on the AAL atlas when Debian's mricron-data is installed; and the bad-input matrix: each bad
// file is one InputError line of printable ASCII that names the file.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "NiftiFiles.h"
#include "TempDir.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/VolumeFormats.h"
#include "voxcut/io/VolumeReader.h"

namespace voxcut {
namespace {

using test::NiftiSpec;
using test::SphereGrid;
using test::TempDir;
using Affine = Eigen::Matrix<double, 3, 4>;

const std::array<std::int64_t, 3> kDims = {20, 22, 24};
const std::array<double, 3> kCentre = {9, 11, 12};
constexpr double kRadius = 6;

/// A file of `version` holding `grid` as `datatype`, other fields at their defaults.
NiftiSpec specOf(int version, const SphereGrid& grid, int datatype = test::kNiftiUInt8,
                 bool bigEndian = false) {
  NiftiSpec s;
  s.version = version;
  s.bigEndian = bigEndian;
  s.datatype = datatype;
  s.dim = {3, grid.dims[0], grid.dims[1], grid.dims[2], 1, 1, 1, 1};
  s.pixdim = {1, 1, 1.5, 2, 0, 0, 0, 0};
  s.data = test::niftiSamples(grid.values, datatype, bigEndian);
  return s;
}

SphereGrid defaultGrid() {
  return test::sphereGrid(kDims, kCentre, kRadius, 7, 3);
}

/// Writes `spec` as `name` (gzip-compressed when the name ends in .gz).
std::string writeSpec(const TempDir& dir, const std::string& name, const NiftiSpec& spec) {
  const std::string bytes = test::niftiBytes(spec);
  const bool gz = name.size() > 3 && name.compare(name.size() - 3, 3, ".gz") == 0;
  return dir.write(name, gz ? test::gzipped(bytes) : bytes);
}

/// The value as the header stores it (NIfTI-1 holds float32).
double stored(const NiftiSpec& s, double v) {
  return s.version == 1 ? static_cast<double>(static_cast<float>(v)) : v;
}

/// The voxel-to-world map (file units) the header of `s` states, from the standard's formulas
/// (nifti1.h, "Method 2" and "Method 3") applied to the stored values.
Affine specAffine(const NiftiSpec& s) {
  Affine m = Affine::Zero();
  if (s.sformCode > 0) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) m(r, c) = stored(s, s.srow[r][c]);
  } else if (s.qformCode > 0) {
    const double b = stored(s, s.quatern[0]), c = stored(s, s.quatern[1]),
                 d = stored(s, s.quatern[2]);
    const double a = std::sqrt(std::max(0.0, 1 - b * b - c * c - d * d));
    Eigen::Matrix3d r;
    r << a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c),
        2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b),
        2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b;
    const double qfac = s.pixdim[0] < 0 ? -1 : 1;
    const Eigen::Vector3d scale(stored(s, s.pixdim[1]), stored(s, s.pixdim[2]),
                                qfac * stored(s, s.pixdim[3]));
    m.leftCols<3>() = r * scale.asDiagonal();
    for (int k = 0; k < 3; ++k) m(k, 3) = stored(s, s.quatern[static_cast<std::size_t>(3 + k)]);
  } else {
    for (int k = 0; k < 3; ++k) m(k, k) = stored(s, s.pixdim[static_cast<std::size_t>(k + 1)]);
  }
  return m;
}

double metresPerUnit(int xyztUnits) {
  switch (xyztUnits & 7) {
    case 1:
      return 1.0;
    case 3:
      return 1e-6;
    default:
      return 1e-3;
  }
}

/// Mean world position (metres) of the labelled voxels of `volume`.
Vec3d worldCentroid(const LabelVolume& volume) {
  Vec3d sum = Vec3d::Zero();
  std::size_t count = 0;
  for (int k = 0; k < volume.dims.z; ++k)
    for (int j = 0; j < volume.dims.y; ++j)
      for (int i = 0; i < volume.dims.x; ++i)
        if (volume.index[volume.linear(i, j, k)] != 0) {
          sum += volume.world(Vec3d(i, j, k));
          ++count;
        }
  return sum / static_cast<double>(count);
}

/// Where the header of `s` puts the centroid of the labelled voxels of `grid` (metres).
Vec3d expectedCentroid(const NiftiSpec& s, const SphereGrid& grid) {
  Eigen::Vector4d sum = Eigen::Vector4d::Zero();
  double count = 0;
  for (std::int64_t k = 0; k < grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < grid.dims[0]; ++i)
        if (grid.values[static_cast<std::size_t>(i + grid.dims[0] * (j + grid.dims[1] * k))]) {
          sum += Eigen::Vector4d(static_cast<double>(i), static_cast<double>(j),
                                 static_cast<double>(k), 1);
          count += 1;
        }
  return specAffine(s) * (sum / count) * metresPerUnit(s.xyztUnits);
}

void expectOneLineNaming(const std::string& message, const std::string& path) {
  EXPECT_EQ(message.rfind(path, 0), 0u) << message;
  for (const char ch : message)
    EXPECT_TRUE(ch >= 0x20 && ch < 0x7f) << "byte " << static_cast<int>(ch) << " in " << message;
}

/// The message readLabelVolume throws for `path`, or "" when it reads.
std::string errorOf(const std::string& path, std::size_t maxMemory = 0) {
  try {
    VolumeReadParams params;
    params.maxMemory = maxMemory;
    (void)readLabelVolume(path, params);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// A rotation quaternion (b, c, d) of 40 degrees about a skew axis.
std::array<double, 3> skewQuaternion() {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  const double half = 20.0 * std::numbers::pi / 180.0;
  return {std::sin(half) * axis.x(), std::sin(half) * axis.y(), std::sin(half) * axis.z()};
}

/// A qform-only spec: rotation `q`, qfac -1, pixdim 1.5 x 2 x 2.5, an offset.
NiftiSpec qformSpec(int version, const SphereGrid& grid, std::array<double, 3> q) {
  NiftiSpec s = specOf(version, grid);
  s.qformCode = 1;
  s.pixdim = {-1, 1.5, 2, 2.5, 0, 0, 0, 0};
  s.quatern = {q[0], q[1], q[2], -30.5, 12.25, 48};
  return s;
}

/// An sform-only spec with a general (sheared, flipped) affine.
NiftiSpec sformSpec(int version, const SphereGrid& grid) {
  NiftiSpec s = specOf(version, grid);
  s.sformCode = 4;
  s.srow = {{{-1.2, 0.3, 0.1, 91.5}, {0.25, 1.9, -0.4, -120.25}, {0.05, 0.35, 2.4, -70.75}}};
  return s;
}

// --- Types, byte orders, versions, compression ---------------------------------------------

TEST(NiftiReader, ReadsEveryLabelTypeInBothByteOrdersAndVersions) {
  const TempDir dir;
  struct Case {
    int datatype;
    std::int64_t sphere, block;
  };
  const std::vector<Case> cases = {
      {test::kNiftiInt8, -7, 100},
      {test::kNiftiUInt8, 200, 3},
      {test::kNiftiInt16, -30000, 12},
      {test::kNiftiUInt16, 60000, 5},
      {test::kNiftiInt32, -2000000000, 7},
      {test::kNiftiUInt32, 4000000000, 9},
      {test::kNiftiInt64, -(std::int64_t{1} << 40), std::int64_t{1} << 50},
      {test::kNiftiUInt64, std::int64_t{1} << 62, 11},
      {test::kNiftiFloat32, 16777216, -3},
      {test::kNiftiFloat64, (std::int64_t{1} << 52) + 1, -3},
  };
  for (const Case& c : cases)
    for (int version : {1, 2})
      for (bool bigEndian : {false, true})
        for (bool gz : {false, true}) {
          SCOPED_TRACE("datatype " + std::to_string(c.datatype) + ", NIfTI-" +
                       std::to_string(version) + (bigEndian ? ", big-endian" : "") +
                       (gz ? ", .nii.gz" : ""));
          const SphereGrid grid = test::sphereGrid(kDims, kCentre, kRadius, c.sphere, c.block);
          const NiftiSpec spec = specOf(version, grid, c.datatype, bigEndian);
          const std::string path = writeSpec(dir, gz ? "v.nii.gz" : "v.nii", spec);
          const LabelVolume v = readLabelVolume(path);
          ASSERT_EQ(v.dims, (Index3{20, 22, 24}));
          ASSERT_EQ(v.labels.size(), 2u);
          EXPECT_EQ(v.labels[0].value, std::min(c.sphere, c.block));
          EXPECT_EQ(v.labels[1].value, std::max(c.sphere, c.block));
          const int sphereSlot = c.sphere < c.block ? 1 : 2;
          EXPECT_EQ(int{v.index[v.linear(9, 11, 12)]}, sphereSlot);
          EXPECT_EQ(int{v.index[v.linear(2, 1, 2)]}, 3 - sphereSlot);
          EXPECT_EQ(int{v.index[v.linear(0, 0, 0)]}, 0);
          EXPECT_EQ(v.labelCounts()[static_cast<std::size_t>(2 - sphereSlot)], 8u);
          EXPECT_EQ(v.placement, "voxel sizes only (no sform or qform)");
          EXPECT_TRUE(v.warnings.empty());
          EXPECT_LT((worldCentroid(v) - expectedCentroid(spec, grid)).norm(), 1e-9);
        }
}

TEST(NiftiReader, AcceptsTrailingUnitDimensionsExtensionsAndUnsetScaling) {
  const TempDir dir;
  const SphereGrid grid = defaultGrid();
  NiftiSpec s = specOf(1, grid);
  s.dim = {5, 20, 22, 24, 1, 1, 1, 1};
  s.sclSlope = 1;  // identity scaling
  EXPECT_EQ(readLabelVolume(writeSpec(dir, "a.nii", s)).labels.size(), 2u);
  s.sclSlope = 0;  // slope 0: no scaling, whatever the intercept
  s.sclInter = 5;
  EXPECT_EQ(readLabelVolume(writeSpec(dir, "b.nii", s)).labels.size(), 2u);
  s.sclSlope = std::nan("");
  EXPECT_EQ(readLabelVolume(writeSpec(dir, "c.nii", s)).labels.size(), 2u);
  // A comment extension between the header and vox_offset.
  s = specOf(1, grid);
  s.voxOffset = 384;
  std::string bytes = test::niftiBytes(s);
  bytes[348] = 1;  // extender: extensions follow
  test::putAt(bytes, 352, std::int32_t{32}, false);
  test::putAt(bytes, 356, std::int32_t{6}, false);  // NIFTI_ECODE_COMMENT
  bytes.replace(360, 12, "a comment...");
  const LabelVolume v = readLabelVolume(dir.write("ext.nii", bytes));
  EXPECT_EQ(v.labelCounts()[0], 8u);  // the block of label 3
  // Float labels holding whole numbers.
  s = specOf(2, grid, test::kNiftiFloat32);
  EXPECT_EQ(readLabelVolume(writeSpec(dir, "f.nii.gz", s)).labels[1].value, 7);
}

// --- Placement -------------------------------------------------------------------------------

TEST(NiftiOrientation, SformOnly) {
  const TempDir dir;
  for (int version : {1, 2}) {
    const SphereGrid grid = defaultGrid();
    const NiftiSpec s = sformSpec(version, grid);
    const LabelVolume v = readLabelVolume(writeSpec(dir, "s.nii", s));
    EXPECT_EQ(v.placement, "sform (code 4)");
    EXPECT_TRUE(v.warnings.empty());
    EXPECT_LT((worldCentroid(v) - expectedCentroid(s, grid)).norm(), 1e-9);
  }
}

TEST(NiftiOrientation, QformOnlyWithQfacMinusOneAndRotation) {
  const TempDir dir;
  for (int version : {1, 2}) {
    const SphereGrid grid = defaultGrid();
    const NiftiSpec s = qformSpec(version, grid, skewQuaternion());
    const LabelVolume v = readLabelVolume(writeSpec(dir, "q.nii.gz", s));
    EXPECT_EQ(v.placement, "qform (code 1)");
    EXPECT_TRUE(v.warnings.empty());
    EXPECT_LT((worldCentroid(v) - expectedCentroid(s, grid)).norm(), 1e-9);
    EXPECT_LT(v.axes.determinant(), 0);  // qfac -1 flips the k axis
  }
}

TEST(NiftiOrientation, BothAgreeingGiveNoWarning) {
  const TempDir dir;
  for (int version : {1, 2}) {
    const SphereGrid grid = defaultGrid();
    NiftiSpec s = qformSpec(version, grid, skewQuaternion());
    const Affine q = specAffine(s);
    s.sformCode = 2;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) s.srow[r][c] = q(r, c);
    const LabelVolume v = readLabelVolume(writeSpec(dir, "b.nii", s));
    EXPECT_EQ(v.placement, "sform (code 2)");
    EXPECT_TRUE(v.warnings.empty()) << v.warnings.front();
    EXPECT_LT((worldCentroid(v) - expectedCentroid(s, grid)).norm(), 1e-9);
  }
}

TEST(NiftiOrientation, BothDisagreeingUseTheSformWithOneWarning) {
  const TempDir dir;
  for (int version : {1, 2}) {
    const SphereGrid grid = defaultGrid();
    NiftiSpec s = qformSpec(version, grid, skewQuaternion());
    const Affine q = specAffine(s);
    s.sformCode = 2;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) s.srow[r][c] = q(r, c);
    s.srow[0][3] += 3.2;  // the sform 3.2 mm to the right of the qform
    const LabelVolume v = readLabelVolume(writeSpec(dir, "d.nii", s));
    EXPECT_EQ(v.placement, "sform (code 2)");
    ASSERT_EQ(v.warnings.size(), 1u);
    EXPECT_EQ(v.warnings[0],
              "sform (code 2) and qform (code 1) disagree by 3.2 mm; using the sform");
    EXPECT_LT((worldCentroid(v) - expectedCentroid(s, grid)).norm(), 1e-9);
  }
}

TEST(NiftiOrientation, NeitherUsesTheVoxelSizes) {
  const TempDir dir;
  const SphereGrid grid = defaultGrid();
  NiftiSpec s = specOf(2, grid);
  s.pixdim = {1, 0.5, 0.75, 1.25, 0, 0, 0, 0};
  const LabelVolume v = readLabelVolume(writeSpec(dir, "n.nii", s));
  EXPECT_EQ(v.placement, "voxel sizes only (no sform or qform)");
  EXPECT_TRUE(v.origin.isZero());
  EXPECT_TRUE(
      v.axes.isApprox(Eigen::Vector3d(0.5e-3, 0.75e-3, 1.25e-3).asDiagonal().toDenseMatrix()));
  EXPECT_LT((worldCentroid(v) - expectedCentroid(s, grid)).norm(), 1e-9);
}

TEST(NiftiOrientation, UnitsMetresMillimetresMicrometres) {
  const TempDir dir;
  const SphereGrid grid = defaultGrid();
  // Space units in the low 3 bits; time units (8: seconds, 16: ms) above them do not matter.
  for (int units : {0, 1, 2, 3, 2 | 8, 3 | 16}) {
    SCOPED_TRACE("xyzt_units " + std::to_string(units));
    NiftiSpec s = sformSpec(1, grid);
    s.xyztUnits = units;
    const LabelVolume v = readLabelVolume(writeSpec(dir, "u.nii", s));
    const Vec3d expected = expectedCentroid(s, grid);
    EXPECT_LT((worldCentroid(v) - expected).norm(), 1e-9);
    EXPECT_NEAR(v.spacing()[0], std::hypot(1.2, 0.25, 0.05) * metresPerUnit(units),
                1e-6 * metresPerUnit(units));
  }
}

// --- Against nibabel -------------------------------------------------------------------------

/// nibabel's shape and world points (file units) of `voxels` of `path`; nullopt when
/// /usr/bin/python3 or nibabel is missing.
std::optional<std::vector<std::vector<double>>> nibabelPoints(const std::string& path,
                                                              const std::vector<Index3>& voxels) {
  if (!std::filesystem::exists("/usr/bin/python3")) return std::nullopt;
  std::string command = std::string("/usr/bin/python3 '") + VOXCUT_SOURCE_DIR +
                        "/tests/io/nibabel_orientation.py' '" + path + "'";
  for (const Index3& v : voxels)
    command += " " + std::to_string(v.x) + " " + std::to_string(v.y) + " " + std::to_string(v.z);
  FILE* pipe = popen((command + " 2>/dev/null").c_str(), "r");
  if (!pipe) return std::nullopt;
  std::string out;
  char buf[4096];
  while (const std::size_t n = std::fread(buf, 1, sizeof buf, pipe)) out.append(buf, n);
  const int status = pclose(pipe);
  if (!WIFEXITED(status) || WEXITSTATUS(status) == 3) return std::nullopt;
  EXPECT_EQ(WEXITSTATUS(status), 0) << out;
  // [[nx, ny, nz], [x, y, z], ...]: brackets and commas to spaces, then numbers per triple.
  for (char& ch : out)
    if (ch == '[' || ch == ']' || ch == ',') ch = ' ';
  std::istringstream in(out);
  std::vector<std::vector<double>> rows;
  double a, b, c;
  while (in >> a >> b >> c) rows.push_back({a, b, c});
  EXPECT_EQ(rows.size(), voxels.size() + 1);
  return rows;
}

/// Expects our world point (m) of each voxel to be nibabel's (mm) within 1e-6 mm.
void expectNibabelAgrees(const std::string& path, const LabelVolume& v) {
  const Index3 d = v.dims;
  const std::vector<Index3> voxels = {{0, 0, 0},
                                      {d.x - 1, 0, 0},
                                      {0, d.y - 1, 0},
                                      {0, 0, d.z - 1},
                                      {d.x - 1, d.y - 1, d.z - 1},
                                      {d.x / 2, d.y / 3, d.z / 4},
                                      {d.x / 5, d.y - 2, d.z / 2}};
  const auto points = nibabelPoints(path, voxels);
  if (!points) GTEST_SKIP() << "/usr/bin/python3 with nibabel is not available";
  ASSERT_EQ(points->size(), voxels.size() + 1);
  EXPECT_EQ((*points)[0], (std::vector<double>{static_cast<double>(d.x), static_cast<double>(d.y),
                                               static_cast<double>(d.z)}));
  for (std::size_t n = 0; n < voxels.size(); ++n) {
    const Vec3d ours = v.world(Vec3d(voxels[n].x, voxels[n].y, voxels[n].z)) * 1e3;
    const Vec3d theirs((*points)[n + 1][0], (*points)[n + 1][1], (*points)[n + 1][2]);
    EXPECT_LT((ours - theirs).norm(), 1e-6)
        << "voxel " << voxels[n].x << " " << voxels[n].y << " " << voxels[n].z << ": ours "
        << ours.transpose() << ", nibabel " << theirs.transpose();
  }
}

TEST(NiftiNibabel, AalAtlas) {
  const std::string path = "/usr/share/mricron/templates/aal.nii.gz";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is missing (mricron-data)";
  const LabelVolume v = readLabelVolume(path);
  EXPECT_EQ(v.dims, (Index3{181, 217, 181}));
  EXPECT_EQ(v.labels.size(), 116u);
  std::size_t labelled = 0;
  for (const std::size_t n : v.labelCounts()) labelled += n;
  EXPECT_EQ(labelled, 1479969u);
  EXPECT_EQ(v.placement, "sform (code 4)");
  expectNibabelAgrees(path, v);
}

TEST(NiftiNibabel, HandWrittenSform) {
  const TempDir dir;
  for (int version : {1, 2}) {
    const std::string path =
        writeSpec(dir, "s" + std::to_string(version) + ".nii", sformSpec(version, defaultGrid()));
    expectNibabelAgrees(path, readLabelVolume(path));
  }
}

TEST(NiftiNibabel, HandWrittenQformWithQfacMinusOne) {
  const TempDir dir;
  // NIfTI-1 stores the quaternion as float32, and nibabel computes with it in float32: a
  // quaternion exact in float32 (120 degrees about (1, -1, 1)) keeps the comparison at 1e-6 mm.
  const std::string path1 = writeSpec(dir, "q1.nii", qformSpec(1, defaultGrid(), {0.5, -0.5, 0.5}));
  expectNibabelAgrees(path1, readLabelVolume(path1));
  const std::string path2 =
      writeSpec(dir, "q2.nii.gz", qformSpec(2, defaultGrid(), skewQuaternion()));
  expectNibabelAgrees(path2, readLabelVolume(path2));
}

TEST(NiftiNibabel, HandWrittenBothDisagreeing) {
  const TempDir dir;
  for (int version : {1, 2}) {
    NiftiSpec s = qformSpec(version, defaultGrid(), {0.5, -0.5, 0.5});
    s.sformCode = 2;
    s.srow = {{{-1.2, 0.3, 0.1, 91.5}, {0.25, 1.9, -0.4, -120.25}, {0.05, 0.35, 2.4, -70.75}}};
    const std::string path = writeSpec(dir, "d" + std::to_string(version) + ".nii", s);
    const LabelVolume v = readLabelVolume(path);
    EXPECT_EQ(v.warnings.size(), 1u);
    expectNibabelAgrees(path, v);
  }
}

// --- Bad input -------------------------------------------------------------------------------

struct BadCase {
  std::string name;    ///< file name (its extension picks the reader)
  std::string bytes;   ///< content
  std::string needle;  ///< what the message must contain besides the path
  std::size_t maxMemory = 0;
};

std::vector<BadCase> badCases() {
  const SphereGrid grid = defaultGrid();
  const std::string good1 = test::niftiBytes(specOf(1, grid));
  const std::string good2 = test::niftiBytes(specOf(2, grid, test::kNiftiInt16, true));
  std::vector<BadCase> cases;
  auto add = [&](std::string name, std::string bytes, std::string needle,
                 std::size_t maxMemory = 0) {
    cases.push_back({std::move(name), std::move(bytes), std::move(needle), maxMemory});
  };
  auto mutated = [&](int version, auto change) {
    NiftiSpec s = specOf(version, grid);
    change(s);
    return test::niftiBytes(s);
  };
  add("truncated.nii", good1.substr(0, good1.size() - 100), "truncated");
  add("truncated2.nii", good2.substr(0, good2.size() - 1), "truncated");
  add(
      "truncated.nii.gz",
      [&] {
        const std::string gz = test::gzipped(good1);
        return gz.substr(0, gz.size() / 2);
      }(),
      "truncated");
  add("header-only.nii", good1.substr(0, 352), "truncated");
  add("lies-larger.nii", mutated(1, [](NiftiSpec& s) { s.dim[3] = 25; }), "truncated");
  add("lies-smaller.nii", mutated(1, [](NiftiSpec& s) { s.dim[3] = 23; }), "after");
  add("lies-smaller.nii.gz", test::gzipped(mutated(2, [](NiftiSpec& s) { s.dim[1] = 19; })),
      "more than");
  add("lies-larger.nii.gz", test::gzipped(mutated(2, [](NiftiSpec& s) { s.dim[2] = 30; })),
      "the header declares");
  add("dim0.nii", mutated(1, [](NiftiSpec& s) { s.dim[2] = 0; }), "dim[2] is 0");
  add("dim-neg.nii", mutated(2, [](NiftiSpec& s) { s.dim[3] = -5; }), "dim[3] is -5");
  add("ndim2.nii", mutated(1, [](NiftiSpec& s) { s.dim[0] = 2; }), "2-D data");
  add("ndim9.nii", mutated(1, [](NiftiSpec& s) { s.dim[0] = 9; }), "dim[0] is 9");
  add("huge.nii",
      mutated(2,
              [](NiftiSpec& s) {
                s.dim = {3, 100000, 100000, 100000, 1, 1, 1, 1};
                s.data.clear();
              }),
      "exceed 2^31 voxels", std::size_t{1} << 30);
  add("huge1.nii",
      mutated(1,
              [](NiftiSpec& s) {
                s.dim = {3, 32767, 32767, 32767, 1, 1, 1, 1};
                s.data.clear();
              }),
      "exceed 2^31 voxels", std::size_t{1} << 30);
  add("over-memory.nii.gz",
      test::gzipped(mutated(2,
                            [](NiftiSpec& s) {
                              s.dim = {3, 1200, 1200, 1200, 1, 1, 1, 1};
                              s.data.clear();
                            })),
      "over the limit", std::size_t{1} << 30);
  add("huge-int.nii",
      mutated(2,
              [](NiftiSpec& s) {
                s.dim = {3, std::int64_t{1} << 40, 1, 1, 1, 1, 1, 1};
                s.data.clear();
              }),
      "dim[1] is 1099511627776");
  for (const double bad : {0.0, -1.0, std::nan(""), HUGE_VAL})
    for (int axis = 1; axis <= 3; ++axis)
      add("pixdim" + std::to_string(axis) + ".nii",
          mutated(axis == 2 ? 2 : 1,
                  [&](NiftiSpec& s) { s.pixdim[static_cast<std::size_t>(axis)] = bad; }),
          "pixdim[" + std::to_string(axis) + "]");
  add("5d.nii", mutated(1, [](NiftiSpec& s) { s.dim = {5, 20, 22, 24, 1, 3, 1, 1}; }),
      "5-D data are not supported");
  add("4d.nii", mutated(2, [](NiftiSpec& s) { s.dim = {4, 20, 22, 24, 2, 1, 1, 1}; }),
      "4-D data are not supported");
  add("complex.nii", mutated(1, [](NiftiSpec& s) { s.datatype = test::kNiftiComplex64; }),
      "datatype 32 (COMPLEX64)");
  add("rgb.nii", mutated(2, [](NiftiSpec& s) { s.datatype = test::kNiftiRgb24; }),
      "datatype 128 (RGB24)");
  add("binary.nii", mutated(1, [](NiftiSpec& s) { s.datatype = 1; }), "(BINARY)");
  add("type-unknown.nii", mutated(1, [](NiftiSpec& s) { s.datatype = 9999; }), "not a NIfTI type");
  add("zeros.nii", mutated(1, [](NiftiSpec& s) { std::fill(s.data.begin(), s.data.end(), 0); }),
      "no non-zero label");
  add("half.nii",
      mutated(1,
              [&](NiftiSpec& s) {
                s.datatype = test::kNiftiFloat32;
                s.data = test::niftiSamples(grid.values, test::kNiftiFloat32, false);
                test::putAt(s.data, 4 * (9 + 20 * (11 + 22 * 12)), 1.5f, false);
              }),
      "voxel (9, 11, 12)");
  add("scaled.nii", mutated(1, [](NiftiSpec& s) { s.sclSlope = 2; }), "scl_slope 2");
  add("shifted.nii",
      mutated(2,
              [](NiftiSpec& s) {
                s.sclSlope = 1;
                s.sclInter = -1;
              }),
      "scl_inter -1");
  add("pair.nii", mutated(1, [](NiftiSpec& s) { s.magic = std::string("ni1\0", 4); }),
      "separate .img");
  add("analyze.nii", mutated(1, [](NiftiSpec& s) { s.magic = std::string("\0\0\0\0", 4); }),
      "ANALYZE");
  add("text-mode.nii",
      mutated(2, [](NiftiSpec& s) { s.magic = std::string("n+2\0\n\x1a\n\0", 8); }), "damaged");
  add("offset0.nii", mutated(1, [](NiftiSpec& s) { s.voxOffset = 0; }), "vox_offset 0 lies inside");
  add("offset-frac.nii", mutated(1, [](NiftiSpec& s) { s.voxOffset = 352.5; }),
      "vox_offset 352.5 is not a byte offset");
  add("sform-nan.nii",
      mutated(1,
              [](NiftiSpec& s) {
                s.sformCode = 1;
                s.srow = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, std::nan("")}}};
              }),
      "srow_z[3] is nan");
  add("sform-flat.nii",
      mutated(2,
              [](NiftiSpec& s) {
                s.sformCode = 1;
                s.srow = {{{1, 1, 0, 0}, {1, 1, 0, 0}, {0, 0, 1, 0}}};  // i and j axes parallel
              }),
      "degenerate");
  add("qform-nan.nii",
      mutated(2,
              [](NiftiSpec& s) {
                s.qformCode = 1;
                s.quatern = {0, std::nan(""), 0, 0, 0, 0};
              }),
      "qform (code 1) is unusable");
  add("qform-long.nii",
      mutated(2,
              [](NiftiSpec& s) {
                s.qformCode = 1;
                s.quatern = {1, 1, 0, 0, 0, 0};
              }),
      "longer than 1");
  add("far.nii",
      mutated(2,
              [](NiftiSpec& s) {
                s.sformCode = 1;
                s.srow = {{{1, 0, 0, 1e12}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
              }),
      "1e6 m");
  add("negative-code.nii", mutated(1, [](NiftiSpec& s) { s.sformCode = -2; }),
      "sform_code -2 is negative");
  add("gzip-named-nii.nii", test::gzipped(good1), "name it .nii.gz");
  add("plain-named-gz.nii.gz", good1, "not gzip-compressed");
  add("garbage.nii.gz", std::string("\x1f\x8b") + std::string(600, 'x'), "corrupt gzip");
  add("empty.nii", "", "empty");
  add("empty.nii.gz", "", "empty");
  add("short.nii", good1.substr(0, 100), "too short");
  add("short2.nii", good2.substr(0, 400), "too short for a NIfTI-2 header");
  std::mt19937 random(12345);
  std::string noise(4000, '\0');
  for (char& ch : noise) ch = static_cast<char>(random() & 0xff);
  add("random.nii", noise, "not a NIfTI file");
  add("random.nii.gz", test::gzipped(noise), "not a NIfTI file");
  add("image.hdr", good1.substr(0, 348), "not a label volume");
  return cases;
}

TEST(NiftiInputErrors, EachBadFileIsOneLineNamingTheFileAndTheField) {
  const TempDir dir;
  for (const BadCase& c : badCases()) {
    SCOPED_TRACE(c.name);
    const std::string path = dir.write(c.name, c.bytes);
    const auto start = std::chrono::steady_clock::now();
    const std::string message = errorOf(path, c.maxMemory);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_FALSE(message.empty()) << "read without an error";
    expectOneLineNaming(message, path);
    EXPECT_NE(message.find(c.needle), std::string::npos) << message;
    EXPECT_LT(seconds, 2.0);
  }
}

TEST(NiftiInputErrors, MissingFilesDirectoriesAndOddNames) {
  const TempDir dir;
  EXPECT_NE(errorOf(dir.file("missing.nii")).find("no such file"), std::string::npos);
  EXPECT_NE(errorOf(dir.file("missing.nii.gz")).find("no such file"), std::string::npos);
  std::filesystem::create_directories(dir.file("folder.nii"));
  EXPECT_NE(errorOf(dir.file("folder.nii")).find("is a directory"), std::string::npos);
  // A name with a newline and a tab: the message stays one line.
  const std::string path = dir.write("odd\nname\t.nii", "");
  const std::string message = errorOf(path);
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  EXPECT_NE(message.find("odd\\nname\\t.nii"), std::string::npos) << message;
}

TEST(NiftiInputErrors, NifticlibStaysSilent) {
  const TempDir dir;
  testing::internal::CaptureStderr();
  for (const BadCase& c : badCases()) (void)errorOf(dir.write(c.name, c.bytes), c.maxMemory);
  (void)readLabelVolume(writeSpec(dir, "good.nii", qformSpec(1, defaultGrid(), {0.5, 0.5, 0.5})));
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

TEST(NiftiInputErrors, MemoryLimitIsCheckedBeforeReading) {
  const TempDir dir;
  // 20 x 22 x 24 uint8 voxels need 31,680 bytes: a limit below refuses them, above reads them.
  const std::string path = writeSpec(dir, "v.nii.gz", specOf(1, defaultGrid()));
  EXPECT_NE(errorOf(path, 20000).find("over the limit"), std::string::npos);
  EXPECT_EQ(errorOf(path, 40000), "");
}

}  // namespace
}  // namespace voxcut
