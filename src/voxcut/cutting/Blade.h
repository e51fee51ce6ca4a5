#pragma once
/// @file Blade.h
/// The blade (a segment) and the surface it sweeps between two frames: a bilinear patch split
/// into two triangles with bit-identical shared corners; exact segment-sweep crossing tests
/// with consistent tie-breaking; an oriented bounding box of the sweep for culling.
///
/// Units: metres, in the world (deformed) frame. Thread-safety: all types are plain values
/// and all functions are pure; a BladeSweep may be read by any number of threads at once.
///
/// Tie-breaking rule (simulation of simplicity, see orient3dSoS in core/Predicates.h): every
/// point takes part in the orientation tests through a symbolic key. Segment endpoints (voxel
/// positions) use the key (0, voxel id); blade corners use (1, corner id), with corner id
/// 2 * pose + (0 for end a, 1 for end b) and pose = frame for the start pose and frame + 1
/// for the end pose, so frame k's end pose and frame k+1's start pose share their keys.
/// Every point is displaced by an infinitesimal amount that decreases with its key, largest
/// along z, then y, then x; all tests are decided exactly for the displaced points, which
/// are in general position. Hence, for bit-identical inputs:
///  - a segment through the shared diagonal, a shared corner or the shared edge between
///    consecutive sweeps crosses exactly one of the triangles there (where the sweeps form a
///    locally flat sheet that the segment crosses transversally);
///  - voxels rank before blade corners, so a voxel lying exactly on a triangle's plane is
///    on the side that +z points to (+y when the plane contains z, then +x): of two collinear
///    links meeting at that voxel on opposite sides, exactly one is cut, and a link lying in
///    the blade's plane is not cut;
///  - the result does not depend on the order in which links or triangles are tested.

#include <array>
#include <cstdint>
#include <optional>

#include "voxcut/core/BladePose.h"
#include "voxcut/core/Predicates.h"
#include "voxcut/core/Types.h"

namespace voxcut {

/// The surface swept by the blade from one pose to the next.
///
/// Corners in order a0, b0, b1, a1 (start pose a, b; end pose b, a). The bilinear patch is
/// replaced by the triangles (a0, b0, b1) and (a0, b1, a1), which share the diagonal a0-b1.
/// Build it with makeSweep: the derived members (normals, bounds, planes, onPlaneSide) must
/// match the corners and ids.
struct BladeSweep {
  /// Corner indices of the two triangles.
  static constexpr std::array<std::array<int, 3>, 2> kTriangles{{{0, 1, 2}, {0, 2, 3}}};

  std::array<Vec3d, 4> corners;               ///< a0, b0, b1, a1 (metres)
  std::array<std::uint64_t, 4> ids{};         ///< symbolic ids of the corners (see file comment)
  std::array<Vec3d, 2> normals;               ///< unit normals of the triangles (see makeSweep)
  std::array<Eigen::AlignedBox3d, 2> bounds;  ///< exact axis-aligned boxes of the triangles
  std::array<OrientPlane, 2> planes;          ///< the triangles' planes, prepared for orient3d
  /// Side (+1/-1) on which a voxel lying exactly on a triangle's plane counts (the same for
  /// every such voxel, see the tie-breaking rule); 0 for a degenerate triangle.
  std::array<int, 2> onPlaneSide{};
  /// Whether the two triangles lie exactly in one plane, on either side of their shared
  /// diagonal (a blade moving within its own plane, when rounding keeps the corners coplanar):
  /// a segment whose ends lie strictly on either side of that plane crosses at most one of
  /// them, which intersectSegment decides with fewer tests (the same decisions).
  bool flat = false;
  std::uint64_t frame = 0;  ///< frame index of the start pose
};

/// Builds the sweep of frame `frame` from pose `from` (time t_frame) to pose `to`.
/// Corner ids: a0 = 2 frame, b0 = 2 frame + 1, a1 = 2 frame + 2, b1 = 2 frame + 3; pass the
/// same pose object (bit-identical) as `to` of frame k and `from` of frame k+1 so the sweeps
/// tile without gaps. frame must be below 2^62 (checked).
/// Normal of triangle (p, q, r): (q - p) x (r - p) normalised; for a planar sweep both equal
/// (b - a) x (motion) normalised. A degenerate triangle (zero area) takes the other
/// triangle's normal; if both are degenerate, a unit vector perpendicular to the blade.
[[nodiscard]] BladeSweep makeSweep(const BladePose& from, const BladePose& to, std::uint64_t frame);

/// As makeSweep, with the corners' symbolic ids given (order a0, b0, b1, a1) instead of
/// derived from a frame index. For a strip of sweeps that share corners (a blade edge sampled
/// into a polyline), give the same point the same id in every sweep and distinct points
/// distinct ids; the ids of one sweep must be distinct. `frame` is stored as is. Every corner
/// must lie within kMaxKernelCoordinate of core/CoordinateRange.h (asserted).
[[nodiscard]] BladeSweep makeSweep(const BladePose& from, const BladePose& to,
                                   const std::array<std::uint64_t, 4>& ids, std::uint64_t frame);

/// Where a segment crosses a sweep.
struct SweepHit {
  double t = 0;                  ///< crossing parameter along p0 -> p1, in [1e-6, 1 - 1e-6]
  Vec3d normal = Vec3d::Zero();  ///< unit normal of the crossed triangle (BladeSweep::normals)
  int triangle = 0;              ///< 0 or 1, index into BladeSweep::kTriangles
};

/// Whether the segment p0 -> p1 (metres) crosses triangle `triangle` (0 or 1) of the sweep.
/// The decision is exact under the file's tie-breaking rule: the ends lie on different sides
/// of the triangle's plane and the three orientations orient3d(p0, p1, x, y) over the
/// triangle's edges (x, y) agree. id0 and id1 are the symbolic ids of p0 and p1 (voxel
/// indices; they must differ). Only after the decision is t computed in floating point, then
/// clamped to [1e-6, 1 - 1e-6].
[[nodiscard]] std::optional<SweepHit> intersectTriangle(const BladeSweep& sweep, int triangle,
                                                        const Vec3d& p0, const Vec3d& p1,
                                                        std::uint64_t id0 = 0,
                                                        std::uint64_t id1 = 1);

/// Whether the segment p0 -> p1 (a link between two deformed voxel positions, metres)
/// crosses the sweep; if it crosses both triangles (a twisted patch), the hit with the
/// smaller t (ties: triangle 0). Pass the voxel indices as id0 and id1 so that links sharing
/// a voxel break ties consistently; the defaults only suit isolated segments.
[[nodiscard]] std::optional<SweepHit> intersectSegment(const BladeSweep& sweep, const Vec3d& p0,
                                                       const Vec3d& p1, std::uint64_t id0 = 0,
                                                       std::uint64_t id1 = 1);

/// An oriented box: the points centre + axes * s with |s_i| <= halfExtents_i.
struct Obb {
  Vec3d centre = Vec3d::Zero();                        ///< metres
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  ///< orthonormal columns
  Vec3d halfExtents = Vec3d::Zero();                   ///< metres, along each column of axes
};

/// An oriented box that holds the whole sweep, enlarged by `margin` (metres, >= 0) on every
/// side. Axes: the blade direction, the motion direction orthogonalised against it, and
/// their cross product; when the blade has zero length or moves along itself or not at all,
/// missing axes are completed to an orthonormal frame. The extents come from the corners
/// (the sweep lies in their convex hull) plus a small rounding allowance.
[[nodiscard]] Obb sweepObb(const BladeSweep& sweep, double margin);

/// Whether the box and the axis-aligned box overlap (touching counts). Separating axis test
/// on all 15 axes, with a small allowance for rounding so that a true overlap is never
/// missed (it may report boxes a rounding error apart as overlapping). An empty box
/// overlaps nothing.
[[nodiscard]] bool overlaps(const Obb& obb, const Eigen::AlignedBox3d& box);

/// Whether p lies in the box (boundary included, up to rounding).
[[nodiscard]] bool contains(const Obb& obb, const Vec3d& p);

}  // namespace voxcut
