#include "DrawData.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include "voxcut/core/Stamp.h"

namespace voxcut::view {
namespace {

using Colour = Eigen::Vector3f;

const Colour kBlade(0.82f, 0.84f, 0.88f);
const Colour kProbe(0.30f, 0.55f, 0.95f);
const Colour kObstacle(0.46f, 0.47f, 0.50f);
const Colour kLink(0.95f, 0.85f, 0.20f);

void pushVertex(std::vector<float>& out, const Vec3d& p, const Vec3d& n, const Colour& c) {
  out.insert(out.end(),
             {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()),
              static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()),
              c.x(), c.y(), c.z()});
}

/// A flat-shaded triangle (its own normal at every corner).
void pushFlat(std::vector<float>& out, const Vec3d& a, const Vec3d& b, const Vec3d& c,
              const Colour& colour) {
  Vec3d n = (b - a).cross(c - a);
  const double len = n.norm();
  n = len > 0.0 ? Vec3d(n / len) : Vec3d::UnitY();
  pushVertex(out, a, n, colour);
  pushVertex(out, b, n, colour);
  pushVertex(out, c, n, colour);
}

void pushLine(std::vector<float>& out, const Vec3d& a, const Vec3d& b, const Colour& c) {
  for (const Vec3d* p : {&a, &b})
    out.insert(out.end(), {static_cast<float>(p->x()), static_cast<float>(p->y()),
                           static_cast<float>(p->z()), c.x(), c.y(), c.z()});
}

/// Two unit vectors perpendicular to the unit vector d and to each other.
void basis(const Vec3d& d, Vec3d& u, Vec3d& v) {
  u = (std::abs(d.x()) < 0.9 ? Vec3d::UnitX() : Vec3d::UnitY()).cross(d).normalized();
  v = d.cross(u);
}

/// A sphere of radius r around c, smooth-shaded.
void pushSphere(std::vector<float>& out, const Vec3d& c, double r, const Colour& colour) {
  constexpr int kRings = 10, kSegments = 16;
  auto at = [&](int i, int j) {
    const double th = std::numbers::pi * i / kRings, ph = 2.0 * std::numbers::pi * j / kSegments;
    return Vec3d(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
  };
  for (int i = 0; i < kRings; ++i)
    for (int j = 0; j < kSegments; ++j) {
      const Vec3d n00 = at(i, j), n01 = at(i, j + 1), n10 = at(i + 1, j), n11 = at(i + 1, j + 1);
      for (const auto& [p, q, s] : {std::array<Vec3d, 3>{n00, n11, n10}, {n00, n01, n11}}) {
        if ((q - p).cross(s - p).norm() < 1e-12) continue;  // the poles' degenerate halves
        pushVertex(out, c + r * p, p, colour);
        pushVertex(out, c + r * q, q, colour);
        pushVertex(out, c + r * s, s, colour);
      }
    }
}

/// A cylinder of radius r around the segment a-b (open ends), smooth-shaded.
void pushCylinder(std::vector<float>& out, const Vec3d& a, const Vec3d& b, double r,
                  const Colour& colour) {
  const Vec3d axis = b - a;
  if (!(axis.norm() > 0.0)) return;
  Vec3d u, v;
  basis(axis.normalized(), u, v);
  constexpr int kSegments = 16;
  for (int j = 0; j < kSegments; ++j) {
    const double p0 = 2.0 * std::numbers::pi * j / kSegments;
    const double p1 = 2.0 * std::numbers::pi * (j + 1) / kSegments;
    const Vec3d n0 = std::cos(p0) * u + std::sin(p0) * v, n1 = std::cos(p1) * u + std::sin(p1) * v;
    pushVertex(out, a + r * n0, n0, colour);
    pushVertex(out, a + r * n1, n1, colour);
    pushVertex(out, b + r * n1, n1, colour);
    pushVertex(out, a + r * n0, n0, colour);
    pushVertex(out, b + r * n1, n1, colour);
    pushVertex(out, b + r * n0, n0, colour);
  }
}

void pushBox(std::vector<float>& out, const Vec3d& lo, const Vec3d& hi, const Colour& colour) {
  auto corner = [&](int k) {
    return Vec3d(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z());
  };
  // Each face as two triangles, counter-clockwise seen from outside.
  static const std::array<std::array<int, 4>, 6> kFaces{
      {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}}};
  for (const auto& f : kFaces) {
    pushFlat(out, corner(f[0]), corner(f[1]), corner(f[2]), colour);
    pushFlat(out, corner(f[0]), corner(f[2]), corner(f[3]), colour);
  }
}

}  // namespace

Colour materialColour(int material) {
  static const std::array<Colour, 6> kPalette{
      Colour(0.88f, 0.60f, 0.52f), Colour(0.58f, 0.70f, 0.40f), Colour(0.55f, 0.60f, 0.88f),
      Colour(0.85f, 0.75f, 0.40f), Colour(0.70f, 0.50f, 0.80f), Colour(0.45f, 0.78f, 0.75f)};
  return kPalette[static_cast<std::size_t>(std::max(material - 1, 0)) % kPalette.size()];
}

Colour cutColour(int material) {
  // Deep red tissue, tinted a little by the material so that cuts through different
  // materials still differ.
  return 0.75f * Colour(0.78f, 0.10f, 0.12f) + 0.25f * materialColour(material);
}

Colour backgroundColour() {
  return {0.11f, 0.12f, 0.15f};
}

DrawData buildDrawData(World& world, const std::vector<Obstacle>& obstacles,
                       const DrawOptions& options) {
  DrawData d;
  d.stamp = newStamp();
  // The bodies' surfaces, indexed (a renderer then shades each vertex once): smooth normals;
  // each vertex slot twice, in its material's colour and its cut colour, so that a cut's
  // triangles keep their colour up to their edges.
  for (const BodyId b : world.bodies()) {
    const SurfaceView s = world.surface(b);
    // The model's own colours (a segmentation's) where it has them, else the palette.
    const auto colours = world.bodyInfo(b).materialColours;
    const auto colourOf = [&colours](std::uint8_t m) {
      if (m >= 1 && m <= colours.size() && colours[m - 1u])
        return Colour((*colours[m - 1u])[0], (*colours[m - 1u])[1], (*colours[m - 1u])[2]);
      return materialColour(m);
    };
    const auto base = static_cast<std::uint32_t>(d.bodyVertices.size() / kTriangleStride);
    std::vector<std::uint8_t> material(s.positions.size(), 0);
    for (std::size_t t = 0; t < s.triangles.size(); ++t) {
      const std::array<int, 3>& tri = s.triangles[t];
      if (tri[0] < 0) continue;
      const TriangleTag tag = s.triangleTags[t];
      for (const int v : tri) {
        material[static_cast<std::size_t>(v)] = tag.material;
        d.bodyIndices.push_back(base + 2 * static_cast<std::uint32_t>(v) + tag.cut);
      }
    }
    for (std::size_t v = 0; v < s.positions.size(); ++v) {
      // Dead slots (material 0 here) are never indexed; they keep the arrays aligned.
      pushVertex(d.bodyVertices, s.positions[v], s.normals[v], colourOf(material[v]));
      pushVertex(d.bodyVertices, s.positions[v], s.normals[v], cutColour(material[v]));
      if (material[v] != 0) d.bodyBounds.extend(s.positions[v]);
    }
  }
  const Eigen::AlignedBox3d bounds =
      d.bodyBounds.isEmpty() ? Eigen::AlignedBox3d(Vec3d::Zero(), Vec3d::Zero()) : d.bodyBounds;
  const double size = std::max(bounds.diagonal().norm(), 1e-3);
  // Tools: a blade as a thin rod along its edge, a probe as its sphere or capsule.
  for (const ToolId t : world.tools()) {
    const BladePose p = world.toolPose(t);
    if (world.toolKind(t) == ToolKind::Blade) {
      pushCylinder(d.triangles, p.a, p.b, 0.004 * size, kBlade);
    } else {
      const double r = world.toolRadius(t);
      pushSphere(d.triangles, p.a, r, kProbe);
      if (p.a != p.b) {
        pushSphere(d.triangles, p.b, r, kProbe);
        pushCylinder(d.triangles, p.a, p.b, r, kProbe);
      }
    }
  }
  // Obstacles: a plane as a square around the bodies, boxes and meshes as they are.
  for (const Obstacle& o : obstacles) {
    switch (o.type) {
      case ObstacleType::Plane: {
        Vec3d u, v;
        const Vec3d n = o.normal.normalized();
        basis(n, u, v);
        const Vec3d c = bounds.center() - n.dot(bounds.center() - o.point) * n;
        const double h = 1.5 * size;
        pushFlat(d.triangles, c - h * u - h * v, c - h * u + h * v, c + h * u + h * v, kObstacle);
        pushFlat(d.triangles, c - h * u - h * v, c + h * u + h * v, c + h * u - h * v, kObstacle);
        break;
      }
      case ObstacleType::Box:
        pushBox(d.triangles, o.lo, o.hi, kObstacle);
        break;
      case ObstacleType::Mesh:
        if (o.mesh)
          for (std::size_t i = 0; i < o.mesh->triangleCount(); ++i) {
            const std::array<Vec3d, 3> tri = o.mesh->triangle(i);
            pushFlat(d.triangles, tri[0], tri[1], tri[2], kObstacle);
          }
        break;
    }
  }
  // The pseudo voxel octree made visible.
  if (options.activeLinks || options.octreeCubes) {
    for (const BodyId b : world.bodies()) {
      // The section's layer: within half a voxel of the plane across z through the middle.
      const double half = 0.5 * world.bodyInfo(b).voxelSize, mid = bounds.center().z();
      const double far = 1e6;  // the coordinate range (core/CoordinateRange.h)
      const Eigen::AlignedBox3d layer(Vec3d(-far, -far, mid - half), Vec3d(far, far, mid + half));
      const ActivityView a = world.activity(b, options.activeLinks ? options.maxLinks : 0,
                                            options.slice ? &layer : nullptr);
      for (const auto& l : a.links) pushLine(d.lines, l[0], l[1], kLink);
      d.linkSegments += a.links.size();
      if (options.octreeCubes) {
        static const std::array<std::array<int, 2>, 12> kEdges{{{0, 1},
                                                                {2, 3},
                                                                {4, 5},
                                                                {6, 7},
                                                                {0, 2},
                                                                {1, 3},
                                                                {4, 6},
                                                                {5, 7},
                                                                {0, 4},
                                                                {1, 5},
                                                                {2, 6},
                                                                {3, 7}}};
        d.cubeCount += a.cubes.size();
        for (std::size_t c = 0; c < a.cubes.size(); ++c) {
          // Larger cubes in cooler colours.
          const float s = std::min(1.0f, static_cast<float>(a.cubeLevels[c]) / 4.0f);
          const Colour colour(0.2f + 0.6f * (1.0f - s), 0.85f, 0.3f + 0.6f * s);
          for (const auto& e : kEdges)
            pushLine(d.lines, a.cubes[c][static_cast<std::size_t>(e[0])],
                     a.cubes[c][static_cast<std::size_t>(e[1])], colour);
        }
      }
    }
  }
  return d;
}

std::optional<Vec3d> pick(const DrawData& data, const Ray& ray) {
  // Möller-Trumbore against every body triangle: run once per mouse press.
  double best = std::numeric_limits<double>::infinity();
  const float* f = data.bodyVertices.data();
  auto vertex = [&](std::size_t i) {
    const float* p = f + data.bodyIndices[i] * kTriangleStride;
    return Vec3d(p[0], p[1], p[2]);
  };
  for (std::size_t i = 0; i + 2 < data.bodyIndices.size(); i += 3) {
    const Vec3d a = vertex(i), b = vertex(i + 1), c = vertex(i + 2);
    const Vec3d e1 = b - a, e2 = c - a, p = ray.direction.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-18) continue;
    const Vec3d s = ray.origin - a;
    const double u = s.dot(p) / det;
    if (u < 0.0 || u > 1.0) continue;
    const Vec3d q = s.cross(e1);
    const double v = ray.direction.dot(q) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    const double t = e2.dot(q) / det;
    if (t > 0.0 && t < best) best = t;
  }
  if (!std::isfinite(best)) return std::nullopt;
  return ray.origin + best * ray.direction;
}

}  // namespace voxcut::view
