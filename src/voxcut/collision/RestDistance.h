#pragma once
/// @file RestDistance.h
/// A body's distance to its own boundary in the rest frame, near the boundary (docs/algorithms.md,
/// "Object collision"): per occupied voxel within `band` voxels of the boundary, its nearest
/// boundary feature, a point on the boundary and the outward normal there. The boundary is
/// every face of an occupied voxel whose link is not connected: the body's surface (the
/// neighbour is empty or off the grid) and both sides of every cut. The feature's point and
/// normal come from the link's Hermite data where it has some (the surface or the cut plane),
/// from the face otherwise. Distances propagate through connected links only, so the two sides
/// of a cut each see their own side of it.
///
/// A penetration depth measured with it stays right next to cuts, and is the depth below the
/// nearest boundary plane: exact for a flat boundary, an estimate around edges.
///
/// Thread-safety: const queries may run concurrently; build and update are not.

#include <cstdint>
#include <vector>

#include "voxcut/core/FlatHashMap.h"
#include "voxcut/core/Types.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

class RestDistanceField {
 public:
  /// Builds the field of `grid` out to `band` voxels (>= 1) from the boundary. O(voxels within
  /// the band + occupied voxels) time; memory O(voxels within the band).
  void build(const VoxelGrid& grid, int band);
  /// After links changed (cut, or healed): recomputes the voxels within band + 1 voxels of
  /// their ends (Chebyshev), from their own boundary faces and the kept features of the voxels
  /// just around them. The same as build() on the changed grid except where the change
  /// re-routed the paths to a voxel farther away. O(voxels of that region), which for a cut is
  /// about its area times 2 band + 3.
  void update(const VoxelGrid& grid, const std::vector<std::uint64_t>& changedLinks);

  /// The depth (m, > 0 inside) of the rest point `x`, in occupied voxel v of `grid` (the grid
  /// the field was built on), below the nearest boundary plane, and in `normal` that plane's
  /// unit outward normal. The planes tried are v's own boundary faces and the nearest features
  /// of v and of its neighbours through connected links, the smallest depth winning: near an
  /// edge or corner of the boundary the plane nearest a voxel's centre is not the one nearest
  /// every point of it. False when none is kept (v deeper than the band, or not occupied).
  bool depth(const VoxelGrid& grid, std::size_t v, const Vec3d& x, double& depth,
             Vec3d& normal) const;

  [[nodiscard]] int band() const { return band_; }
  [[nodiscard]] std::size_t size() const { return field_.size(); }

 private:
  struct Feature {
    float point[3] = {0.f, 0.f, 0.f};
    float normal[3] = {0.f, 0.f, 0.f};
    float distance = 0.f;  ///< from the voxel's centre to the point (m)
  };
  /// Features of v's own boundary faces, the nearest first. Empty when v has none.
  void ownFeatures(const VoxelGrid& grid, std::size_t v, std::vector<Feature>& out) const;
  /// Dijkstra from the seeds over connected links, writing only voxels `inRegion` accepts.
  template <class InRegion>
  void propagate(const VoxelGrid& grid, std::vector<std::pair<float, std::uint64_t>>& heap,
                 InRegion&& inRegion);

  FlatHashMap<Feature> field_;
  int band_ = 4;
};

}  // namespace voxcut
