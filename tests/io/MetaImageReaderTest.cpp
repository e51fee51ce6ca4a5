// The MetaImage reader (readMetaImage, through readLabelVolume): every element type, raw and
// zlib-compressed, both byte orders, .mha and .mhd with a detached file; ITK's LPS placement
// with a TransformMatrix converted to RAS metres (and agreeing with the NRRD reader on the same
// object); and malformed files, each one InputError line naming the file and the key.

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "TempDir.h"
#include "VolumeFiles.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/VolumeFormats.h"
#include "voxcut/io/VolumeReader.h"

namespace voxcut {
namespace {

using test::MetaHeader;
using test::TempDir;

constexpr double kTol = 1e-9;  // metres
constexpr std::size_t kMaxMemory = std::size_t{256} << 20;

// Placement most tests write (LPS mm): spacing 0.5 0.75 1.25, Offset (-10, 20, 30).
const std::vector<std::string> kPlacement = {
    "TransformMatrix = 1 0 0 0 1 0 0 0 1", "Offset = -10 20 30", "ElementSpacing = 0.5 0.75 1.25"};
// The sphere's centre with kPlacement: LPS (-6, 26, 38.75) mm as RAS metres.
const Vec3d kCentre(0.006, -0.026, 0.03875);

LabelVolume readOk(const std::string& path) {
  try {
    return readLabelVolume(path);
  } catch (const InputError& e) {
    ADD_FAILURE() << "refused: " << e.what();
    throw;
  }
}

void expectRefused(const std::string& path, const std::vector<std::string>& parts) {
  VolumeReadParams params;
  params.maxMemory = kMaxMemory;
  try {
    (void)readLabelVolume(path, params);
    ADD_FAILURE() << path << " was read";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path, 0), 0u) << message;
    for (const std::string& part : parts)
      EXPECT_NE(message.find(part), std::string::npos) << message;
    EXPECT_TRUE(test::isPrintable(message)) << message;
  }
}

struct TypeCase {
  const char* name;
  SampleType type;
  std::int64_t sphere;
  std::int64_t box;
};

class MetaImageReaderTypes : public ::testing::TestWithParam<TypeCase> {};

TEST_P(MetaImageReaderTypes, ReadsRawAndCompressedInBothByteOrdersMhaAndMhd) {
  const TypeCase& c = GetParam();
  const test::LabelGrid grid = test::sphereAndBox(c.sphere, c.box);
  TempDir dir;
  int n = 0;
  for (const bool compressed : {false, true})
    for (const bool msb : {false, true})
      for (const bool detached : {false, true}) {
        SCOPED_TRACE(std::string(compressed ? "compressed" : "raw") + (msb ? " MSB" : " LSB") +
                     (detached ? " .mhd" : " .mha"));
        MetaHeader h;
        h.elementType = c.name;
        h.msb = msb;
        h.compressed = compressed;
        h.extra = kPlacement;
        h.extra.push_back("AnatomicalOrientation = RAI");
        std::string data = test::samplesOf(grid, c.type, msb);
        if (compressed) {
          data = test::deflated(data, false);
          if (n % 2 == 0) h.extra.push_back("CompressedDataSize = " + std::to_string(data.size()));
        }
        const std::string stem = "vol" + std::to_string(n++);
        std::string path;
        if (detached) {
          h.dataFile = stem + (compressed ? ".zraw" : ".raw");
          dir.write(h.dataFile, data);
          path = dir.write(stem + ".mhd", h.text());
        } else {
          path = dir.write(stem + ".mha", h.text() + data);
        }
        const LabelVolume v = readOk(path);
        EXPECT_EQ(v.dims, grid.dims);
        ASSERT_EQ(v.labels.size(), 2u);
        EXPECT_EQ(test::voxelsOf(v, c.sphere), test::countOf(grid, c.sphere));
        EXPECT_EQ(test::voxelsOf(v, c.box), test::countOf(grid, c.box));
        EXPECT_LT((test::worldCentroid(v, c.sphere) - kCentre).norm(), kTol);
        EXPECT_NE(v.placement.find("RAI"), std::string::npos) << v.placement;
      }
}

INSTANTIATE_TEST_SUITE_P(
    MetaImageTypes, MetaImageReaderTypes,
    ::testing::Values(TypeCase{"MET_CHAR", SampleType::Int8, -5, 100},
                      TypeCase{"MET_UCHAR", SampleType::UInt8, 5, 200},
                      TypeCase{"MET_SHORT", SampleType::Int16, -300, 30000},
                      TypeCase{"MET_USHORT", SampleType::UInt16, 5, 40000},
                      TypeCase{"MET_INT", SampleType::Int32, -70000, 2000000000},
                      TypeCase{"MET_UINT", SampleType::UInt32, 5, 3000000000},
                      TypeCase{"MET_LONG", SampleType::Int32, -7, 100000},
                      TypeCase{"MET_ULONG", SampleType::UInt32, 7, 4000000000},
                      TypeCase{"MET_LONG_LONG", SampleType::Int64, -5, 5000000000000},
                      TypeCase{"MET_ULONG_LONG", SampleType::UInt64, 5, 9000000000000},
                      TypeCase{"MET_FLOAT", SampleType::Float32, 5, 1000000},
                      TypeCase{"MET_DOUBLE", SampleType::Float64, -5, 4000000000}),
    [](const ::testing::TestParamInfo<TypeCase>& param) { return std::string(param.param.name); });

TEST(MetaImageReader, RefusesFloatLabelsThatAreNotWholeNumbers) {
  TempDir dir;
  std::vector<double> values(24, 2.0);
  values[13] = 1.5;
  MetaHeader h;
  h.elementType = "MET_FLOAT";
  h.dimSize = "4 3 2";
  expectRefused(dir.write("f.mha", h.text() + test::samplesOf(values, SampleType::Float32, false)),
                {"voxel (1, 0, 1)", "not an integer label"});
}

// TransformMatrix lists the direction of index axis a as numbers 3a..3a+2 (ITK's reading);
// the test uses a rotation that is not symmetric, so the transposed reading would misplace it.
TEST(MetaImageReader, TransformMatrixRowsAreAxisDirections) {
  const Eigen::Matrix3d rotation =
      (Eigen::AngleAxisd(0.5, Vec3d::UnitZ()) * Eigen::AngleAxisd(0.3, Vec3d::UnitX()))
          .toRotationMatrix();
  ASSERT_GT((rotation - rotation.transpose()).norm(), 0.1);
  const Vec3d spacing(0.6, 0.9, 1.3);
  const Vec3d offset(-40.5, 12.25, 88);
  std::string matrix = "TransformMatrix =";
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) {
      char number[32];
      std::snprintf(number, sizeof number, " %.17g", rotation(c, a));
      matrix += number;
    }
  MetaHeader h;
  h.extra = {matrix, "Offset = -40.5 12.25 88", "ElementSpacing = 0.6 0.9 1.3"};
  TempDir dir;
  const LabelVolume v = readOk(dir.write(
      "rot.mha", h.text() + test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false)));
  const Eigen::Matrix3d lpsAxes = rotation * spacing.asDiagonal();
  const Eigen::Matrix3d toRas = Vec3d(-1e-3, -1e-3, 1e-3).asDiagonal();
  EXPECT_LT((v.axes - toRas * lpsAxes).norm(), kTol);
  const Vec3d expected = toRas * (offset + lpsAxes * test::kSphereCentre);
  EXPECT_LT((test::worldCentroid(v, 1) - expected).norm(), kTol);
}

// The same physical object as NRRD in LPS and as MetaImage lands on the same RAS point.
TEST(MetaImageReader, AgreesWithNrrdOnTheSameObject) {
  const std::string data = test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false);
  TempDir dir;
  test::NrrdHeader nrrd;
  // Direction of axis 0 (0,1,0), axis 1 (-1,0,0), axis 2 (0,0,1), scaled by the spacings.
  nrrd.extra = {"space: left-posterior-superior",
                "space directions: (0,0.5,0) (-0.75,0,0) (0,0,1.25)", "space origin: (3,-4,5)"};
  MetaHeader meta;
  meta.extra = {"TransformMatrix = 0 1 0 -1 0 0 0 0 1", "Offset = 3 -4 5",
                "ElementSpacing = 0.5 0.75 1.25"};
  const LabelVolume a = readOk(dir.write("a.nrrd", nrrd.text() + data));
  const LabelVolume b = readOk(dir.write("b.mha", meta.text() + data));
  EXPECT_LT((a.axes - b.axes).norm(), kTol);
  EXPECT_LT((a.origin - b.origin).norm(), kTol);
  EXPECT_LT((test::worldCentroid(a, 1) - test::worldCentroid(b, 1)).norm(), kTol);
  EXPECT_LT((test::worldCentroid(b, 2) - test::worldCentroid(a, 2)).norm(), kTol);
}

TEST(MetaImageReader, SpacingFallbacksAndUnits) {
  const std::string data = test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false);
  TempDir dir;
  MetaHeader size;
  size.extra = {"ElementSize = 2 3 4", "Origin = 1 1 1"};
  LabelVolume v = readOk(dir.write("size.mha", size.text() + data));
  EXPECT_LT((v.axes - Eigen::Matrix3d(Vec3d(-2e-3, -3e-3, 4e-3).asDiagonal())).norm(), kTol);
  EXPECT_LT((v.origin - Vec3d(-1e-3, -1e-3, 1e-3)).norm(), kTol);
  MetaHeader none;
  v = readOk(dir.write("none.mha", none.text() + data));
  EXPECT_LT((v.axes - Eigen::Matrix3d(Vec3d(-1e-3, -1e-3, 1e-3).asDiagonal())).norm(), kTol);
  ASSERT_FALSE(v.warnings.empty());
  EXPECT_NE(v.warnings[0].find("ElementSpacing"), std::string::npos);
  MetaHeader um;
  um.extra = {"ElementSpacing = 100 100 100", "Position = 10 0 0", "DistanceUnits = um"};
  v = readOk(dir.write("um.mha", um.text() + data));
  EXPECT_LT((v.axes - Eigen::Matrix3d(Vec3d(-1e-4, -1e-4, 1e-4).asDiagonal())).norm(), kTol);
  EXPECT_LT((v.origin - Vec3d(-1e-5, 0, 0)).norm(), kTol);
}

TEST(MetaImageReader, FourDimensionsWithALastSizeOfOne) {
  TempDir dir;
  MetaHeader h;
  h.ndims = 4;
  h.dimSize = "20 18 16 1";
  h.extra = {"ElementSpacing = 0.5 0.75 1.25 1", "Offset = -10 20 30 0",
             "TransformMatrix = 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1", "ElementNumberOfChannels = 1"};
  const LabelVolume v = readOk(dir.write(
      "four.mha", h.text() + test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false)));
  EXPECT_EQ(v.dims, (Index3{20, 18, 16}));
  EXPECT_LT((test::worldCentroid(v, 1) - kCentre).norm(), kTol);
}

TEST(MetaImageReader, DetachedHeaderSizes) {
  const test::LabelGrid grid = test::sphereAndBox();
  const std::string data = test::samplesOf(grid, SampleType::Int16, true);
  TempDir dir;
  MetaHeader h;
  h.elementType = "MET_SHORT";
  h.msb = true;
  h.extra = kPlacement;
  dir.write("head.raw", "1234567" + data);
  MetaHeader skip = h;
  skip.extra.push_back("HeaderSize = 7");
  skip.dataFile = "head.raw";
  EXPECT_EQ(test::voxelsOf(readOk(dir.write("skip.mhd", skip.text())), 1), test::countOf(grid, 1));
  MetaHeader tail = h;
  tail.extra.push_back("HeaderSize = -1");
  tail.dataFile = "head.raw";
  EXPECT_EQ(test::voxelsOf(readOk(dir.write("tail.mhd", tail.text())), 2), test::countOf(grid, 2));
  MetaHeader zipped = h;
  zipped.compressed = true;
  zipped.extra.push_back("HeaderSize = 3");
  zipped.dataFile = "head.zraw";
  dir.write("head.zraw", "abc" + test::deflated(data, false));
  EXPECT_EQ(test::voxelsOf(readOk(dir.write("zipped.mhd", zipped.text())), 1),
            test::countOf(grid, 1));
  // Without HeaderSize the file must hold exactly the samples.
  MetaHeader exact = h;
  exact.dataFile = "head.raw";
  expectRefused(dir.write("exact.mhd", exact.text()), {"data file 'head.raw'", "more than"});
  dir.write("short.raw", data.substr(3));
  exact.dataFile = "short.raw";
  expectRefused(dir.write("short.mhd", exact.text()), {"data file 'short.raw'", "fewer than"});
  tail.dataFile = "short.raw";
  expectRefused(dir.write("tailshort.mhd", tail.text()), {"fewer than"});
  zipped.extra.back() = "HeaderSize = -1";
  expectRefused(dir.write("zippedtail.mhd", zipped.text()), {"key 'HeaderSize'"});
}

TEST(MetaImageReader, DetachedDataFileMustBeInsideTheFolderAndExist) {
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "sub");
  dir.write("outside.raw", std::string(24, '\1'));
  auto header = [](const std::string& file) {
    MetaHeader h;
    h.dimSize = "4 3 2";
    h.dataFile = file;
    return h.text();
  };
  expectRefused(dir.write("sub/up.mhd", header("../outside.raw")),
                {"data file '../outside.raw'", "outside the folder"});
  expectRefused(dir.write("sub/etc.mhd", header("/etc/passwd")), {"outside the folder"});
  expectRefused(dir.write("sub/missing.mhd", header("missing.raw")),
                {"data file 'missing.raw'", "does not exist"});
  expectRefused(dir.write("sub/list.mhd", header("LIST") + "a.raw\n"), {"LIST"});
  expectRefused(dir.write("sub/pattern.mhd", header("slice%03d.raw 1 4 1")),
                {"numbered data files"});
  dir.write("sub/inside.raw", std::string(24, '\1'));
  EXPECT_EQ(readOk(dir.write("sub/ok.mhd", header("inside.raw"))).labels.size(), 1u);
}

TEST(MetaImageReader, EmptySegmentationIsRefused) {
  TempDir dir;
  MetaHeader h;
  h.dimSize = "4 3 2";
  expectRefused(dir.write("empty.mha", h.text() + std::string(24, '\0')), {"no non-zero label"});
}

TEST(MetaImageReaderInputErrors, EachIsOneClearLine) {
  const std::string data(24, '\1');
  const auto with = [](std::vector<std::string> extra, const std::string& dims = "4 3 2") {
    MetaHeader h;
    h.dimSize = dims;
    h.extra = std::move(extra);
    return h.text();
  };
  const std::string full = test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false);
  const std::string compressed = test::deflated(full, false);
  MetaHeader zipped;
  zipped.compressed = true;
  MetaHeader fiveD;
  fiveD.ndims = 5;
  fiveD.dimSize = "4 3 2 1 1";
  MetaHeader twoD;
  twoD.ndims = 2;
  twoD.dimSize = "4 6";
  MetaHeader fourD;
  fourD.ndims = 4;
  fourD.dimSize = "4 3 2 3";
  const std::string typeLine = "ElementType = MET_UCHAR";
  const auto withType = [&](const std::string& type) {
    std::string s = with({});
    return s.replace(s.find(typeLine), typeLine.size(), "ElementType = " + type);
  };
  struct Case {
    const char* name;
    std::string bytes;
    std::vector<std::string> parts;
  };
  const std::vector<Case> cases = {
      {"truncated", zipped.text() + compressed.substr(0, compressed.size() / 2), {"truncated"}},
      {"compressed_size_lies",
       [&] {
         MetaHeader h = zipped;
         h.extra = {"CompressedDataSize = 999999"};
         return h.text();
       }() +
           compressed,
       {"key 'CompressedDataSize'", "999999"}},
      {"short", with({}) + data.substr(1), {"23 bytes", "fewer than the 24"}},
      {"long", with({}) + data + "xy", {"26 bytes", "more than the 24"}},
      {"zero_size", with({}, "4 0 2") + data, {"key 'DimSize'", "must be positive"}},
      {"negative_size", with({}, "-4 3 2") + data, {"key 'DimSize'", "must be positive"}},
      {"nan_size", with({}, "4 3 nan") + data, {"key 'DimSize'", "'nan'"}},
      {"few_sizes", with({}, "4 3") + data, {"key 'DimSize'", "2 sizes"}},
      {"huge", with({}, "100000 100000 100000"), {"exceed 2^31 voxels"}},
      {"over_memory", with({}, "1000 1000 1000"), {"over the limit of 256 MiB"}},
      {"zero_spacing", with({"ElementSpacing = 1 0 1"}) + data, {"key 'ElementSpacing'"}},
      {"negative_spacing",
       with({"ElementSpacing = 1 1 -1"}) + data,
       {"key 'ElementSpacing'", "positive"}},
      {"nan_spacing", with({"ElementSpacing = nan 1 1"}) + data, {"key 'ElementSpacing'", "'nan'"}},
      {"inf_spacing", with({"ElementSpacing = 1 inf 1"}) + data, {"key 'ElementSpacing'", "'inf'"}},
      {"nan_offset", with({"Offset = 0 nan 0"}) + data, {"key 'Offset'"}},
      {"short_matrix",
       with({"TransformMatrix = 1 0 0 0 1 0 0 0"}) + data,
       {"key 'TransformMatrix'", "8 values"}},
      {"singular_matrix", with({"TransformMatrix = 1 0 0 1 0 0 0 0 1"}) + data, {"degenerate"}},
      {"five_d", fiveD.text() + data, {"key 'NDims'", "5-D"}},
      {"two_d", twoD.text() + data, {"key 'NDims'", "2-D"}},
      {"four_d_time", fourD.text() + data + data + data, {"key 'DimSize'", "4th dimension"}},
      {"string_type", withType("MET_STRING") + data, {"key 'ElementType'", "'MET_STRING'"}},
      {"array_type", withType("MET_FLOAT_ARRAY") + data, {"'MET_FLOAT_ARRAY'"}},
      {"float_fraction",
       withType("MET_DOUBLE") +
           test::samplesOf(std::vector<double>(24, 0.25), SampleType::Float64, false),
       {"not an integer label"}},
      {"channels",
       with({"ElementNumberOfChannels = 3"}) + data + data + data,
       {"key 'ElementNumberOfChannels'"}},
      {"ascii",
       with({"BinaryData = False"}).replace(with({}).find("BinaryData = True"), 18, "") + "1 1 1",
       {"BinaryData"}},
      {"not_bool",
       with({}).replace(with({}).find("CompressedData = False"), 22, "CompressedData = maybe") +
           data,
       {"key 'CompressedData'", "'maybe'"}},
      {"no_data_file_line",
       "ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\n",
       {"ElementDataFile"}},
      {"no_ndims",
       "DimSize = 4 3 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n" + data,
       {"key 'NDims' is missing"}},
      {"binary_garbage",
       std::string("\x89PNG\r\n\x1a\n\0\0", 10) + data,
       {"not 'Key = Value'", "\\x89PNG"}},
      {"twice", with({"Offset = 0 0 0", "Offset = 1 1 1"}) + data, {"'Offset'", "twice"}},
      {"control_bytes",
       withType(std::string("MET_\x01\x1b[0m\xff", 10)) + data,
       {"key 'ElementType'", "\\x01", "\\x1B", "\\xFF"}},
      {"object_mesh",
       with({}).replace(0, 18, "ObjectType = Mesh") + data,
       {"key 'ObjectType'", "'Mesh'"}},
      {"units", with({"DistanceUnits = furlong"}) + data, {"key 'DistanceUnits'", "'furlong'"}},
  };
  TempDir dir;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    expectRefused(dir.write(std::string(c.name) + ".mha", c.bytes), c.parts);
  }
}

}  // namespace
}  // namespace voxcut
