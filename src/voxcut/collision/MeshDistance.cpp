#include "voxcut/collision/MeshDistance.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "voxcut/collision/FaceCrossings.h"
#include "voxcut/collision/TriangleClosestPoint.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/voxel/MeshRepair.h"

namespace voxcut {
namespace {

constexpr int kLeafSize = 4;
constexpr int kMaxDepth = 60;  // median splits stay far below it (log2 of the triangle count)
constexpr double kInfinity = std::numeric_limits<double>::infinity();
// MeshDistance::sides_ bits.
constexpr std::uint8_t kKnown = 1, kInsideAbove = 2, kInsideBelow = 4;
// x - c within about 1e-5 rad of a face's normal: x is on the face's normal line.
constexpr double kOnNormalLine = 1.0 - 1e-10;

/// The squared distance from x to the box [lo, hi] (0 inside it).
double boxDistance2(const Vec3d& lo, const Vec3d& hi, const Vec3d& x) {
  return ((lo - x).cwiseMax(0.0) + (x - hi).cwiseMax(0.0)).squaredNorm();
}

}  // namespace

MeshDistance::Repaired MeshDistance::repaired(const TriangleMesh& mesh) {
  RepairReport report;
  Repaired r;
  r.mesh = repairMesh(mesh, &report);
  r.watertight = report.watertight;
  return r;
}

MeshDistance::MeshDistance(const TriangleMesh& mesh) : MeshDistance(repaired(mesh)) {}

MeshDistance::MeshDistance(const Repaired& repaired)
    : watertight_(repaired.watertight), winding_(repaired.mesh) {
  const TriangleMesh& mesh = repaired.mesh;
  const std::size_t n = mesh.faces.size();
  bounds_ = {Vec3d::Constant(kInfinity), Vec3d::Constant(-kInfinity)};
  if (n == 0) return;
  orientation_ = mesh.signedVolume() < 0.0 ? -1.0 : 1.0;
  a_.resize(n);
  b_.resize(n);
  c_.resize(n);
  std::vector<Vec3d> centroids(n);
  double longestEdges = 0.0;
  for (std::size_t f = 0; f < n; ++f) {
    a_[f] = mesh.vertices[mesh.faces[f][0]];
    b_[f] = mesh.vertices[mesh.faces[f][1]];
    c_[f] = mesh.vertices[mesh.faces[f][2]];
    centroids[f] = (a_[f] + b_[f] + c_[f]) / 3.0;
    longestEdges +=
        std::max({(b_[f] - a_[f]).norm(), (c_[f] - b_[f]).norm(), (a_[f] - c_[f]).norm()});
  }
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  nodes_.reserve(2 * n / kLeafSize + 2);
  build(order, centroids, 0, static_cast<int>(n), 0);
  // The corners in tree order, so that a leaf's triangles lie side by side.
  const auto permuted = [&](const std::vector<Vec3d>& in) {
    std::vector<Vec3d> out(n);
    for (std::size_t k = 0; k < n; ++k) out[k] = in[order[k]];
    return out;
  };
  a_ = permuted(a_);
  b_ = permuted(b_);
  c_ = permuted(c_);
  unitNormal_.resize(n);
  for (std::size_t t = 0; t < n; ++t) {
    const Vec3d cross = (b_[t] - a_[t]).cross(c_[t] - a_[t]);
    const double length = cross.norm();
    unitNormal_[t] = length > 0.0 ? Vec3d(cross / length) : Vec3d(Vec3d::Zero());
  }
  bounds_ = {nodes_[0].lo, nodes_[0].hi};
  surfaceTolerance_ = 1e-10 * (bounds_[1] - bounds_[0]).norm();
  // Within about two triangles of the surface the nearest face is cheaper to find than w is
  // to evaluate (farther, w's far field makes it the cheaper of the two).
  if (watertight_) sideRadius_ = 2.0 * longestEdges / static_cast<double>(n);
  sides_.assign(n, 0);
  if (watertight_) {
    const std::vector<std::uint8_t> crossed = crossedFaces(mesh);
    std::vector<std::uint8_t> crossedInTreeOrder(n);
    for (std::size_t k = 0; k < n; ++k) crossedInTreeOrder[k] = crossed[order[k]];
    classifyFaceSides(crossedInTreeOrder);
  }
}

int MeshDistance::build(std::vector<int>& order, const std::vector<Vec3d>& centroids, int first,
                        int count, int depth) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  Vec3d lo = Vec3d::Constant(kInfinity), hi = Vec3d::Constant(-kInfinity);
  Vec3d clo = lo, chi = hi;  // bounds of the centroids
  for (int k = first; k < first + count; ++k) {
    const int t = order[k];
    lo = lo.cwiseMin(a_[t]).cwiseMin(b_[t]).cwiseMin(c_[t]);
    hi = hi.cwiseMax(a_[t]).cwiseMax(b_[t]).cwiseMax(c_[t]);
    clo = clo.cwiseMin(centroids[t]);
    chi = chi.cwiseMax(centroids[t]);
  }
  nodes_[id].lo = lo;
  nodes_[id].hi = hi;
  nodes_[id].first = first;
  nodes_[id].count = count;
  if (count <= kLeafSize || depth >= kMaxDepth) return id;

  // Median split of the centroids along their widest axis (ties by index: deterministic).
  int axis = 0;
  (chi - clo).maxCoeff(&axis);
  const int mid = count / 2;
  std::nth_element(order.begin() + first, order.begin() + first + mid,
                   order.begin() + first + count, [&](int s, int t) {
                     return centroids[s][axis] < centroids[t][axis] ||
                            (centroids[s][axis] == centroids[t][axis] && s < t);
                   });
  const int left = build(order, centroids, first, mid, depth + 1);
  const int right = build(order, centroids, first + mid, count - mid, depth + 1);
  nodes_[id].left = left;
  nodes_[id].right = right;
  return id;
}

int MeshDistance::nearestTriangle(const Vec3d& x, double& best2, Vec3d& nearest) const {
  if (nodes_.empty()) return -1;
  struct Entry {
    int node;
    double distance2;  // from x to the node's box
  };
  // Depth-first, nearer child first: at most one waiting sibling per level.
  Entry stack[kMaxDepth + 2];
  int top = 0;
  const double root = boxDistance2(nodes_[0].lo, nodes_[0].hi, x);
  if (!(root < best2)) return -1;
  stack[top++] = {0, root};
  int found = -1;
  while (top > 0) {
    const Entry e = stack[--top];
    if (!(e.distance2 < best2)) continue;  // pruned by a triangle found since it was pushed
    const Node& nd = nodes_[e.node];
    if (nd.left < 0) {
      for (int t = nd.first; t < nd.first + nd.count; ++t) {
        // The distance to the triangle's plane bounds the distance to the triangle.
        const double h = (x - a_[t]).dot(unitNormal_[t]);
        if (!(h * h < best2)) continue;
        const Vec3d q = closestPointOnTriangle(x, a_[t], b_[t], c_[t]);
        const double d2 = (x - q).squaredNorm();
        if (d2 < best2) {
          best2 = d2;
          nearest = q;
          found = t;
        }
      }
      continue;
    }
    const double dl = boxDistance2(nodes_[nd.left].lo, nodes_[nd.left].hi, x);
    const double dr = boxDistance2(nodes_[nd.right].lo, nodes_[nd.right].hi, x);
    const bool leftFirst = dl <= dr;
    const Entry nearer = leftFirst ? Entry{nd.left, dl} : Entry{nd.right, dr};
    const Entry farther = leftFirst ? Entry{nd.right, dr} : Entry{nd.left, dl};
    if (farther.distance2 < best2) stack[top++] = farther;
    if (nearer.distance2 < best2) stack[top++] = nearer;
  }
  return found;
}

void MeshDistance::classifyFaceSides(const std::vector<std::uint8_t>& crossed) {
  parallelFor(0, a_.size(), 64, [&](std::size_t lo, std::size_t hi) {
    for (std::size_t t = lo; t < hi; ++t) {
      // Another face through this one: more than one region on each side.
      if (crossed[t] != 0) continue;
      const Vec3d ab = b_[t] - a_[t], bc = c_[t] - b_[t], ca = a_[t] - c_[t];
      const double perimeter = ab.norm() + bc.norm() + ca.norm();
      const double inradius = ab.cross(-ca).norm() / perimeter;  // 2 area / perimeter
      if (!(inradius > 0.0) || unitNormal_[t] == Vec3d::Zero()) continue;
      // Just off the centroid on either side: no other face meets this one, so only one
      // passing within a thousandth of its inradius could come between.
      const Vec3d centroid = (a_[t] + b_[t] + c_[t]) / 3.0;
      const Vec3d offset = 1e-3 * inradius * unitNormal_[t];
      const double above = winding_(centroid + offset), below = winding_(centroid - offset);
      const double roundAbove = std::round(above), roundBelow = std::round(below);
      // Crossing an outward face inwards adds 1 to w.
      if (std::abs(above - roundAbove) > 0.25 || std::abs(below - roundBelow) > 0.25 ||
          roundBelow - roundAbove != 1.0)
        continue;
      sides_[t] =
          static_cast<std::uint8_t>(kKnown | (std::abs(roundAbove) >= 1.0 ? kInsideAbove : 0) |
                                    (std::abs(roundBelow) >= 1.0 ? kInsideBelow : 0));
    }
  });
}

int MeshDistance::sideOfFace(int t, const Vec3d& x, const Vec3d& c, double d) const {
  const std::uint8_t sides = sides_[t];
  if ((sides & kKnown) == 0) return -1;
  // On the face's normal line, c is inside the face (or on its rim, seen straight on): the
  // open segment from x to c meets no face, so x is in the region just off that side.
  const double cosine = (x - c).dot(unitNormal_[t]) / d;
  if (cosine >= kOnNormalLine) return (sides & kInsideAbove) != 0 ? 1 : 0;
  if (cosine <= -kOnNormalLine) return (sides & kInsideBelow) != 0 ? 1 : 0;
  return -1;
}

Vec3d MeshDistance::faceNormal(int t) const {
  return unitNormal_[t] != Vec3d::Zero() ? Vec3d(orientation_ * unitNormal_[t])
                                         : Vec3d(Vec3d::UnitY());
}

double MeshDistance::signedDistance(const Vec3d& x, Vec3d& normal, double maxDistance) const {
  VOXCUT_ASSERT(maxDistance >= 0.0, "maxDistance must be >= 0");
  normal = Vec3d::UnitY();
  if (a_.empty()) return kInfinity;
  // Outside the bounding box, x is outside; the box's distance is a lower bound of the mesh's.
  const Vec3d fromBox = (x - bounds_[1]).cwiseMax(0.0) - (bounds_[0] - x).cwiseMax(0.0);
  const double box2 = fromBox.squaredNorm();
  const bool outsideBox = box2 > 0.0;
  if (outsideBox && box2 >= maxDistance * maxDistance) {
    const double d = std::sqrt(box2);
    normal = fromBox / d;
    return d;
  }
  // Inside the box, the search goes on past the bound as far as a nearest face is likely to
  // tell the side without w.
  const double reach = outsideBox ? maxDistance : std::max(maxDistance, sideRadius_);
  double best2 = reach * reach;
  Vec3d nearest = x;
  int t = nearestTriangle(x, best2, nearest);
  int inside = outsideBox ? 0 : -1;
  if (inside < 0 && t >= 0 && best2 > surfaceTolerance_ * surfaceTolerance_)
    inside = sideOfFace(t, x, nearest, std::sqrt(best2));
  if (inside < 0) inside = std::abs(winding_(x)) > 0.5 ? 1 : 0;
  if (t < 0) {
    if (inside == 0) {
      if (outsideBox) normal = fromBox / std::sqrt(box2);
      return maxDistance;
    }
    // Deep inside: the bound was no use; the exact distance is needed.
    best2 = kInfinity;
    t = nearestTriangle(x, best2, nearest);
    if (t < 0) return maxDistance;  // x not finite
  }
  const double d = std::sqrt(best2);
  if (d <= surfaceTolerance_) {
    normal = faceNormal(t);
  } else {
    normal = (inside != 0 ? nearest - x : x - nearest) / d;
  }
  return inside != 0 ? -d : d;
}

Vec3d MeshDistance::closestPoint(const Vec3d& x) const {
  double best2 = kInfinity;
  Vec3d nearest = x;
  (void)nearestTriangle(x, best2, nearest);
  return nearest;
}

}  // namespace voxcut
