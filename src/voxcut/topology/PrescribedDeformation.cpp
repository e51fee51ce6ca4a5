#include "voxcut/topology/PrescribedDeformation.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"

namespace voxcut {

Deformation parseDeformation(std::string_view text) {
  if (text == "none") return Deformation::None;
  if (text == "rigid") return Deformation::Rigid;
  if (text == "bend") return Deformation::Bend;
  if (text == "twist") return Deformation::Twist;
  throw InputError("unknown deformation '" + std::string(text) +
                   "' (expected rigid, bend or twist)");
}

std::string_view deformationName(Deformation d) {
  switch (d) {
    case Deformation::None:
      return "none";
    case Deformation::Rigid:
      return "rigid";
    case Deformation::Bend:
      return "bend";
    case Deformation::Twist:
      return "twist";
  }
  return "none";
}

namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

/// The deformation's frame and constants, computed once per call.
class DeformationMap {
 public:
  DeformationMap(const DeformationOctree& octree, Deformation d, double amount) : kind_(d) {
    const Eigen::AlignedBox3d& box = octree.restVoxelBounds();
    if (box.isEmpty() || amount == 0.0) {
      kind_ = Deformation::None;
      return;
    }
    centre_ = box.center();
    const Vec3d ext = box.sizes();
    // Longest axis a (lowest index on ties), then the longer of the other two as b.
    a_ = 0;
    for (int i = 1; i < 3; ++i)
      if (ext[i] > ext[a_]) a_ = i;
    const int o1 = (a_ + 1) % 3, o2 = (a_ + 2) % 3;
    b_ = (ext[o2] > ext[o1] || (ext[o2] == ext[o1] && o2 < o1)) ? o2 : o1;
    const double length = std::max(ext[a_], octree.voxelSize());
    switch (kind_) {
      case Deformation::Rigid:
        rotation_ = Eigen::AngleAxisd(30.0 * kDegree * amount, Vec3d(1, 2, 3).normalized())
                        .toRotationMatrix();
        break;
      case Deformation::Bend:
        kappa_ = (60.0 * kDegree * amount) / length;
        break;
      case Deformation::Twist:
        twistRate_ = (30.0 * kDegree * amount) / (0.5 * length);
        break;
      case Deformation::None:
        break;
    }
  }

  [[nodiscard]] bool isIdentity() const { return kind_ == Deformation::None; }

  [[nodiscard]] Vec3d operator()(const Vec3d& x) const {
    const Vec3d r = x - centre_;
    switch (kind_) {
      case Deformation::None:
        return x;
      case Deformation::Rigid:
        return centre_ + rotation_ * r;
      case Deformation::Bend: {
        // Arc of radius 1/κ with its centre at u = 1/κ on the b axis: the point at (s, u) goes to
        // angle φ = κ s on the circle of radius 1/κ - u. Jacobian determinant 1 - κ u > 0.
        const double s = r[a_], u = r[b_], phi = kappa_ * s;
        const double half = std::sin(0.5 * phi);
        Vec3d y = r;
        y[a_] = std::sin(phi) / kappa_ - u * std::sin(phi);
        y[b_] = u * std::cos(phi) + 2.0 * half * half / kappa_;
        return centre_ + y;
      }
      case Deformation::Twist: {
        // Rotate the part across the axis by θ(s); the Jacobian determinant is 1.
        const int p = (a_ + 1) % 3, q = (a_ + 2) % 3;
        const double theta = twistRate_ * r[a_], c = std::cos(theta), sn = std::sin(theta);
        Vec3d y = r;
        y[p] = c * r[p] - sn * r[q];
        y[q] = sn * r[p] + c * r[q];
        return centre_ + y;
      }
    }
    return x;
  }

 private:
  Deformation kind_;
  Vec3d centre_ = Vec3d::Zero();
  int a_ = 0, b_ = 1;
  Eigen::Matrix3d rotation_ = Eigen::Matrix3d::Identity();
  double kappa_ = 0.0;
  double twistRate_ = 0.0;
};

}  // namespace

Vec3d deformedPoint(const DeformationOctree& octree, Deformation d, double amount,
                    const Vec3d& rest) {
  return DeformationMap(octree, d, amount)(rest);
}

void applyDeformation(DeformationOctree& octree, Deformation d, double amount) {
  const DeformationMap map(octree, d, amount);
  const std::vector<Vec3d>& rest = octree.restPositions();
  std::vector<Vec3d>& pos = octree.positions();
  if (map.isIdentity()) {  // exactly the rest state, hanging nodes included
    pos = rest;
    return;
  }
  parallelFor(0, pos.size(), 1024, [&](std::size_t b, std::size_t e) {
    for (std::size_t n = b; n < e; ++n)
      if (!octree.isHanging(static_cast<std::uint32_t>(n))) pos[n] = map(rest[n]);
  });
  octree.updateHangingNodes();
}

}  // namespace voxcut
