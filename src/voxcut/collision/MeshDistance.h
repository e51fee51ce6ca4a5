#pragma once
/// @file MeshDistance.h
/// The signed distance to a static triangle mesh, the shape of a mesh obstacle
/// (docs/algorithms.md, "Mesh obstacles"). Its magnitude is the exact distance to the nearest
/// point of the mesh's triangles, found in a bounding volume hierarchy over them, nearest child
/// first with branch-and-bound pruning; its sign comes from the generalized winding number w
/// (voxel/WindingNumber.h): inside where |w| > 1/2, as the voxelizer decides for bodies, so a
/// small hole, a non-manifold edge or an inverted shell does not flip it the way a nearest
/// face's normal would. Units: metres, world frame.
///
/// Thread-safety: immutable after construction; concurrent queries are safe.

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "voxcut/core/TriangleMesh.h"
#include "voxcut/voxel/WindingNumber.h"

namespace voxcut {

class MeshDistance {
 public:
  /// Builds the hierarchies over `mesh` (#V vertices, #F faces; copied). The mesh goes through
  /// repairMesh first (voxel/MeshRepair.h: welded, degenerate and duplicate faces dropped,
  /// orientation made consistent per patch); an input with no face left gives an empty
  /// MeshDistance (triangleCount() == 0), whose distance is +infinity everywhere. For a
  /// watertight mesh, the faces other faces meet are found, and w is evaluated once on each
  /// side of every other face (in parallel), so that queries near a face need not evaluate it.
  /// Coordinates must be finite. O(F log F) time (plus the face pairs whose boxes overlap),
  /// O(F) memory.
  explicit MeshDistance(const TriangleMesh& mesh);

  /// The signed distance of `x` from the mesh's surface (m; negative inside) and, in `normal`,
  /// the unit direction in which it grows fastest: from the nearest point c of the surface
  /// towards x outside, from x towards c inside; within 1e-10 of the mesh's size of the
  /// surface, the nearest triangle's normal (outward for a mesh of positive volume).
  ///
  /// Inside or outside: points outside the mesh's bounding box are outside. Otherwise w(x)
  /// decides, except where the mesh is watertight and x lies on the normal line of its nearest
  /// face (c inside that face): no face lies between x and c and w only changes across faces,
  /// so w on x's side of that face, evaluated when the mesh was built, decides. That is used
  /// only for faces no other face meets (FaceCrossings.h: where the mesh passes through
  /// itself, a face has more than one region on a side) and whose two sides' values came out
  /// clearly as integers one apart.
  ///
  /// `maxDistance` (>= 0) bounds the work: where the signed distance is at least maxDistance
  /// the result is only some value >= maxDistance and `normal` some unit vector; the search
  /// then stops as soon as no triangle can be nearer (a point that far outside the bounding
  /// box costs one box test). Below maxDistance the result is exact.
  [[nodiscard]] double signedDistance(
      const Vec3d& x, Vec3d& normal,
      double maxDistance = std::numeric_limits<double>::infinity()) const;

  /// The nearest point of the surface to `x` (x itself for an empty mesh).
  [[nodiscard]] Vec3d closestPoint(const Vec3d& x) const;

  /// Triangles after repair.
  [[nodiscard]] std::size_t triangleCount() const { return a_.size(); }
  /// Corners of triangle i (0 <= i < triangleCount(), after the repair; for drawing).
  [[nodiscard]] std::array<Vec3d, 3> triangle(std::size_t i) const { return {a_[i], b_[i], c_[i]}; }
  /// Axis-aligned bounds of the repaired mesh, {min, max}; {+inf, -inf} when empty.
  [[nodiscard]] const std::array<Vec3d, 2>& bounds() const { return bounds_; }
  /// Whether the repaired mesh is watertight (RepairReport::watertight).
  [[nodiscard]] bool watertight() const { return watertight_; }

 private:
  struct Repaired {
    TriangleMesh mesh;
    bool watertight = false;
  };
  static Repaired repaired(const TriangleMesh& mesh);
  explicit MeshDistance(const Repaired& repaired);

  struct Node {
    Vec3d lo, hi;              // bounds of the node's triangles
    int first = 0, count = 0;  // triangle range (leaves)
    int left = -1, right = -1;
  };
  /// Nearest triangle to x closer than sqrt(best2): its index, or -1; best2 and nearest are
  /// updated.
  int nearestTriangle(const Vec3d& x, double& best2, Vec3d& nearest) const;
  int build(std::vector<int>& order, const std::vector<Vec3d>& centroids, int first, int count,
            int depth);
  /// sides_: per face that no other face meets (`crossed`, in tree order, 0), whether each side
  /// of it is inside, where w just off its centroid on the two sides is clearly two integers
  /// one apart.
  void classifyFaceSides(const std::vector<std::uint8_t>& crossed);
  /// Whether x, nearest to point c of face t at distance d > 0, is inside, from t's side
  /// values: 1 inside, 0 outside, -1 when they cannot tell.
  [[nodiscard]] int sideOfFace(int t, const Vec3d& x, const Vec3d& c, double d) const;
  /// The unit normal of triangle t, outward for a mesh of positive volume.
  [[nodiscard]] Vec3d faceNormal(int t) const;

  std::vector<Vec3d> a_, b_, c_;     // triangle corners, in tree order
  std::vector<Vec3d> unitNormal_;    // per triangle, as wound; zero where it has none
  std::vector<std::uint8_t> sides_;  // per triangle, kKnown | kInsideAbove | kInsideBelow bits
  std::vector<Node> nodes_;
  std::array<Vec3d, 2> bounds_;
  double surfaceTolerance_ = 0.0;  // below it, x is on the surface (m)
  double orientation_ = 1.0;       // +1, or -1 for a mesh of negative volume
  double sideRadius_ = 0.0;        // how far the search goes for a face that knows its sides
  bool watertight_ = false;
  WindingNumberTree winding_;
};

}  // namespace voxcut
