#include "voxcut/voxel/WindingNumber.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace voxcut {
namespace {
constexpr int kLeafSize = 8;
constexpr double kPi = 3.14159265358979323846;
}  // namespace

WindingNumberTree::WindingNumberTree(const TriangleMesh& mesh, double accuracy) : beta_(accuracy) {
  const std::size_t n = mesh.faces.size();
  v0_.resize(n);
  v1_.resize(n);
  v2_.resize(n);
  for (std::size_t f = 0; f < n; ++f) {
    v0_[f] = mesh.vertices[mesh.faces[f][0]];
    v1_[f] = mesh.vertices[mesh.faces[f][1]];
    v2_[f] = mesh.vertices[mesh.faces[f][2]];
  }
  nodes_.reserve(2 * n / kLeafSize + 2);
  if (n > 0) build(0, static_cast<int>(n), 0);
}

int WindingNumberTree::build(int first, int count, int depth) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  Vec3d an = Vec3d::Zero(), weighted = Vec3d::Zero(), lo = Vec3d::Constant(1e300),
        hi = Vec3d::Constant(-1e300);
  double area = 0.0;
  for (int t = first; t < first + count; ++t) {
    const Vec3d c = (v1_[t] - v0_[t]).cross(v2_[t] - v0_[t]);
    const double a = 0.5 * c.norm();
    an += 0.5 * c;
    area += a;
    const Vec3d centroid = (v0_[t] + v1_[t] + v2_[t]) / 3.0;
    weighted += a * centroid;
    lo = lo.cwiseMin(centroid);
    hi = hi.cwiseMax(centroid);
  }
  Vec3d centre = area > 0 ? Vec3d(weighted / area) : Vec3d(0.5 * (lo + hi));
  double r = 0.0;
  for (int t = first; t < first + count; ++t)
    r = std::max({r, (v0_[t] - centre).norm(), (v1_[t] - centre).norm(), (v2_[t] - centre).norm()});
  nodes_[id].centre = centre;
  nodes_[id].areaNormal = an;
  nodes_[id].radius = r;
  nodes_[id].first = first;
  nodes_[id].count = count;
  if (count <= kLeafSize || depth > 60) return id;

  // Median split of centroids along the widest axis.
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  std::vector<int> idx(count);
  std::iota(idx.begin(), idx.end(), first);
  const int mid = count / 2;
  auto key = [&](int t) { return v0_[t][axis] + v1_[t][axis] + v2_[t][axis]; };
  std::nth_element(idx.begin(), idx.begin() + mid, idx.end(),
                   [&](int a, int b) { return key(a) < key(b) || (key(a) == key(b) && a < b); });
  std::vector<Vec3d> a0(count), a1(count), a2(count);
  for (int k = 0; k < count; ++k) {
    a0[k] = v0_[idx[k]];
    a1[k] = v1_[idx[k]];
    a2[k] = v2_[idx[k]];
  }
  std::copy(a0.begin(), a0.end(), v0_.begin() + first);
  std::copy(a1.begin(), a1.end(), v1_.begin() + first);
  std::copy(a2.begin(), a2.end(), v2_.begin() + first);
  const int l = build(first, mid, depth + 1);
  const int rgt = build(first + mid, count - mid, depth + 1);
  nodes_[id].left = l;
  nodes_[id].right = rgt;
  return id;
}

double WindingNumberTree::exactSolidAngle(int t, const Vec3d& p) const {
  // Van Oosterom & Strackee: tan(Omega/2) = a.(b x c) / (|a||b||c| + (a.b)|c| + (b.c)|a| +
  // (c.a)|b|).
  const Vec3d a = v0_[t] - p, b = v1_[t] - p, c = v2_[t] - p;
  const double la = a.norm(), lb = b.norm(), lc = c.norm();
  const double num = a.dot(b.cross(c));
  const double den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
  return 2.0 * std::atan2(num, den);
}

double WindingNumberTree::operator()(const Vec3d& p) const {
  if (nodes_.empty()) return 0.0;
  double omega = 0.0;
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& nd = nodes_[stack[--top]];
    const Vec3d d = nd.centre - p;
    const double dist = d.norm();
    if (dist > beta_ * nd.radius && dist > 0) {
      // Dipole far field: the node's area vector seen from p.
      omega += nd.areaNormal.dot(d) / (dist * dist * dist);
    } else if (nd.left < 0) {
      for (int t = nd.first; t < nd.first + nd.count; ++t) omega += exactSolidAngle(t, p);
    } else {
      stack[top++] = nd.left;
      stack[top++] = nd.right;
    }
  }
  return omega / (4.0 * kPi);
}

}  // namespace voxcut
