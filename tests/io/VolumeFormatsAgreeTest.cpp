// One sphere in world space (radius 10 mm about (12, -7, 30) mm, RAS) written in every format
// and placement the readers know, each file labelling the voxels whose centres it puts inside
// the sphere, then read and resampled onto voxcut's 1 mm grid: every copy lands at the same
// place within half a voxel, with the same volume within 2 %.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "NiftiFiles.h"
#include "TempDir.h"
#include "VolumeFiles.h"
#include "voxcut/io/VolumeReader.h"
#include "voxcut/surface/DualContour.h"
#include "voxcut/surface/SurfaceMesh.h"
#include "voxcut/voxel/LabelResample.h"

namespace voxcut::test {
namespace {

const Vec3d kCentre(12, -7, 30);  // mm, RAS
constexpr double kRadius = 10;    // mm

// A grid placed by `axes` (columns: RAS mm per index step) and `origin` (mm): its dims (to
// cover the sphere with a margin) and the sphere's labels.
struct Placed {
  Eigen::Matrix3d axes;
  Vec3d origin;
  std::array<std::int64_t, 3> dims{};
  std::vector<std::int64_t> labels;
};

// Places a grid of the given axes so that its middle voxel sits at the sphere's centre plus
// `shift` (mm) and labels it.
Placed place(const Eigen::Matrix3d& axes, const Vec3d& shift) {
  Placed p;
  p.axes = axes;
  const Vec3d spacing = axes.colwise().norm().transpose();
  for (int a = 0; a < 3; ++a)
    p.dims[static_cast<std::size_t>(a)] = static_cast<std::int64_t>(std::ceil(32 / spacing[a]));
  const Vec3d middle(static_cast<double>(p.dims[0] - 1) / 2, static_cast<double>(p.dims[1] - 1) / 2,
                     static_cast<double>(p.dims[2] - 1) / 2);
  p.origin = kCentre + shift - axes * middle;
  p.labels.assign(static_cast<std::size_t>(p.dims[0] * p.dims[1] * p.dims[2]), 0);
  for (std::int64_t k = 0; k < p.dims[2]; ++k)
    for (std::int64_t j = 0; j < p.dims[1]; ++j)
      for (std::int64_t i = 0; i < p.dims[0]; ++i) {
        const Vec3d x = p.origin + axes * Vec3d(static_cast<double>(i), static_cast<double>(j),
                                                static_cast<double>(k));
        if ((x - kCentre).norm() <= kRadius)
          p.labels[static_cast<std::size_t>(i + p.dims[0] * (j + p.dims[1] * k))] = 5;
      }
  return p;
}

std::string dimsText(const Placed& p) {
  return std::to_string(p.dims[0]) + " " + std::to_string(p.dims[1]) + " " +
         std::to_string(p.dims[2]);
}

std::string vectorText(const Vec3d& v) {
  std::ostringstream os;
  os.precision(17);
  os << "(" << v.x() << "," << v.y() << "," << v.z() << ")";
  return os.str();
}

std::string numbers(const std::vector<double>& v) {
  std::ostringstream os;
  os.precision(17);
  for (std::size_t i = 0; i < v.size(); ++i) os << (i ? " " : "") << v[i];
  return os.str();
}

void writeFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

std::vector<double> asDoubles(const std::vector<std::int64_t>& v) {
  return {v.begin(), v.end()};
}

// NIfTI-1 with the sform (and, when `qformDisagrees`, a qform 3 mm off).
std::string niftiSform(const Placed& p, bool qformDisagrees) {
  NiftiSpec s;
  s.dim = {3, p.dims[0], p.dims[1], p.dims[2], 1, 1, 1, 1};
  const Vec3d spacing = p.axes.colwise().norm().transpose();
  s.pixdim = {1, spacing.x(), spacing.y(), spacing.z(), 0, 0, 0, 0};
  s.sformCode = 2;
  for (int r = 0; r < 3; ++r)
    s.srow[static_cast<std::size_t>(r)] = {p.axes(r, 0), p.axes(r, 1), p.axes(r, 2), p.origin[r]};
  if (qformDisagrees) {
    s.qformCode = 1;
    s.quatern = {0, 0, 0, p.origin.x() + 3, p.origin.y(), p.origin.z()};
  }
  s.data = niftiSamples(p.labels, kNiftiUInt8, false);
  return niftiBytes(s);
}

// NIfTI-2, big-endian int16, a qform with qfac -1 (the z axis flipped) and no sform.
std::string niftiQform(const Placed& p) {
  NiftiSpec s;
  s.version = 2;
  s.bigEndian = true;
  s.dim = {3, p.dims[0], p.dims[1], p.dims[2], 1, 1, 1, 1};
  const Vec3d spacing = p.axes.colwise().norm().transpose();
  s.pixdim = {-1, spacing.x(), spacing.y(), spacing.z(), 0, 0, 0, 0};
  s.qformCode = 1;
  s.quatern = {0, 0, 0, p.origin.x(), p.origin.y(), p.origin.z()};
  s.datatype = kNiftiInt16;
  s.data = niftiSamples(p.labels, kNiftiInt16, true);
  return niftiBytes(s);
}

// The resampled sphere's centroid (mm) and volume (mm^3).
struct Landed {
  Vec3d centroid = Vec3d::Zero();
  double volume = 0;
};

Landed resampled(const std::filesystem::path& path) {
  const LabelVolume vol = readLabelVolume(path.string());
  LabelResampleParams params;
  params.resolution.voxelSize = 0.001;
  const VoxelGrid g = resampleLabels(vol, params);
  Landed l;
  std::size_t n = 0;
  for (std::size_t v = 0; v < g.voxelCount(); ++v)
    if (g.material(v)) {
      l.centroid += g.position(v);
      ++n;
    }
  l.centroid = 1e3 * l.centroid / static_cast<double>(n);
  l.volume = static_cast<double>(n) * 1.0;  // 1 mm voxels
  return l;
}

TEST(VolumeFormatsAgree, OneSphereEveryFormatSamePlace) {
  TempDir dir;
  const Eigen::Matrix3d iso = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d flipZ = Vec3d(1, 1, -1).asDiagonal();
  const Eigen::Matrix3d lps = Vec3d(-1, -1, 1).asDiagonal();  // RAS <-> LPS
  const Eigen::Matrix3d rotated =
      Eigen::AngleAxisd(0.6, Vec3d(1, -2, 2).normalized()).toRotationMatrix() *
      Vec3d(0.8, 1.1, 1.3).asDiagonal();
  std::vector<std::filesystem::path> files;

  // NIfTI: sform; qform with qfac -1; both, disagreeing (the sform wins).
  const Placed a = place(iso, Vec3d(0.3, -0.2, 0.1));
  files.push_back(dir.path() / "sform.nii");
  writeFile(files.back(), niftiSform(a, false));
  files.push_back(dir.path() / "both.nii.gz");
  writeFile(files.back(), gzipped(niftiSform(a, true)));
  const Placed q = place(flipZ, Vec3d(-0.4, 0.25, 0.35));
  files.push_back(dir.path() / "qform.nii");
  writeFile(files.back(), niftiQform(q));

  // NRRD: RAS attached raw little-endian uint8; LPS detached gzip big-endian int16.
  const Placed n = place(iso * 0.9, Vec3d(0.1, 0.2, -0.3));
  NrrdHeader ras;
  ras.sizes = dimsText(n);
  ras.extra = {"space: right-anterior-superior",
               "space directions: " + vectorText(n.axes.col(0)) + " " + vectorText(n.axes.col(1)) +
                   " " + vectorText(n.axes.col(2)),
               "space origin: " + vectorText(n.origin)};
  files.push_back(dir.path() / "ras.nrrd");
  writeFile(files.back(), ras.text() + samplesOf(asDoubles(n.labels), SampleType::UInt8, false));
  const Placed m = place(rotated, Vec3d(0.2, 0.1, 0.15));
  NrrdHeader left;
  left.type = "int16";
  left.endian = "big";
  left.encoding = "gzip";
  left.sizes = dimsText(m);
  left.extra = {"space: left-posterior-superior",
                "space directions: " + vectorText(lps * m.axes.col(0)) + " " +
                    vectorText(lps * m.axes.col(1)) + " " + vectorText(lps * m.axes.col(2)),
                "space origin: " + vectorText(lps * m.origin), "data file: lps.raw.gz"};
  files.push_back(dir.path() / "lps.nhdr");
  writeFile(files.back(), left.text());
  writeFile(dir.path() / "lps.raw.gz",
            deflated(samplesOf(asDoubles(m.labels), SampleType::Int16, true), true));

  // MetaImage: the rotated, anisotropic grid in ITK's LPS, TransformMatrix listing each axis's
  // direction in turn.
  MetaHeader meta;
  meta.elementType = "MET_USHORT";
  meta.msb = true;
  meta.dimSize = dimsText(m);
  const Vec3d spacing = m.axes.colwise().norm().transpose();
  std::vector<double> matrix;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) matrix.push_back((lps * m.axes.col(c) / spacing[c])[r]);
  const Vec3d offset = lps * m.origin;
  meta.extra = {"TransformMatrix = " + numbers(matrix),
                "Offset = " + numbers({offset.x(), offset.y(), offset.z()}),
                "ElementSpacing = " + numbers({spacing.x(), spacing.y(), spacing.z()})};
  files.push_back(dir.path() / "rotated.mha");
  writeFile(files.back(), meta.text() + samplesOf(asDoubles(m.labels), SampleType::UInt16, true));

  const double exactVolume = 4.0 / 3.0 * std::numbers::pi * kRadius * kRadius * kRadius;
  const Landed reference = resampled(files.front());
  EXPECT_LT((reference.centroid - kCentre).norm(), 0.5);
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    const Landed l = resampled(f);
    EXPECT_LT((l.centroid - reference.centroid).norm(), 0.5) << l.centroid.transpose();
    EXPECT_NEAR(l.volume / reference.volume, 1.0, 0.02);
    EXPECT_NEAR(l.volume / exactVolume, 1.0, 0.05);
  }
}

// The known answer from a file: a sphere of radius 20 mm labelled in a 1 mm NIfTI (its centre
// on a voxel centre, so each pole is a terrace of one voxel), read and resampled at 1 mm,
// contours to a closed surface with the sphere's area within 3 % and every vertex within a
// quarter voxel of the sphere.
TEST(VolumeFormatsAgree, NiftiSphereContoursWithinAQuarterVoxel) {
  constexpr double r = 20;  // mm
  Placed p;
  p.axes = Eigen::Matrix3d::Identity();
  p.dims = {47, 47, 47};
  p.origin = kCentre - Vec3d(23, 23, 23);
  p.labels.assign(47 * 47 * 47, 0);
  for (std::int64_t k = 0; k < 47; ++k)
    for (std::int64_t j = 0; j < 47; ++j)
      for (std::int64_t i = 0; i < 47; ++i)
        if ((p.origin +
             Vec3d(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k)) -
             kCentre)
                .norm() <= r)
          p.labels[static_cast<std::size_t>(i + 47 * (j + 47 * k))] = 1;
  TempDir dir;
  const auto path = dir.path() / "sphere.nii.gz";
  writeFile(path, gzipped(niftiSform(p, false)));
  LabelResampleParams params;
  params.resolution.voxelSize = 0.001;
  const SurfaceMesh s = dualContour(resampleLabels(readLabelVolume(path.string()), params));
  EXPECT_TRUE(surfaceTopology(s).closed);
  double area = 0, worst = 0;
  for (const auto& t : s.triangles)
    area +=
        0.5 *
        (s.positions[t[1]] - s.positions[t[0]]).cross(s.positions[t[2]] - s.positions[t[0]]).norm();
  for (const Vec3d& x : s.positions)
    worst = std::max(worst, std::abs((1e3 * x - kCentre).norm() - r));
  EXPECT_NEAR(area * 1e6 / (4 * std::numbers::pi * r * r), 1.0, 0.03);
  EXPECT_LT(worst, 0.25);  // mm, a quarter of the file's voxel
}

}  // namespace
}  // namespace voxcut::test
