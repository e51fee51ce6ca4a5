// The NRRD reader (readNrrd, through readLabelVolume): every sample type, raw and gzip, both
// byte orders, attached and detached data; placement in RAS metres from each space; 3D
// Slicer segmentations, layered ones with overlaps; and malformed files, each one InputError
// line that names the file and the field and quotes no raw byte.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "TempDir.h"
#include "VolumeFiles.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/VolumeFormats.h"
#include "voxcut/io/VolumeReader.h"

namespace voxcut {
namespace {

using test::NrrdHeader;
using test::TempDir;

constexpr double kTol = 1e-9;  // metres
constexpr std::size_t kMaxMemory = std::size_t{256} << 20;

// The placement most tests write: LPS, anisotropic, off the origin (millimetres).
const std::vector<std::string> kLpsPlacement = {"space: left-posterior-superior",
                                                "space directions: (0.5,0,0) (0,0.75,0) (0,0,1.25)",
                                                "space origin: (-10,20,30)"};
// Where the sphere's centre lands with kLpsPlacement: LPS (-10 + 0.5*8, 20 + 0.75*8,
// 30 + 1.25*7) mm, RAS metres.
const Vec3d kLpsCentre(0.006, -0.026, 0.03875);

// Reads `path`; fails the test with the message if the reader refuses it.
LabelVolume readOk(const std::string& path) {
  try {
    return readLabelVolume(path);
  } catch (const InputError& e) {
    ADD_FAILURE() << "refused: " << e.what();
    throw;
  }
}

// Reads `path` expecting an InputError that starts with the path and contains `parts`.
void expectRefused(const std::string& path, const std::vector<std::string>& parts,
                   std::size_t maxMemory = kMaxMemory) {
  VolumeReadParams params;
  params.maxMemory = maxMemory;
  try {
    (void)readLabelVolume(path, params);
    ADD_FAILURE() << path << " was read";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path, 0), 0u) << message;
    for (const std::string& part : parts)
      EXPECT_NE(message.find(part), std::string::npos) << message;
    EXPECT_TRUE(test::isPrintable(message)) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

struct TypeCase {
  const char* spelling;
  SampleType type;
  std::int64_t sphere;
  std::int64_t box;
};

class NrrdReaderTypes : public ::testing::TestWithParam<TypeCase> {};

TEST_P(NrrdReaderTypes, ReadsRawAndGzipInBothByteOrdersAttachedAndDetached) {
  const TypeCase& c = GetParam();
  const test::LabelGrid grid = test::sphereAndBox(c.sphere, c.box);
  TempDir dir;
  int n = 0;
  for (const bool gzip : {false, true})
    for (const bool big : {false, true})
      for (const bool detached : {false, true}) {
        SCOPED_TRACE(std::string(gzip ? "gzip" : "raw") + (big ? " big" : " little") +
                     (detached ? " detached" : " attached"));
        NrrdHeader h;
        h.type = c.spelling;
        h.encoding = gzip ? "gzip" : "raw";
        h.endian = big ? "big" : "little";
        h.extra = kLpsPlacement;
        std::string data = test::samplesOf(grid, c.type, big);
        if (gzip) data = test::deflated(data, true);
        const std::string stem = "vol" + std::to_string(n++);
        std::string path;
        if (detached) {
          h.extra.push_back("data file: " + stem + (gzip ? ".raw.gz" : ".raw"));
          dir.write(stem + (gzip ? ".raw.gz" : ".raw"), data);
          path = dir.write(stem + ".nhdr", h.text());
        } else {
          path = dir.write(stem + ".nrrd", h.text() + data);
        }
        const LabelVolume v = readOk(path);
        EXPECT_EQ(v.dims, grid.dims);
        ASSERT_EQ(v.labels.size(), 2u);
        EXPECT_EQ(test::voxelsOf(v, c.sphere), test::countOf(grid, c.sphere));
        EXPECT_EQ(test::voxelsOf(v, c.box), test::countOf(grid, c.box));
        EXPECT_LT((test::worldCentroid(v, c.sphere) - kLpsCentre).norm(), kTol);
        EXPECT_NE(v.placement.find("left-posterior-superior"), std::string::npos);
      }
}

INSTANTIATE_TEST_SUITE_P(
    NrrdTypes, NrrdReaderTypes,
    ::testing::Values(TypeCase{"signed char", SampleType::Int8, -5, 100},
                      TypeCase{"int8_t", SampleType::Int8, 5, 127},
                      TypeCase{"uchar", SampleType::UInt8, 5, 200},
                      TypeCase{"unsigned char", SampleType::UInt8, 1, 2},
                      TypeCase{"short", SampleType::Int16, -300, 30000},
                      TypeCase{"signed short int", SampleType::Int16, 7, 8},
                      TypeCase{"ushort", SampleType::UInt16, 5, 40000},
                      TypeCase{"uint16_t", SampleType::UInt16, 1, 2},
                      TypeCase{"int", SampleType::Int32, -70000, 2000000000},
                      TypeCase{"uint32", SampleType::UInt32, 5, 3000000000},
                      TypeCase{"longlong", SampleType::Int64, -5, 5000000000000},
                      TypeCase{"unsigned long long int", SampleType::UInt64, 5, 9000000000000},
                      TypeCase{"float", SampleType::Float32, 5, 1000000},
                      TypeCase{"double", SampleType::Float64, -5, 4000000000}),
    [](const ::testing::TestParamInfo<TypeCase>& param) {
      std::string name = param.param.spelling;
      for (char& ch : name)
        if (ch == ' ') ch = '_';
      return name;
    });

TEST(NrrdReader, RefusesFloatLabelsThatAreNotWholeNumbers) {
  TempDir dir;
  std::vector<double> values(24, 0.0);
  values[5] = 1.5;
  for (const auto& [name, type] :
       {std::pair{"float", SampleType::Float32}, std::pair{"double", SampleType::Float64}}) {
    NrrdHeader h;
    h.type = name;
    h.sizes = "4 3 2";
    const std::string path =
        dir.write(std::string(name) + ".nrrd", h.text() + test::samplesOf(values, type, false));
    expectRefused(path, {"voxel (1, 1, 0)", "not an integer label"});
  }
}

// The same physical object written in RAS, LPS and LAS lands on the same RAS world point.
TEST(NrrdReader, SpacesAreConvertedToRas) {
  const test::LabelGrid grid = test::sphereAndBox();
  const std::string data = test::samplesOf(grid, SampleType::UInt8, false);
  TempDir dir;
  struct Space {
    const char* name;
    Vec3d sign;
  };
  for (const Space& s : {Space{"right-anterior-superior", {1, 1, 1}}, Space{"RAS", {1, 1, 1}},
                         Space{"left-posterior-superior", {-1, -1, 1}}, Space{"LPS", {-1, -1, 1}},
                         Space{"left-anterior-superior", {-1, 1, 1}},
                         Space{"scanner-xyz", {1, 1, 1}}, Space{"3D-right-handed", {1, 1, 1}}}) {
    SCOPED_TRACE(s.name);
    // RAS directions and origin (mm), written in the file's own space.
    const Eigen::Matrix3d ras = Vec3d(0.5, 0.75, 1.25).asDiagonal();
    const Vec3d rasOrigin(12, -20, 30);
    const Eigen::Matrix3d file = s.sign.asDiagonal() * ras;
    const Vec3d fileOrigin = s.sign.cwiseProduct(rasOrigin);
    auto vec = [](const Vec3d& v) {
      return "(" + std::to_string(v.x()) + "," + std::to_string(v.y()) + "," +
             std::to_string(v.z()) + ")";
    };
    NrrdHeader h;
    h.extra = {
        std::string("space: ") + s.name,
        "space directions: " + vec(file.col(0)) + " " + vec(file.col(1)) + " " + vec(file.col(2)),
        "space origin: " + vec(fileOrigin), "centers: cell cell cell"};
    const LabelVolume v = readOk(dir.write(std::string("s.nrrd"), h.text() + data));
    const Vec3d expected = (rasOrigin + ras * test::kSphereCentre) * 1e-3;
    EXPECT_LT((test::worldCentroid(v, 1) - expected).norm(), kTol);
    EXPECT_LT((v.axes - ras * 1e-3).norm(), kTol);
    EXPECT_LT((v.origin - rasOrigin * 1e-3).norm(), kTol);
  }
}

TEST(NrrdReader, BareSpaceDimensionIsRas) {
  TempDir dir;
  NrrdHeader h;
  h.extra = {"space dimension: 3", "space directions: (2,0,0) (0,2,0) (0,0,2)",
             "space origin: (1,2,3)"};
  const LabelVolume v = readOk(dir.write(
      "d.nrrd", h.text() + test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false)));
  EXPECT_LT((v.origin - Vec3d(1e-3, 2e-3, 3e-3)).norm(), kTol);
  EXPECT_NE(v.placement.find("taken as RAS"), std::string::npos);
}

TEST(NrrdReader, SpacingsWithoutDirectionsGiveAnAnisotropicGrid) {
  TempDir dir;
  NrrdHeader h;
  h.extra = {"spacings: 0.5 1.25 2"};
  const LabelVolume v = readOk(dir.write(
      "s.nrrd", h.text() + test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false)));
  EXPECT_LT((v.axes - Eigen::Matrix3d(Vec3d(0.5e-3, 1.25e-3, 2e-3).asDiagonal())).norm(), kTol);
  EXPECT_LT(v.origin.norm(), kTol);
  EXPECT_EQ(v.placement.rfind("spacings only", 0), 0u) << v.placement;
  const Vec3d expected = Vec3d(0.5 * 8, 1.25 * 8, 2 * 7) * 1e-3;
  EXPECT_LT((test::worldCentroid(v, 1) - expected).norm(), kTol);
}

TEST(NrrdReader, NoSpacingAtAllIsOneMillimetreWithAWarning) {
  TempDir dir;
  const LabelVolume v =
      readOk(dir.write("n.nrrd", NrrdHeader{}.text() + test::samplesOf(test::sphereAndBox(),
                                                                       SampleType::UInt8, false)));
  EXPECT_LT((v.axes - Eigen::Matrix3d::Identity() * 1e-3).norm(), kTol);
  ASSERT_FALSE(v.warnings.empty());
  EXPECT_NE(v.warnings[0].find("1 mm"), std::string::npos);
}

// Rotated, anisotropic axes: the sphere's centre lands at origin + R * diag(s) * centre.
TEST(NrrdReader, RotatedSpaceDirectionsPlaceTheSphere) {
  const Eigen::Matrix3d rotation = (Eigen::AngleAxisd(0.4, Vec3d::UnitZ()) *
                                    Eigen::AngleAxisd(-0.7, Vec3d(1, 1, 0).normalized()))
                                       .toRotationMatrix();
  const Eigen::Matrix3d axes = rotation * Vec3d(0.6, 0.9, 1.3).asDiagonal();  // RAS mm
  const Vec3d origin(-40.5, 12.25, 88);
  char line[512];
  std::snprintf(line, sizeof line,
                "space directions: (%.17g,%.17g,%.17g) (%.17g,%.17g,%.17g) "
                "(%.17g,%.17g,%.17g)",
                axes(0, 0), axes(1, 0), axes(2, 0), axes(0, 1), axes(1, 1), axes(2, 1), axes(0, 2),
                axes(1, 2), axes(2, 2));
  NrrdHeader h;
  h.extra = {"space: RAS", line, "space origin: (-40.5, 12.25, 88)"};  // blanks are allowed
  TempDir dir;
  const LabelVolume v = readOk(dir.write(
      "r.nrrd", h.text() + test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false)));
  EXPECT_LT((v.axes - axes * 1e-3).norm(), kTol);
  const Vec3d expected = (origin + axes * test::kSphereCentre) * 1e-3;
  EXPECT_LT((test::worldCentroid(v, 1) - expected).norm(), kTol);
}

TEST(NrrdReader, SpaceUnitsAreScaledToMetres) {
  const std::string data = test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false);
  TempDir dir;
  struct Unit {
    const char* name;
    double metres;
  };
  for (const Unit& u : {Unit{"m", 1.0}, Unit{"mm", 1e-3}, Unit{"cm", 1e-2}, Unit{"um", 1e-6},
                        Unit{"micron", 1e-6}}) {
    SCOPED_TRACE(u.name);
    NrrdHeader h;
    const std::string q = std::string("\"") + u.name + "\"";
    h.extra = {"space: RAS", "space directions: (2,0,0) (0,3,0) (0,0,4)", "space origin: (5,6,7)",
               "space units: " + q + " " + q + " " + q};
    const LabelVolume v = readOk(dir.write("u.nrrd", h.text() + data));
    EXPECT_LT((v.axes - Eigen::Matrix3d(Vec3d(2, 3, 4).asDiagonal()) * u.metres).norm(),
              kTol * u.metres);
    EXPECT_LT((v.origin - Vec3d(5, 6, 7) * u.metres).norm(), kTol * u.metres);
  }
  NrrdHeader h;
  h.extra = {"space: RAS", "space directions: (2,0,0) (0,3,0) (0,0,4)",
             "space units: \"furlong\" \"mm\" \"mm\""};
  expectRefused(dir.write("bad.nrrd", h.text() + data), {"space units", "furlong"});
}

TEST(NrrdReader, DetachedDataWithSkips) {
  const test::LabelGrid grid = test::sphereAndBox();
  const std::string data = test::samplesOf(grid, SampleType::UInt16, true);
  TempDir dir;
  NrrdHeader h;
  h.type = "uint16";
  h.endian = "big";
  h.extra = kLpsPlacement;
  // Two text lines, then 5 bytes, then the samples.
  dir.write("skip.raw", "first line\nsecond\nabcde" + data);
  NrrdHeader skips = h;
  skips.extra.insert(skips.extra.end(), {"data file: ./skip.raw", "line skip: 2", "byte skip: 5"});
  // A detached header may end at the end of the file, without an empty line.
  std::string text = skips.text();
  text.pop_back();
  LabelVolume v = readOk(dir.write("skip.nhdr", text));
  EXPECT_EQ(test::voxelsOf(v, 1), test::countOf(grid, 1));
  EXPECT_LT((test::worldCentroid(v, 1) - kLpsCentre).norm(), kTol);
  // Byte skip -1: the samples end the file, whatever precedes them.
  dir.write("tail.raw", std::string(1000, 'x') + data);
  NrrdHeader tail = h;
  tail.extra.insert(tail.extra.end(), {"datafile: tail.raw", "byte skip: -1"});
  v = readOk(dir.write("tail.nhdr", tail.text()));
  EXPECT_EQ(test::voxelsOf(v, 2), test::countOf(grid, 2));
  // A gzip data file with a byte skip counted in the inflated bytes.
  dir.write("skip.raw.gz", test::deflated("0123" + data, true));
  NrrdHeader gz = h;
  gz.encoding = "gz";
  gz.extra.insert(gz.extra.end(), {"data file: skip.raw.gz", "byte skip: 4"});
  v = readOk(dir.write("gz.nhdr", gz.text()));
  EXPECT_EQ(test::voxelsOf(v, 1), test::countOf(grid, 1));
  // An absolute path inside the folder is fine.
  NrrdHeader absolute = h;
  absolute.extra.push_back("data file: " + dir.file("tail.raw"));
  absolute.extra.push_back("byte skip: -1");
  v = readOk(dir.write("abs.nhdr", absolute.text()));
  EXPECT_EQ(test::voxelsOf(v, 1), test::countOf(grid, 1));
}

TEST(NrrdReader, DetachedDataFileMustBeInsideTheFolderAndExist) {
  TempDir dir;
  const std::string data(24, '\1');
  std::filesystem::create_directories(dir.path() / "sub");
  dir.write("outside.raw", data);
  dir.write("sub/inside.raw", data);
  std::filesystem::create_symlink(dir.path() / "outside.raw", dir.path() / "sub" / "link.raw");
  NrrdHeader h;
  h.sizes = "4 3 2";
  auto header = [&](const std::string& file) {
    NrrdHeader d = h;
    d.extra.push_back("data file: " + file);
    return d.text();
  };
  EXPECT_EQ(readOk(dir.write("sub/ok.nhdr", header("inside.raw"))).labels.size(), 1u);
  expectRefused(dir.write("sub/up.nhdr", header("../outside.raw")),
                {"data file '../outside.raw'", "outside the folder"});
  expectRefused(dir.write("sub/etc.nhdr", header("/etc/passwd")),
                {"data file '/etc/passwd'", "outside the folder"});
  expectRefused(dir.write("sub/link.nhdr", header("link.raw")),
                {"data file 'link.raw'", "outside the folder"});
  expectRefused(dir.write("sub/missing.nhdr", header("missing.raw")),
                {"data file 'missing.raw'", "does not exist"});
  expectRefused(dir.write("sub/dir.nhdr", header(".")), {"data file '.'"});
  // Exactly the samples after the skips: fewer or more bytes are refused.
  dir.write("sub/short.raw", data.substr(1));
  expectRefused(dir.write("sub/short.nhdr", header("short.raw")), {"23 bytes", "fewer"});
  dir.write("sub/long.raw", data + "x");
  expectRefused(dir.write("sub/long.nhdr", header("long.raw")), {"25 bytes", "more"});
  NrrdHeader list = h;
  list.extra.push_back("data file: LIST");
  expectRefused(dir.write("sub/list.nhdr", list.text() + "inside.raw\n"), {"LIST"});
  NrrdHeader numbered = h;
  numbered.extra.push_back("data file: slice%03d.raw 1 2 1");
  expectRefused(dir.write("sub/numbered.nhdr", numbered.text()), {"numbered data files"});
}

// A 3D Slicer segmentation with one layer: names and colours from the segments.
TEST(NrrdReader, SegmentationNamesAndColoursLabels) {
  TempDir dir;
  NrrdHeader h;
  h.extra = kLpsPlacement;
  h.extra.insert(h.extra.end(),
                 {"kinds: domain domain domain", "Segment0_ID:=Segment_1", "Segment0_Name:=Liver",
                  "Segment0_Color:=0.2 0.4 0.6", "Segment0_LabelValue:=1", "Segment0_Layer:=0",
                  "Segment1_ID:=Segment_2", "Segment1_Name:=Tu\x01mor", "Segment1_Color:=1 0 0.5",
                  "Segment1_LabelValue:=2", "Segment1_Layer:=0", "Segment2_Name:=Empty",
                  "Segment2_LabelValue:=9", "Segmentation_MasterRepresentation:=Binary labelmap"});
  const LabelVolume v =
      readOk(dir.write("liver.seg.nrrd",
                       h.text() + test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false)));
  ASSERT_EQ(v.labels.size(), 2u);
  EXPECT_EQ(v.labels[0].name, "Liver");
  ASSERT_TRUE(v.labels[0].colour.has_value());
  EXPECT_FLOAT_EQ((*v.labels[0].colour)[1], 0.4f);
  EXPECT_EQ(v.labels[1].name, "Tu?mor");
  EXPECT_FLOAT_EQ((*v.labels[1].colour)[2], 0.5f);
  bool droppedNamed = false;
  for (const std::string& w : v.warnings) {
    droppedNamed = droppedNamed || w.find("'Empty'") != std::string::npos;
    EXPECT_TRUE(test::isPrintable(w)) << w;
  }
  EXPECT_TRUE(droppedNamed);
}

// Layered (4-D) segmentation: layer 0 holds a sphere (1) and a corner box (2), layer 1 a slab
// (1) that overlaps the sphere. Where layers overlap, the segment numbered last wins.
struct Layered {
  test::LabelGrid layer0 = test::sphereAndBox();
  test::LabelGrid layer1 = test::sphereAndBox(0, 0);
  Layered() {
    for (int k = 5; k <= 9; ++k)
      for (int j = 6; j <= 10; ++j)
        for (int i = 10; i <= 14; ++i) layer1.values[layer1.linear(i, j, k)] = 1;
  }
  [[nodiscard]] std::string samples(SampleType type) const {
    std::vector<double> values;
    for (std::size_t v = 0; v < layer0.values.size(); ++v) {
      values.push_back(static_cast<double>(layer0.values[v]));
      values.push_back(static_cast<double>(layer1.values[v]));
    }
    return test::samplesOf(values, type, false);
  }
};

NrrdHeader layeredHeader(bool slabLast) {
  NrrdHeader h;
  h.dimension = 4;
  h.sizes = "2 20 18 16";
  h.type = "short";
  const std::string sphere = slabLast ? "0" : "1";
  const std::string slab = slabLast ? "1" : "0";
  h.extra = {"space: left-posterior-superior",
             "space directions: none (0.5,0,0) (0,0.75,0) (0,0,1.25)",
             "space origin: (-10,20,30)",
             "kinds: list domain domain domain",
             "Segment" + sphere + "_Name:=Sphere",
             "Segment" + sphere + "_LabelValue:=1",
             "Segment" + sphere + "_Layer:=0",
             "Segment" + slab + "_Name:=Slab",
             "Segment" + slab + "_Color:=0 1 0",
             "Segment" + slab + "_LabelValue:=1",
             "Segment" + slab + "_Layer:=1",
             "Segment2_Name:=Corner",
             "Segment2_LabelValue:=2",
             "Segment2_Layer:=0",
             "Segment3_Name:=Ghost",
             "Segment3_LabelValue:=7",
             "Segment3_Layer:=1"};
  return h;
}

const LabelInfo* labelNamed(const LabelVolume& v, const std::string& name) {
  for (const LabelInfo& l : v.labels)
    if (l.name == name) return &l;
  return nullptr;
}

TEST(NrrdReader, LayeredSegmentationGivesOverlapsToTheLaterSegment) {
  const Layered layered;
  TempDir dir;
  for (const bool slabLast : {true, false}) {
    SCOPED_TRACE(slabLast ? "slab is Segment1" : "sphere is Segment1");
    const LabelVolume v = readOk(dir.write(
        "layers.seg.nrrd", layeredHeader(slabLast).text() + layered.samples(SampleType::Int16)));
    EXPECT_EQ(v.dims, (Index3{20, 18, 16}));
    ASSERT_EQ(v.labels.size(), 3u);
    const LabelInfo* sphere = labelNamed(v, "Sphere");
    const LabelInfo* slab = labelNamed(v, "Slab");
    const LabelInfo* corner = labelNamed(v, "Corner");
    ASSERT_TRUE(sphere && slab && corner);
    // Unique values: the first segment keeps 1, the other moves above every value in use.
    EXPECT_EQ((slabLast ? sphere : slab)->value, 1);
    EXPECT_EQ((slabLast ? slab : sphere)->value, 3);
    EXPECT_EQ(corner->value, 2);
    ASSERT_TRUE(slab->colour.has_value());
    EXPECT_FLOAT_EQ((*slab->colour)[1], 1.0f);
    // (12, 8, 7) is in both the sphere and the slab; (8, 8, 7) only in the sphere.
    EXPECT_EQ(test::valueAt(v, 12, 8, 7), (slabLast ? slab : sphere)->value);
    EXPECT_EQ(test::valueAt(v, 8, 8, 7), sphere->value);
    EXPECT_EQ(test::valueAt(v, 17, 2, 3), corner->value);
    EXPECT_EQ(test::voxelsOf(v, corner->value), test::countOf(layered.layer0, 2));
    std::size_t overlap = 0;
    for (std::size_t k = 0; k < layered.layer0.values.size(); ++k)
      overlap += layered.layer0.values[k] == 1 && layered.layer1.values[k] == 1;
    EXPECT_GT(overlap, 0u);
    const std::size_t slabVoxels = test::countOf(layered.layer1, 1);
    const std::size_t sphereVoxels = test::countOf(layered.layer0, 1);
    EXPECT_EQ(test::voxelsOf(v, slab->value), slabLast ? slabVoxels : slabVoxels - overlap);
    EXPECT_EQ(test::voxelsOf(v, sphere->value), slabLast ? sphereVoxels - overlap : sphereVoxels);
    // The 4-D file is placed by its 3 spatial axes.
    EXPECT_LT((test::worldCentroid(v, corner->value) -
               Vec3d(-(-10 + 0.5 * 17), -(20 + 0.75 * 2), 30 + 1.25 * 2.5) * 1e-3)
                  .norm(),
              kTol);
    bool ghostDropped = false;
    bool overlapWarned = false;
    for (const std::string& w : v.warnings) {
      ghostDropped = ghostDropped || w.find("'Ghost'") != std::string::npos;
      overlapWarned = overlapWarned || w.find(std::to_string(overlap) + " voxels") == 0;
    }
    EXPECT_TRUE(ghostDropped);
    EXPECT_TRUE(overlapWarned);
  }
}

TEST(NrrdReader, FourDimensionalWithOneLayerOrALastSizeOfOne) {
  const std::string data = test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false);
  TempDir dir;
  NrrdHeader first;
  first.dimension = 4;
  first.sizes = "1 20 18 16";
  first.extra = {"kinds: list domain domain domain", "spacings: nan 1 1 1"};
  EXPECT_EQ(readOk(dir.write("first.nrrd", first.text() + data)).labels.size(), 2u);
  NrrdHeader last;
  last.dimension = 4;
  last.sizes = "20 18 16 1";
  last.extra = {"space: RAS", "space directions: (1,0,0) (0,1,0) (0,0,1) none"};
  const LabelVolume v = readOk(dir.write("last.nrrd", last.text() + data));
  EXPECT_EQ(v.dims, (Index3{20, 18, 16}));
  NrrdHeader time = last;
  time.sizes = "20 18 16 2";
  expectRefused(dir.write("time.nrrd", time.text() + data + data), {"4-D", "axis 3"});
}

TEST(NrrdReader, ReadsFromMemoryWithTheFolderGiven) {
  TempDir dir;
  dir.write("d.raw", std::string(24, '\3'));
  NrrdHeader h;
  h.sizes = "4 3 2";
  h.extra = {"data file: d.raw"};
  const LabelVolume v =
      volumeio::readNrrd(h.text(), dir.path().string(), "header in memory", VolumeReadParams{});
  ASSERT_EQ(v.labels.size(), 1u);
  EXPECT_EQ(v.labels[0].value, 3);
  try {
    (void)volumeio::readNrrd(h.text(), (dir.path() / "elsewhere").string(), "header in memory",
                             VolumeReadParams{});
    ADD_FAILURE() << "read a data file outside the folder";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("header in memory: data file 'd.raw'"), std::string::npos)
        << e.what();
  }
}

TEST(NrrdReader, EmptySegmentationIsRefused) {
  TempDir dir;
  NrrdHeader h;
  h.sizes = "4 3 2";
  expectRefused(dir.write("empty.nrrd", h.text() + std::string(24, '\0')), {"no non-zero label"});
}

// Malformed headers and data: each one line naming the file and what is wrong.
TEST(NrrdReaderInputErrors, EachIsOneClearLine) {
  const std::string data(24, '\1');
  const auto with = [](std::vector<std::string> extra, const std::string& sizes = "4 3 2") {
    NrrdHeader h;
    h.sizes = sizes;
    h.extra = std::move(extra);
    return h.text();
  };
  NrrdHeader gzip;
  gzip.encoding = "gzip";
  const std::string full = test::samplesOf(test::sphereAndBox(), SampleType::UInt8, false);
  const std::string compressed = test::deflated(full, true);
  NrrdHeader noEndian;
  noEndian.type = "ushort";
  noEndian.endian = "";
  noEndian.sizes = "4 3 2";
  NrrdHeader fiveD;
  fiveD.dimension = 5;
  fiveD.sizes = "4 3 2 1 1";
  std::string noEnd = with({});
  noEnd.pop_back();
  struct Case {
    const char* name;
    std::string bytes;
    std::vector<std::string> parts;
  };
  const std::vector<Case> cases = {
      {"truncated_gzip", gzip.text() + compressed.substr(0, compressed.size() / 2), {"truncated"}},
      {"corrupt_gzip", gzip.text() + compressed.substr(0, 20) + std::string(40, '\xff'), {"gzip"}},
      {"short", with({}) + data.substr(1), {"23 bytes", "fewer than the 24"}},
      {"long", with({}) + data + "x", {"25 bytes", "more than the 24"}},
      {"zero_size", with({}, "4 0 2") + data, {"field 'sizes'", "must be positive"}},
      {"negative_size", with({}, "4 -3 2") + data, {"field 'sizes'", "must be positive"}},
      {"nan_size", with({}, "4 nan 2") + data, {"field 'sizes'", "'nan' is not an integer"}},
      {"few_sizes", with({}, "4 3") + data, {"field 'sizes'", "2 values for 3 axes"}},
      {"huge", with({}, "100000 100000 100000"), {"exceed 2^31 voxels"}},
      {"over_memory", with({}, "1000 1000 1000"), {"over the limit of 256 MiB"}},
      {"int_overflow_size", with({}, "4 3 3000000000") + data, {"field 'sizes'", "too large"}},
      {"zero_spacing", with({"spacings: 1 0 1"}) + data, {"field 'spacings'", "'0'"}},
      {"negative_spacing", with({"spacings: 1 1 -2"}) + data, {"field 'spacings'", "'-2'"}},
      {"nan_spacing", with({"spacings: nan 1 1"}) + data, {"field 'spacings'", "'nan'"}},
      {"inf_spacing", with({"spacings: 1 inf 1"}) + data, {"field 'spacings'", "'inf'"}},
      {"nan_direction",
       with({"space: RAS", "space directions: (nan,0,0) (0,1,0) (0,0,1)"}) + data,
       {"field 'space directions'", "finite"}},
      {"degenerate_directions",
       with({"space: RAS", "space directions: (1,0,0) (1,0,0) (0,0,1)"}) + data,
       {"degenerate"}},
      {"zero_direction",
       with({"space: RAS", "space directions: (0,0,0) (0,1,0) (0,0,1)"}) + data,
       {"spacing along axis 0"}},
      {"none_direction",
       with({"space: RAS", "space directions: none (0,1,0) (0,0,1)"}) + data,
       {"field 'space directions'", "'none'"}},
      {"inf_origin",
       with({"space: RAS", "space origin: (0,inf,0)"}) + data,
       {"field 'space origin'"}},
      {"five_d", fiveD.text() + data, {"field 'dimension'", "5-D"}},
      {"block", with({}).replace(with({}).find("uint8"), 5, "block") + data, {"'block'"}},
      {"unknown_type",
       with({}).replace(with({}).find("uint8"), 5, "complex") + data,
       {"field 'type'", "'complex'"}},
      {"bzip2",
       with({}).replace(with({}).find("raw"), 3, "bzip2") + data,
       {"field 'encoding'", "'bzip2'", "not supported"}},
      {"ascii",
       with({}).replace(with({}).find("raw"), 3, "ascii") + "1 1 1\n",
       {"field 'encoding'", "'ascii'"}},
      {"hex", with({}).replace(with({}).find("raw"), 3, "hex") + "01\n", {"'hex'"}},
      {"no_endian", noEndian.text() + data + data, {"field 'endian' is missing"}},
      {"bad_endian", with({}).replace(with({}).find("little"), 6, "middle") + data, {"'middle'"}},
      {"no_empty_line", noEnd, {"no empty line"}},
      {"not_nrrd", "hello\n" + data, {"not a NRRD file"}},
      {"bad_magic", "NRRD0009\n" + with({}).substr(9) + data, {"'NRRD0009'"}},
      {"twice", with({"spacings: 1 1 1", "spacings: 1 1 1"}) + data, {"'spacings'", "twice"}},
      {"no_colon", with({"what is this"}) + data, {"header line", "'what is this'"}},
      {"control_bytes",
       with({}).replace(with({}).find("uint8"), 5, std::string("u\x01\x1b[31mint\xff\x7f", 12)) +
           data,
       {"field 'type'", "\\x01", "\\x1B", "\\xFF"}},
      {"gzip_tail_skip",
       gzip.text().insert(gzip.text().size() - 1, "byte skip: -1\n") + compressed,
       {"field 'byte skip'", "raw"}},
      {"negative_skip", with({"byte skip: -2"}) + data, {"field 'byte skip'", "at least -1"}},
      {"skip_past_end", with({"byte skip: 100"}) + data, {"byte skip 100"}},
      {"line_skip_past_end", with({"line skip: 3"}) + data, {"line skip 3"}},
      {"time_space",
       with({"space: right-anterior-superior-time"}) + data,
       {"field 'space'", "not supported"}},
      {"space_dimension_2", with({"space dimension: 2"}) + data, {"field 'space dimension'"}},
      {"float_fraction",
       with({}).replace(with({}).find("uint8"), 5, "double") +
           test::samplesOf(std::vector<double>(24, 1.5), SampleType::Float64, false),
       {"voxel (0, 0, 0)", "not an integer label"}},
      {"bad_label_value",
       with({"Segment0_LabelValue:=one"}) + data,
       {"Segment0_LabelValue", "'one'"}},
      {"four_d_no_layer_axis",
       [] {
         NrrdHeader h;
         h.dimension = 4;
         h.sizes = "2 4 3 2";
         return h.text();
       }() +
           data + data,
       {"4-D data with no axis marked"}},
  };
  TempDir dir;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    expectRefused(dir.write(std::string(c.name) + ".nrrd", c.bytes), c.parts);
  }
}

}  // namespace
}  // namespace voxcut
