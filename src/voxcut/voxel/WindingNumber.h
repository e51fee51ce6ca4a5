#pragma once
/// @file WindingNumber.h
/// Generalized winding number (Jacobson et al. 2013) of a triangle mesh, evaluated fast with a
/// bounding volume hierarchy and a first-order (dipole) far-field expansion (Barill et al.
/// 2018). w(p) = (1/4pi) * sum of signed solid angles of the triangles seen from p: 1 inside a
/// closed outward mesh, 0 outside, and in between near holes.

#include <vector>

#include "voxcut/core/TriangleMesh.h"

namespace voxcut {

/// Immutable after construction; concurrent queries are safe.
class WindingNumberTree {
 public:
  /// Builds the hierarchy over `mesh` (copied). `accuracy` is the far-field ratio beta:
  /// a node is expanded when the query is closer than beta * (node radius).
  explicit WindingNumberTree(const TriangleMesh& mesh, double accuracy = 2.0);

  /// Winding number at p.
  [[nodiscard]] double operator()(const Vec3d& p) const;

 private:
  struct Node {
    Vec3d centre;              // area-weighted centroid of the node's triangles
    Vec3d areaNormal;          // sum of (area * unit normal) = half the sum of edge cross products
    double radius = 0;         // max distance from centre to a vertex of the node's triangles
    int first = 0, count = 0;  // triangle range (leaves)
    int left = -1, right = -1;
  };
  int build(int first, int count, int depth);
  double exactSolidAngle(int tri, const Vec3d& p) const;

  std::vector<Vec3d> v0_, v1_, v2_;  // triangle corners, permuted into tree order
  std::vector<Node> nodes_;
  double beta_;
};

}  // namespace voxcut
