#pragma once
/// @file ContouredSurface.h
/// The dual-contoured surface of a linked voxel grid, kept up to date while it is cut
/// (docs/algorithms.md, "Local surface update").
///
/// build() contours the whole grid and gives the same surface as dualContour(); update()
/// then follows a set of links whose state or Hermite data changed by re-solving only the
/// dual cells around them and replacing only the vertices and triangles that change. Vertex
/// and triangle ids are stable: an id keeps its data until a delta lists it as removed; freed
/// ids are reused by later updates. Vertices are in the rest frame and keep their voxel, so a
/// caller embeds each one in the deforming element that holds its voxel and, after an update,
/// embeds only the added ones.
///
/// What an update re-solves: the 4 cells around each changed link (their occupancy,
/// connectivity or Hermite data changed), and those of their face neighbours whose ring rule
/// (dualCellPatches) read one of them, when their patches now differ, and the cells around a
/// cut link of a re-solved cell whose record disagrees with whether that link is now sealed
/// (isSealedLink: its 4 cells decide it together, so a cell whose own links did not change
/// can lose or regain a sealed link's patch). Split vertices are
/// re-derived on the faces of every cell whose record changed (faces with two or more surface
/// segments, or that had split vertices), and the sheets of the links with incidences in such
/// a cell (or on a face whose split vertices changed) are rebuilt. A vertex of a re-solved cell
/// keeps its id when the cell had a vertex with the same position and voxel, and a sheet keeps
/// its triangles when it comes out the same. Cost: O(changed links) work in hash maps keyed by
/// cell, face and link, no pass over the grid or the surface (docs/performance.md, "Surface").

#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/core/FlatHashMap.h"
#include "voxcut/surface/DualCell.h"
#include "voxcut/surface/DualContour.h"
#include "voxcut/surface/SurfaceMesh.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// What one ContouredSurface::update changed. Each list is sorted ascending; no id is both
/// removed and added in one update. Removed ids were alive before the update and are dead
/// after it; added ids are alive after it and were dead before (a removed id is reused only by
/// a later update).
struct SurfaceDelta {
  std::vector<std::int32_t> removedVertices;
  std::vector<std::int32_t> addedVertices;
  std::vector<std::int32_t> removedTriangles;
  std::vector<std::int32_t> addedTriangles;
  std::size_t solvedCells = 0;  ///< dual cells whose vertices were solved again (work done)
};

/// An incrementally updated dual-contoured surface. Copyable (a world's snapshot holds a
/// copy) and movable. Not thread-safe: one update at a time, and no reads
/// while an update runs; concurrent const reads are fine.
class ContouredSurface {
 public:
  ContouredSurface() = default;
  ContouredSurface(const ContouredSurface&) = default;
  ContouredSurface& operator=(const ContouredSurface&) = default;
  ContouredSurface(ContouredSurface&&) noexcept = default;
  ContouredSurface& operator=(ContouredSurface&&) noexcept = default;

  /// Contours all of `grid` (the same vertices and triangles as dualContour(grid, params), up to
  /// their order). Cells are solved in parallel when params.threaded; the result does not
  /// depend on the thread count.
  [[nodiscard]] static ContouredSurface build(const VoxelGrid& grid,
                                              const DualContourParams& params = {});

  /// Brings the surface up to date with `grid` after the links `changedLinks` (link ids
  /// 3*v + axis, in any order, repeats allowed) changed state or Hermite data; no other link and
  /// no occupancy may have changed since the last build or update (to change a voxel's
  /// material, list its 6 links). `grid` has the dimensions given to build. Afterwards the
  /// surface equals a full rebuild up to the order of vertices and triangles. Serial and
  /// deterministic; cost proportional to the number of changed links.
  SurfaceDelta update(const VoxelGrid& grid, const std::vector<std::uint64_t>& changedLinks);

  /// Number of vertex ids in use or free (ids are 0..vertexSlots()-1).
  [[nodiscard]] std::size_t vertexSlots() const { return positions_.size(); }
  /// Whether vertex id v holds a vertex of the surface.
  [[nodiscard]] bool alive(std::int32_t v) const {
    return alive_[static_cast<std::size_t>(v)] != 0;
  }
  /// Rest-frame positions (metres) by vertex id; a dead id keeps its last value.
  [[nodiscard]] const std::vector<Vec3d>& positions() const { return positions_; }
  /// Voxel whose component each vertex belongs to, by vertex id.
  [[nodiscard]] const std::vector<std::uint64_t>& vertexVoxels() const { return voxel_; }
  /// Triangles by id (vertex ids, counter-clockwise seen from outside the material); a dead id
  /// holds {-1, -1, -1}.
  [[nodiscard]] const std::vector<std::array<int, 3>>& triangles() const { return triangles_; }
  /// By triangle id: its material and whether it is on a cut (stale for a dead id).
  [[nodiscard]] const std::vector<TriangleTag>& triangleTags() const { return tags_; }
  /// Alive vertices and triangles.
  [[nodiscard]] std::size_t vertexCount() const { return vertexCount_; }
  [[nodiscard]] std::size_t triangleCount() const { return triangleCount_; }

  /// A compact copy: alive vertices in id order, alive triangles in id order, area-weighted
  /// unit normals. O(V + T).
  [[nodiscard]] SurfaceMesh mesh() const;

 private:
  // Vertices of one dual cell that holds surface.
  struct CellRecord {
    std::array<std::int8_t, 24> patch{};
    std::int8_t count = 0;
    std::uint8_t splitFaces = 0;  // bit a: the +a face has split vertices (a FaceSplits entry)
    std::uint8_t ringFaces = 0;   // bit f: the ring rule read the neighbour across face f
    std::array<std::int32_t, 12> vertex{};
    std::array<FaceSegments, 3> segments{};  // surface segments on the +a face
  };
  // Split vertices of the +a face of a cell (key cell * 3 + a).
  struct FaceSplits {
    int count = 0;
    std::array<std::array<std::int8_t, 2>, 3> slots{};
    std::array<std::int32_t, 3> vertex{};
  };
  // Triangles of one side of a link (key linkId * 2 + side); a polygon with a centre vertex
  // when the link's ring has split vertices.
  struct SheetRecord {
    std::int8_t count = 0;
    std::int32_t centre = -1;
    std::array<std::int32_t, 8> triangle{};
  };

  // Stores a solved cell, reusing the ids of unchanged vertices. Returns -1 when the record
  // did not change, else the mask of its edges with incidences before or after (whose sheets
  // must be rebuilt).
  int applyCell(std::uint64_t cell, const DualCellVertices& cv,
                const std::array<FaceSegments, 6>& segments, std::uint8_t ringFaces,
                SurfaceDelta& delta);
  // Re-derives the split vertices of the +a face of `cell`; returns whether they changed.
  bool refreshFace(const VoxelGrid& grid, std::uint64_t cell, int a, SurfaceDelta& delta);
  void refreshLink(const VoxelGrid& grid, std::uint64_t v, int a, SurfaceDelta& delta);
  std::int32_t newVertex(const Vec3d& position, std::uint64_t voxel, SurfaceDelta& delta);
  void dropVertex(std::int32_t v, SurfaceDelta& delta);
  std::int32_t newTriangle(const std::array<int, 3>& t, SurfaceDelta& delta);
  void dropTriangle(std::int32_t t, SurfaceDelta& delta);
  void dropSheet(const SheetRecord& sheet, SurfaceDelta& delta);
  void finish(SurfaceDelta& delta);

  // The steps of update() (ContouredSurface.cpp): what it re-solved and what follows.
  struct UpdateWork;
  // Face neighbours of `direct` cells whose ring rule read one of them (sorted, unique).
  [[nodiscard]] std::vector<std::uint64_t> ringReaders(
      const VoxelGrid& grid, const std::vector<std::uint64_t>& direct) const;
  // Solves `cell` again, noting its seal checks, and stores it (a changed cell and its links).
  void resolveCell(const VoxelGrid& grid, std::uint64_t cell, UpdateWork& work,
                   SurfaceDelta& delta);
  // Re-solves the ring readers whose patches differ now; returns those re-solved, sorted.
  std::vector<std::uint64_t> resolveReaders(const VoxelGrid& grid,
                                            const std::vector<std::uint64_t>& direct,
                                            const std::vector<std::uint64_t>& readers,
                                            UpdateWork& work, SurfaceDelta& delta);
  // Cells not solved yet whose record disagrees with the seal checks of the solves.
  [[nodiscard]] std::vector<std::uint64_t> staleCells(
      UpdateWork& work, const std::vector<std::uint64_t>& direct,
      const std::vector<std::uint64_t>& solvedReaders) const;
  // Refreshes the split vertices on the faces of changed cells, noting the links they touch.
  void refreshChangedFaces(const VoxelGrid& grid, UpdateWork& work, SurfaceDelta& delta);

  Index3 dims_;
  double qefThreshold_ = 0.1;
  std::vector<Vec3d> positions_;
  std::vector<std::uint64_t> voxel_;
  std::vector<std::uint8_t> alive_;
  std::vector<std::int32_t> freeVertices_;
  std::vector<std::array<int, 3>> triangles_;
  std::vector<TriangleTag> tags_;  // per triangle id
  std::vector<std::int32_t> freeTriangles_;
  std::size_t vertexCount_ = 0;
  std::size_t triangleCount_ = 0;
  FlatHashMap<CellRecord> cells_;
  FlatHashMap<FaceSplits> faceSplits_;
  FlatHashMap<SheetRecord> sheets_;
};

}  // namespace voxcut
