#include "voxcut/voxel/BuiltinModels.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <unordered_map>
#include <utility>

#include "voxcut/core/Error.h"

namespace voxcut {
namespace {

// ---------------------------------------------------------------------------------------------
// Shared construction: every curved model is the unit icosphere with its vertices moved, so
// it inherits a closed, outward, genus-0 connectivity. The liver and the tumor move a vertex at
// direction d to R(d) d with R > 0 (a star-shaped surface: each flat triangle stays inside the
// cone of its three directions, so the mesh cannot intersect itself and keeps the icosphere's
// orientation), the liver followed by a gentle injective warp; the starfish maps the sphere by
// a smooth injective map that fades to a scaling near its poles. Meshes are fine enough that
// the flat triangles follow these smooth maps without folding (the tests check it).
// ---------------------------------------------------------------------------------------------

/// Unit icosphere: `subdivisions` 4-way splits of an icosahedron, midpoints pushed to the sphere.
TriangleMesh unitIcosphere(int subdivisions) {
  const double t = std::numbers::phi;
  TriangleMesh m;
  m.vertices = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  m.faces = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
             {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
             {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& v : m.vertices) v.normalize();

  for (int level = 0; level < subdivisions; ++level) {
    // Each undirected edge gets one midpoint, shared by the two faces that use it.
    std::unordered_map<std::uint64_t, int> midpointOf;
    midpointOf.reserve(m.faces.size() * 2);
    const auto midpoint = [&](int a, int b) {
      const auto lo = static_cast<std::uint64_t>(std::min(a, b));
      const auto hi = static_cast<std::uint64_t>(std::max(a, b));
      const auto [it, inserted] = midpointOf.try_emplace(lo << 32 | hi, 0);
      if (inserted) {
        it->second = static_cast<int>(m.vertices.size());
        m.vertices.push_back((m.vertices[a] + m.vertices[b]).normalized());
      }
      return it->second;
    };
    std::vector<std::array<int, 3>> finer;
    finer.reserve(m.faces.size() * 4);
    for (const auto& [a, b, c] : m.faces) {
      const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      finer.push_back({a, ab, ca});
      finer.push_back({b, bc, ab});
      finer.push_back({c, ca, bc});
      finer.push_back({ab, bc, ca});
    }
    m.faces = std::move(finer);
  }
  return m;
}

/// Per-axis affine map p -> scale .* p + offset.
struct AxisMap {
  Vec3d scale = Vec3d::Ones();
  Vec3d offset = Vec3d::Zero();
  [[nodiscard]] Vec3d operator()(const Vec3d& p) const { return scale.cwiseProduct(p) + offset; }
};

/// Scales each axis of `mesh` so that its bounding box measures `size` and centres the box at
/// the origin (a positive diagonal map keeps orientation and embedding); returns the map.
AxisMap fitToBox(TriangleMesh& mesh, const Vec3d& size) {
  const auto [lo, hi] = mesh.bounds();
  AxisMap map;
  map.scale = size.cwiseQuotient(hi - lo);
  map.offset = -map.scale.cwiseProduct(0.5 * (lo + hi));
  for (auto& v : mesh.vertices) v = map(v);
  return map;
}

// ---------------------------------------------------------------------------------------------
// Liver. Design space: x along the organ (right lobe at -x), y antero-posterior, z superior;
// roughly x in [-1, 1] before fitting to the paper's 100:62:88 proportions.
// ---------------------------------------------------------------------------------------------

/// An ellipsoid that contains the origin, seen from the origin.
struct Lobe {
  Vec3d centre;
  Eigen::Matrix3d toUnit;  // maps the ellipsoid, centred, onto the unit ball

  /// Ellipsoid with the given centre and semi-axes, its x axis turned up by `rise` radians
  /// towards +z (a rotation about y).
  Lobe(const Vec3d& c, const Vec3d& semiAxes, double rise)
      : centre(c),
        toUnit(semiAxes.cwiseInverse().asDiagonal() *
               Eigen::AngleAxisd(rise, Vec3d::UnitY()).toRotationMatrix()) {
    VOXCUT_ASSERT((toUnit * centre).norm() < 1.0, "Lobe: the origin must lie inside");
  }

  /// Distance from the origin to the ellipsoid's surface along unit direction d: the far root
  /// of |toUnit (t d - centre)|^2 = 1, positive because the origin is inside.
  [[nodiscard]] double reach(const Vec3d& d) const {
    const Vec3d a = toUnit * d, b = toUnit * centre;
    const double qa = a.squaredNorm(), qb = a.dot(b), qc = b.squaredNorm() - 1.0;
    return (qb + std::sqrt(qb * qb - qa * qc)) / qa;
  }
};

/// Radial function of the liver in design space: a smooth union of three ellipsoids (the big
/// right lobe, the flat left lobe tilted up towards its tip, and a bridge between them), taken
/// as the p-norm max(R_i) ~ (sum R_i^p)^(1/p), which rounds the creases where lobes meet.
double liverRadius(const Vec3d& d) {
  static const std::array<Lobe, 3> lobes = {
      Lobe({-0.40, 0.00, -0.20}, {0.60, 0.60, 0.80}, 0.00),  // right lobe
      Lobe({0.35, -0.05, 0.15}, {0.65, 0.30, 0.30}, 0.10),   // left lobe, tip raised
      Lobe({-0.05, 0.00, 0.10}, {0.70, 0.50, 0.50}, 0.00)};  // bridge under the dome
  constexpr double p = 6.0;
  double sum = 0.0;
  for (const auto& lobe : lobes) sum += std::pow(lobe.reach(d), p);
  return std::pow(sum, 1.0 / p);
}

/// Smooth injective warp of design space giving the wedge profile and the curvature. Depth y
/// is scaled by a positive factor, thinner towards the left tip (+x) and towards the sharp
/// inferior border (-z): with X = (x + 1) / 2 and Z = (z + 1) / 2 (both about 0..1),
///   y' = (1 - 0.35 X^2) (0.7 + 0.3 Z) y + 0.22 x^2,   z' = z - 0.10 x^2;
/// the x^2 terms are a shear with unit Jacobian that bends the organ around the ribcage.
/// For fixed (x, z) the map of y is increasing, so the warp is injective.
Vec3d liverWarp(const Vec3d& p) {
  const double alongX = 0.5 * (p.x() + 1.0), alongZ = 0.5 * (p.z() + 1.0);
  const double taper = (1.0 - 0.35 * alongX * alongX) * (0.7 + 0.3 * alongZ);
  return {p.x(), taper * p.y() + 0.22 * p.x() * p.x(), p.z() - 0.10 * p.x() * p.x()};
}

/// Tumor: a sphere with gentle low-order bumps (smooth, star-shaped), radius ~ `radius`.
TriangleMesh tumorBlob(const Vec3d& centre, double radius) {
  TriangleMesh m = unitIcosphere(4);
  for (auto& d : m.vertices) {
    const double bumps = 0.06 * d.x() * d.y() + 0.05 * (d.z() * d.z() - 1.0 / 3.0) +
                         0.04 * std::sin(3.0 * d.x() + 1.0);
    d = centre + radius * (1.0 + bumps) * d;
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// Starfish. Design space: the unit sphere mapped to a flat star, r1 = 1 at the arm tips.
// ---------------------------------------------------------------------------------------------

constexpr double kStarDisc = 0.30;  // outline radius half-way between arms (tips at 1)

/// Planar outline in polar form, r(theta) in [kStarDisc, 1], one arm along +y. With
/// u = (2/5) |sin(5 (theta - pi/2) / 2)| (about the angle to the nearest arm axis, flat half-way
/// between arms) the arm profile
///   f(u) = 1 / (1 + c (sqrt(u^2 + e^2) - e))
/// is the polar form of an arm whose width shrinks linearly towards the tip (r ~ 1 / (1 + c u)),
/// rounded over |u| < e so that each tip is a smooth cap; it is rescaled to g in [0, 1] from
/// the gaps to the tips: r = r0 + (1 - r0) g. It depends on u^2 only, hence is smooth.
double starfishOutline(double theta) {
  constexpr double r0 = kStarDisc, c = 3.5, e = 0.15;
  const auto f = [&](double u2) { return 1.0 / (1.0 + c * (std::sqrt(u2 + e * e) - e)); };
  const double u2 = 0.08 * (1.0 - std::cos(5.0 * (theta - 0.5 * std::numbers::pi)));
  const double fGap = f(0.16);  // u^2 = 0.16 half-way between arms
  return r0 + (1.0 - r0) * (f(u2) - fGap) / (1.0 - fGap);
}

/// Maps a unit-sphere point p (s = |(p_x, p_y)| in [0, 1], z = p_z = +-sqrt(1 - s^2)) to the
/// starfish. Both planar distortions fade in as s^2, so that near the poles the map is a plain
/// scaling (a strongly anisotropic map there would fold the triangles around the poles,
/// however fine the mesh):
///   theta' = theta - 0.075 s^2 sin(10 (theta - pi/2))   squeezes longitudes towards the arm
///            axes and the gaps (derivative 0.25 there at s = 1, 1.75 on the flanks), where
///            the outline curves most;
///   rho    = s (r0 + (r(theta') - r0) s^2)               reaches the outline at s = 1.
/// Both are increasing (in theta, in s), so the planar part is a bijection onto the outline.
/// The height is z' = z h(rho) sqrt(1 + s^2 + s^4 + s^6) k(z), so the top surface is
///   z' = h(rho) sqrt(1 - s^8) k(z),   h(rho) = h0 (1 - a rho^2):
/// flat at the centre (a round dome, no crease where the arms meet), thinner along each arm
/// towards its tip, rounded at the rim (vertical tangent at s = 1); the smooth step
/// k(z) = 0.8 + 0.2 z / sqrt(z^2 + 0.01) makes the underside flatter than the top. For a fixed
/// theta' the half circle of (s, z) goes to graphs above and below the planar outline, so the
/// whole map is injective.
Vec3d starfishMap(const Vec3d& p) {
  constexpr double h0 = 0.16, a = 0.35, r0 = kStarDisc;
  const double s2 = p.x() * p.x() + p.y() * p.y();
  const double theta0 = std::atan2(p.y(), p.x());
  const double theta = theta0 - 0.075 * s2 * std::sin(10.0 * (theta0 - 0.5 * std::numbers::pi));
  const double rho = std::sqrt(s2) * (r0 + (starfishOutline(theta) - r0) * s2);
  const double k = 0.8 + 0.2 * p.z() / std::sqrt(p.z() * p.z() + 0.01);
  const double rim = std::sqrt(1.0 + s2 * (1.0 + s2 * (1.0 + s2)));  // (1 - s^8) / (1 - s^2)
  const double t = h0 * (1.0 - a * rho * rho) * rim * k;
  return {rho * std::cos(theta), rho * std::sin(theta), t * p.z()};
}

}  // namespace

TriangleMesh makeBox(const Vec3d& size) {
  VOXCUT_ASSERT((size.array() > 0.0).all(), "makeBox: side lengths must be positive");
  const Vec3d h = 0.5 * size;
  TriangleMesh m;
  // Vertex i has coordinate +h on axis a where bit a of i is set, -h otherwise.
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back(i & 1 ? h.x() : -h.x(), i & 2 ? h.y() : -h.y(), i & 4 ? h.z() : -h.z());
  m.faces = {{0, 4, 6}, {0, 6, 2},   // -x
             {1, 3, 7}, {1, 7, 5},   // +x
             {0, 1, 5}, {0, 5, 4},   // -y
             {2, 6, 7}, {2, 7, 3},   // +y
             {0, 2, 3}, {0, 3, 1},   // -z
             {4, 5, 7}, {4, 7, 6}};  // +z
  return m;
}

TriangleMesh makeSphere(double radius, int subdivisions) {
  VOXCUT_ASSERT(radius > 0.0, "makeSphere: radius must be positive");
  VOXCUT_ASSERT(subdivisions >= 0 && subdivisions <= 8, "makeSphere: subdivisions in 0..8");
  TriangleMesh m = unitIcosphere(subdivisions);
  for (auto& v : m.vertices) v *= radius;
  return m;
}

std::vector<MaterialMesh> makeLiver() {
  TriangleMesh liver = unitIcosphere(5);
  for (auto& d : liver.vertices) {
    // Shifting the unit icosphere by +0.45 x before projecting back to the sphere keeps every
    // face facing away from the origin and crowds directions towards the thin left tip.
    d = (d + Vec3d(0.45, 0.0, 0.0)).normalized();
    d = liverWarp(liverRadius(d) * d);
  }
  const AxisMap fit = fitToBox(liver, Vec3d(0.200, 0.124, 0.176));

  // Off-centre in the right lobe, slightly posterior and superior, where the lobe is deepest.
  const Vec3d tumorCentre = fit(liverWarp(Vec3d(-0.50, 0.05, 0.10)));
  std::vector<MaterialMesh> out;
  out.push_back({"liver", std::move(liver)});
  out.push_back({"tumor", tumorBlob(tumorCentre, 0.018)});
  return out;
}

std::vector<MaterialMesh> makeStarfish() {
  TriangleMesh star = unitIcosphere(5);
  for (auto& p : star.vertices) p = starfishMap(p);
  fitToBox(star, Vec3d(0.200, 0.200 * 166.0 / 180.0, 0.200 * 30.0 / 180.0));
  std::vector<MaterialMesh> out;
  out.push_back({"default", std::move(star)});
  return out;
}

}  // namespace voxcut
