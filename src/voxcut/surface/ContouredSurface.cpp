#include "voxcut/surface/ContouredSurface.h"

#include <algorithm>

#include "voxcut/core/Parallel.h"
#include "voxcut/surface/VertexNormals.h"

namespace voxcut {
namespace {

// Whether the cell with min corner m lies inside a grid of dims d (all 8 corners inside).
bool cellInside(const Index3& d, const Index3& m) {
  for (int a = 0; a < 3; ++a)
    if (m[a] < 0 || m[a] + 1 >= d[a]) return false;
  return true;
}

// Link id of edge e of the cell with min corner voxel `cell`.
std::uint64_t edgeLink(const VoxelGrid& grid, std::uint64_t cell, int e) {
  const int lo = edgeCorner(e, 0);
  const std::size_t v = static_cast<std::size_t>(cell) + cornerBit(lo, 0) * grid.stride(0) +
                        cornerBit(lo, 1) * grid.stride(1) + cornerBit(lo, 2) * grid.stride(2);
  return VoxelGrid::linkId(v, e / 4);
}

std::uint64_t faceKey(std::uint64_t cell, int a) {
  return cell * 3 + static_cast<std::uint64_t>(a);
}

bool samePoint(const Vec3d& p, const Vec3d& q) {
  return p[0] == q[0] && p[1] == q[1] && p[2] == q[2];
}

template <class T>
void sortUnique(std::vector<T>& v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

// Whether a face's segments can need split vertices (two or more segments).
bool multiSegment(const FaceSegments& fs) {
  return fs.count >= 2;
}

// Whether two face segment lists are equal.
bool sameSegments(const FaceSegments& x, const FaceSegments& y) {
  return x.count == y.count &&
         std::equal(x.slots.begin(), x.slots.begin() + x.count, y.slots.begin());
}

// Solved cells of one z slice of cells (build).
struct SliceCells {
  std::vector<std::uint64_t> cell;
  std::vector<std::array<std::int8_t, 24>> patch;
  std::vector<std::uint8_t> count;
  std::vector<std::array<FaceSegments, 6>> segments;
  std::vector<std::uint8_t> ringFaces;  // bit f: the ring rule read the cell across face f
  std::vector<Vec3d> positions;         // per vertex, in cell order then patch order
  std::vector<std::uint64_t> voxel;
};

// Cells whose occupancy, connectivity or Hermite data changed with `changedLinks` (the cells
// around each link), sorted and unique; their face neighbours read their components.
std::vector<std::uint64_t> directCells(const VoxelGrid& grid,
                                       const std::vector<std::uint64_t>& changedLinks,
                                       const Index3& d) {
  std::vector<std::uint64_t> direct;
  direct.reserve(4 * changedLinks.size());
  for (const std::uint64_t id : changedLinks) {
    const std::size_t v = static_cast<std::size_t>(id / 3);
    const int a = static_cast<int>(id % 3);
    VOXCUT_ASSERT(v < grid.voxelCount() && grid.hasLink(v, a), "changed link outside the grid");
    const Index3 c = grid.coord(v);
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    for (int k = 0; k < 4; ++k) {
      Index3 m = c;
      m[u] -= (k == 0 || k == 3) ? 1 : 0;
      m[w] -= (k < 2) ? 1 : 0;
      if (cellInside(d, m)) direct.push_back(grid.index(m));
    }
  }
  sortUnique(direct);
  return direct;
}

}  // namespace

ContouredSurface ContouredSurface::build(const VoxelGrid& grid, const DualContourParams& params) {
  ContouredSurface s;
  s.dims_ = grid.dims();
  s.qefThreshold_ = params.qefThreshold;
  const Index3 d = grid.dims();
  if (d.x < 2 || d.y < 2 || d.z < 2) return s;

  // Solve every cell that holds surface, one z slice of cells per task.
  std::vector<SliceCells> slices(static_cast<std::size_t>(d.z - 1));
  parallelFor(
      0, slices.size(), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z) {
          SliceCells& out = slices[z];
          for (int y = 0; y + 1 < d.y; ++y)
            for (int x = 0; x + 1 < d.x; ++x) {
              const Index3 m{x, y, static_cast<int>(z)};
              if (!gatherDualCell(grid, m).hasSurface()) continue;
              std::array<FaceSegments, 6> seg;
              std::uint8_t ring = 0;
              const DualCellVertices cv =
                  dualCellVertices(grid, m, params.qefThreshold, &seg, &ring);
              out.cell.push_back(grid.index(m));
              out.patch.push_back(cv.patch);
              out.count.push_back(static_cast<std::uint8_t>(cv.count));
              out.segments.push_back(seg);
              out.ringFaces.push_back(ring);
              out.positions.insert(out.positions.end(), cv.position.begin(),
                                   cv.position.begin() + cv.count);
              out.voxel.insert(out.voxel.end(), cv.voxel.begin(), cv.voxel.begin() + cv.count);
            }
        }
      },
      params.threaded);

  // Records in slice order, then split vertices, then the sheets of every surface link (each
  // found once, as edge 4a of the cell whose min corner is the link's low voxel).
  SurfaceDelta ignored;
  std::size_t cells = 0, vertices = 0;
  for (const SliceCells& sc : slices) {
    cells += sc.cell.size();
    vertices += sc.positions.size();
  }
  // Headroom for cuts, so that the first updates do not regrow the tables.
  s.cells_.reserve(cells + cells / 2);
  s.sheets_.reserve(3 * vertices);
  s.positions_.reserve(2 * vertices);
  s.voxel_.reserve(2 * vertices);
  s.alive_.reserve(2 * vertices);
  s.triangles_.reserve(4 * vertices);
  s.tags_.reserve(4 * vertices);
  for (const SliceCells& sc : slices)
    for (std::size_t i = 0, first = 0; i < sc.cell.size(); first += sc.count[i], ++i) {
      DualCellVertices cv;
      cv.patch = sc.patch[i];
      cv.count = sc.count[i];
      std::copy_n(sc.positions.begin() + static_cast<std::ptrdiff_t>(first), cv.count,
                  cv.position.begin());
      std::copy_n(sc.voxel.begin() + static_cast<std::ptrdiff_t>(first), cv.count,
                  cv.voxel.begin());
      s.applyCell(sc.cell[i], cv, sc.segments[i], sc.ringFaces[i], ignored);
    }
  for (const SliceCells& sc : slices)
    for (std::size_t i = 0; i < sc.cell.size(); ++i)
      for (int a = 0; a < 3; ++a)
        if (multiSegment(sc.segments[i][2 * a + 1])) s.refreshFace(grid, sc.cell[i], a, ignored);
  for (const SliceCells& sc : slices)
    for (std::size_t i = 0; i < sc.cell.size(); ++i)
      for (int a = 0; a < 3; ++a)
        if (sc.patch[i][8 * a] >= 0 || sc.patch[i][8 * a + 1] >= 0)
          s.refreshLink(grid, sc.cell[i], a, ignored);
  return s;
}

// What update() re-solved: the cells whose vertices or patches changed, the links whose
// sheets must be rebuilt, and the seal checks of the solves.
struct ContouredSurface::UpdateWork {
  // A cell around a cut link (both sides occupied) of a re-solved cell, with whether the link
  // is sealed now: the 4 cells around a link decide that together, so a cell whose own links
  // did not change loses or regains a sealed link's patch when a cell across the link changed.
  struct SealCheck {
    std::uint64_t cell;
    std::int8_t slot;
    bool sealed;
    bool operator<(const SealCheck& o) const { return cell < o.cell; }
  };
  std::vector<std::uint64_t> changedCells, links;
  std::vector<SealCheck> sealChecks;
};

SurfaceDelta ContouredSurface::update(const VoxelGrid& grid,
                                      const std::vector<std::uint64_t>& changedLinks) {
  VOXCUT_ASSERT(grid.dims() == dims_,
                "ContouredSurface::update: grid dimensions differ from build");
  SurfaceDelta delta;
  const std::vector<std::uint64_t> direct = directCells(grid, changedLinks, dims_);
  const std::vector<std::uint64_t> readers = ringReaders(grid, direct);
  // Solve them again; keep the cells whose vertices or patches changed.
  UpdateWork work;
  for (const std::uint64_t cell : direct) resolveCell(grid, cell, work, delta);
  const std::vector<std::uint64_t> solvedReaders =
      resolveReaders(grid, direct, readers, work, delta);
  for (const std::uint64_t cell : staleCells(work, direct, solvedReaders))
    resolveCell(grid, cell, work, delta);
  refreshChangedFaces(grid, work, delta);
  // Sheets of the links whose cells or faces changed.
  sortUnique(work.links);
  for (const std::uint64_t link : work.links)
    refreshLink(grid, link / 3, static_cast<int>(link % 3), delta);
  finish(delta);
  return delta;
}

std::vector<std::uint64_t> ContouredSurface::ringReaders(
    const VoxelGrid& grid, const std::vector<std::uint64_t>& direct) const {
  // Only their patches can change besides those of `direct` (their vertices follow their
  // patches).
  const Index3 d = dims_;
  std::vector<std::uint64_t> readers;
  for (const std::uint64_t cell : direct) {
    const Index3 m = grid.coord(static_cast<std::size_t>(cell));
    for (int f = 0; f < 6; ++f) {
      const int a = f / 2;
      if ((f & 1) ? m[a] + 2 >= d[a] : m[a] < 1) continue;
      const std::uint64_t across = (f & 1) ? cell + grid.stride(a) : cell - grid.stride(a);
      const CellRecord* rec = cells_.find(across);
      if (rec && ((rec->ringFaces >> (f ^ 1)) & 1)) readers.push_back(across);
    }
  }
  sortUnique(readers);
  return readers;
}

void ContouredSurface::resolveCell(const VoxelGrid& grid, std::uint64_t cell, UpdateWork& work,
                                   SurfaceDelta& delta) {
  const Index3 m = grid.coord(static_cast<std::size_t>(cell));
  std::array<FaceSegments, 6> seg;
  std::uint8_t ring = 0;
  const DualCellVertices cv = dualCellVertices(grid, m, qefThreshold_, &seg, &ring);
  ++delta.solvedCells;
  const DualCell dc = gatherDualCell(grid, m);
  for (int e = 0; e < 12; ++e) {
    if (((dc.connected >> e) & 1) || !((dc.occupied >> edgeCorner(e, 0)) & 1) ||
        !((dc.occupied >> edgeCorner(e, 1)) & 1))
      continue;
    const std::uint64_t link = edgeLink(grid, cell, e);
    std::array<std::size_t, 4> around;
    std::array<int, 4> edges;
    cellsAroundLink(grid, static_cast<std::size_t>(link / 3), static_cast<int>(link % 3), around,
                    edges);
    for (int k = 0; k < 4; ++k)
      if (around[k] != cell)
        work.sealChecks.push_back(
            {around[k], static_cast<std::int8_t>(2 * edges[k]), cv.patch[2 * e] < 0});
  }
  const int edges = applyCell(cell, cv, seg, ring, delta);
  if (edges < 0) return;
  work.changedCells.push_back(cell);
  for (int e = 0; e < 12; ++e)
    if ((edges >> e) & 1) work.links.push_back(edgeLink(grid, cell, e));
}

std::vector<std::uint64_t> ContouredSurface::resolveReaders(
    const VoxelGrid& grid, const std::vector<std::uint64_t>& direct,
    const std::vector<std::uint64_t>& readers, UpdateWork& work, SurfaceDelta& delta) {
  std::vector<std::uint64_t> solvedReaders;
  for (const std::uint64_t cell : readers) {
    if (std::binary_search(direct.begin(), direct.end(), cell)) continue;
    const Index3 m = grid.coord(static_cast<std::size_t>(cell));
    std::array<std::int8_t, 24> patch;
    const int n = dualCellPatches(gatherDualCell(grid, m), patch, gridNeighbour(grid, m));
    (void)dropSealedPatches(grid, m, patch, n);
    if (cells_.find(cell)->patch != patch) {
      resolveCell(grid, cell, work, delta);
      solvedReaders.push_back(cell);
    }
  }
  std::sort(solvedReaders.begin(), solvedReaders.end());
  return solvedReaders;
}

std::vector<std::uint64_t> ContouredSurface::staleCells(
    UpdateWork& work, const std::vector<std::uint64_t>& direct,
    const std::vector<std::uint64_t>& solvedReaders) const {
  // Their patch of a link dropped (-1) exactly when it is not sealed, or no record at all
  // (every patch sealed) while it is not. The checks their own solves add need no answer: a
  // link of theirs whose 4 cells hold no re-solved cell kept its state.
  std::vector<UpdateWork::SealCheck>& sealChecks = work.sealChecks;
  std::sort(sealChecks.begin(), sealChecks.end());
  std::vector<std::uint64_t> stale;
  for (std::size_t i = 0; i < sealChecks.size();) {
    const std::uint64_t cell = sealChecks[i].cell;
    const CellRecord* rec = cells_.find(cell);
    bool differs = false;
    for (; i < sealChecks.size() && sealChecks[i].cell == cell; ++i)
      differs = differs || (rec ? (rec->patch[sealChecks[i].slot] < 0) != sealChecks[i].sealed
                                : !sealChecks[i].sealed);
    if (differs && !std::binary_search(direct.begin(), direct.end(), cell) &&
        !std::binary_search(solvedReaders.begin(), solvedReaders.end(), cell))
      stale.push_back(cell);
  }
  return stale;
}

void ContouredSurface::refreshChangedFaces(const VoxelGrid& grid, UpdateWork& work,
                                           SurfaceDelta& delta) {
  // Only faces that have or had split vertices.
  const Index3 d = dims_;
  std::vector<std::uint64_t> faces;
  for (const std::uint64_t cell : work.changedCells) {
    const Index3 m = grid.coord(static_cast<std::size_t>(cell));
    for (int a = 0; a < 3; ++a) {
      if (m[a] + 2 < d[a]) faces.push_back(faceKey(cell, a));
      if (m[a] >= 1) faces.push_back(faceKey(cell - grid.stride(a), a));
    }
  }
  sortUnique(faces);
  for (const std::uint64_t key : faces) {
    const std::uint64_t cell = key / 3;
    const int a = static_cast<int>(key % 3);
    const CellRecord* lower = cells_.find(cell);
    const bool candidate = lower
                               ? multiSegment(lower->segments[a]) || ((lower->splitFaces >> a) & 1)
                               : faceSplits_.find(key) != nullptr;
    if (!candidate || !refreshFace(grid, cell, a, delta)) continue;
    for (int e = 0; e < 12; ++e)  // the 4 edges on the cell's +a face
      if (e / 4 != a && cornerBit(edgeCorner(e, 0), a) == 1)
        work.links.push_back(edgeLink(grid, cell, e));
  }
}

int ContouredSurface::applyCell(std::uint64_t cell, const DualCellVertices& cv,
                                const std::array<FaceSegments, 6>& segments, std::uint8_t ringFaces,
                                SurfaceDelta& delta) {
  // Edges with an incidence in a patch array.
  auto incidentEdges = [](const std::array<std::int8_t, 24>& patch) {
    int edges = 0;
    for (int e = 0; e < 12; ++e)
      if (patch[2 * e] >= 0 || patch[2 * e + 1] >= 0) edges |= 1 << e;
    return edges;
  };
  CellRecord* old = cells_.find(cell);
  if (cv.count == 0) {
    if (!old) return -1;
    const int edges = incidentEdges(old->patch);
    for (int q = 0; q < old->count; ++q) dropVertex(old->vertex[q], delta);
    cells_.erase(cell);
    return edges;
  }
  CellRecord rec;
  rec.patch = cv.patch;
  rec.count = static_cast<std::int8_t>(cv.count);
  for (int a = 0; a < 3; ++a) rec.segments[a] = segments[2 * a + 1];
  rec.ringFaces = ringFaces;
  std::array<bool, 12> matched{};
  if (old) rec.splitFaces = old->splitFaces;
  for (int p = 0; p < cv.count; ++p) {
    std::int32_t id = -1;
    for (int q = 0; old && q < old->count && id < 0; ++q) {
      const std::int32_t o = old->vertex[q];
      if (!matched[q] && samePoint(positions_[static_cast<std::size_t>(o)], cv.position[p]) &&
          voxel_[static_cast<std::size_t>(o)] == cv.voxel[p]) {
        matched[q] = true;
        id = o;
      }
    }
    rec.vertex[p] = id >= 0 ? id : newVertex(cv.position[p], cv.voxel[p], delta);
  }
  int edges = incidentEdges(rec.patch);
  if (old) {
    for (int q = 0; q < old->count; ++q)
      if (!matched[q]) dropVertex(old->vertex[q], delta);
    const bool changed = old->count != rec.count || old->patch != rec.patch ||
                         old->vertex != rec.vertex ||
                         !sameSegments(old->segments[0], rec.segments[0]) ||
                         !sameSegments(old->segments[1], rec.segments[1]) ||
                         !sameSegments(old->segments[2], rec.segments[2]);
    edges = changed ? edges | incidentEdges(old->patch) : -1;
    *old = rec;
  } else {
    cells_[cell] = rec;
  }
  return edges;
}

bool ContouredSurface::refreshFace(const VoxelGrid& grid, std::uint64_t cell, int a,
                                   SurfaceDelta& delta) {
  const std::uint64_t key = faceKey(cell, a);
  FaceSplits next;
  CellRecord* lower = cells_.find(cell);
  const CellRecord* upper = cells_.find(cell + grid.stride(a));
  const FaceSplits* old = faceSplits_.find(key);
  if (lower && upper && multiSegment(lower->segments[a])) {
    std::array<DoubledSegment, 4> doubled;
    const int n = doubledSegments(lower->segments[a], a, lower->patch, upper->patch, doubled);
    VOXCUT_ASSERT(n <= 3, "a face has at most 3 split vertices");
    next.count = n;
    std::array<bool, 3> matched{};
    for (int i = 0; i < n; ++i) {
      next.slots[i] = doubled[i].slots;
      next.vertex[i] = -1;
      const std::int32_t v1 = lower->vertex[doubled[i].lowerPatch];
      const std::int32_t v2 = upper->vertex[doubled[i].upperPatch];
      const Vec3d p = 0.5 * (positions_[static_cast<std::size_t>(v1)] +
                             positions_[static_cast<std::size_t>(v2)]);
      const std::uint64_t voxel = voxel_[static_cast<std::size_t>(v1)];
      for (int q = 0; old && q < old->count; ++q) {
        const std::int32_t o = old->vertex[q];
        if (!matched[q] && old->slots[q] == next.slots[i] &&
            samePoint(positions_[static_cast<std::size_t>(o)], p) &&
            voxel_[static_cast<std::size_t>(o)] == voxel) {
          matched[q] = true;
          next.vertex[i] = o;
          break;
        }
      }
      if (next.vertex[i] < 0) next.vertex[i] = newVertex(p, voxel, delta);
    }
  }
  bool changed = next.count > 0;
  if (old) {
    for (int q = 0; q < old->count; ++q)
      if (std::find(next.vertex.begin(), next.vertex.begin() + next.count, old->vertex[q]) ==
          next.vertex.begin() + next.count)
        dropVertex(old->vertex[q], delta);
    changed =
        old->count != next.count ||
        !std::equal(old->slots.begin(), old->slots.begin() + old->count, next.slots.begin()) ||
        !std::equal(old->vertex.begin(), old->vertex.begin() + old->count, next.vertex.begin());
  }
  if (lower)
    lower->splitFaces = static_cast<std::uint8_t>(next.count > 0 ? lower->splitFaces | (1u << a)
                                                                 : lower->splitFaces & ~(1u << a));
  if (next.count > 0)
    faceSplits_[key] = next;
  else if (old)
    faceSplits_.erase(key);
  return changed;
}

void ContouredSurface::refreshLink(const VoxelGrid& grid, std::uint64_t v, int a,
                                   SurfaceDelta& delta) {
  const auto vi = static_cast<std::size_t>(v);
  const bool open = !grid.connected(vi, a);
  LinkRing ring;
  ring.sheet = {open && grid.occupied(vi), open && grid.occupied(vi + grid.stride(a))};
  std::array<std::size_t, 4> cells{};
  std::array<int, 4> edges{};
  if (ring.sheet[0] || ring.sheet[1]) {
    const Index3 c = grid.coord(vi);
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    VOXCUT_ASSERT(c[u] >= 1 && c[w] >= 1 && c[u] + 1 < dims_[u] && c[w] + 1 < dims_[w],
                  "material in the padding layer");
    cellsAroundLink(grid, vi, a, cells, edges);
  }
  if (ring.sheet[0] && ring.sheet[1]) {
    // A sealed link: its patches have no vertices (its cells may have none at all), and it
    // has no sheets.
    const CellRecord* first = cells_.find(cells[0]);
    if (!first || first->patch[2 * edges[0]] < 0) ring.sheet = {false, false};
  }
  if (ring.sheet[0] || ring.sheet[1]) {
    std::array<const CellRecord*, 4> rec;
    for (int k = 0; k < 4; ++k) {
      rec[k] = cells_.find(cells[k]);
      VOXCUT_ASSERT(rec[k] != nullptr, "a surface link's cell has no vertices");
    }
    for (int side = 0; side < 2; ++side) {
      ring.split[side].fill(-1);
      if (!ring.sheet[side]) continue;
      for (int k = 0; k < 4; ++k) {
        const int p = rec[k]->patch[2 * edges[k] + side];
        VOXCUT_ASSERT(p >= 0, "a surface link's incidence has no patch");
        ring.vertex[side][k] = rec[k]->vertex[p];
      }
      for (int k = 0; k < 4; ++k) {
        const LinkFace f = linkFace(a, k);
        if (!((rec[f.lower]->splitFaces >> f.axis) & 1)) continue;
        const FaceSplits* fs = faceSplits_.find(faceKey(cells[f.lower], f.axis));
        VOXCUT_ASSERT(fs != nullptr, "a face marked split has no split vertices");
        const int slot = 2 * edges[f.lower] + side;
        for (int i = 0; i < fs->count; ++i)
          if (fs->slots[i][0] == slot || fs->slots[i][1] == slot)
            ring.split[side][k] = fs->vertex[i];
      }
    }
  }
  std::array<LinkSheet, 2> sheets;
  triangulateLink(ring, positions_, sheets);
  for (int side = 0; side < 2; ++side) {
    const std::uint64_t key = VoxelGrid::linkId(vi, a) * 2 + static_cast<std::uint64_t>(side);
    const SheetRecord* old = sheets_.find(key);
    if (!ring.sheet[side]) {
      if (old) {
        dropSheet(*old, delta);
        sheets_.erase(key);
      }
      continue;
    }
    const LinkSheet& sh = sheets[side];
    // What the sheet's triangles show: the material of the voxel on their side, and whether
    // the link was cut (material on both sides) rather than a boundary of the material.
    const std::size_t own = side == 0 ? vi : vi + grid.stride(a);
    const TriangleTag tag{grid.material(own),
                          static_cast<std::uint8_t>(ring.sheet[0] && ring.sheet[1] ? 1 : 0)};
    if (old) {
      bool same = true;
      if (sh.polygonSize > 0) {
        same = old->centre >= 0 && old->count == sh.polygonSize;
        for (int i = 0; same && i < sh.polygonSize; ++i)
          same = triangles_[static_cast<std::size_t>(old->triangle[i])][0] == sh.polygon[i];
      } else {
        same = old->centre < 0 && old->count == sh.triangleCount;
        for (int i = 0; same && i < sh.triangleCount; ++i)
          same = triangles_[static_cast<std::size_t>(old->triangle[i])] == sh.triangles[i];
      }
      if (same) {
        for (int i = 0; i < old->count; ++i)
          tags_[static_cast<std::size_t>(old->triangle[i])] = tag;
        continue;
      }
      dropSheet(*old, delta);
    }
    SheetRecord rec;
    if (sh.polygonSize > 0) {
      // A polygon with split edges, fanned around its own centre.
      rec.centre = newVertex(polygonCentre(sh, positions_),
                             voxel_[static_cast<std::size_t>(sh.polygon[0])], delta);
      rec.count = static_cast<std::int8_t>(sh.polygonSize);
      for (int i = 0; i < sh.polygonSize; ++i)
        rec.triangle[i] =
            newTriangle({sh.polygon[i], sh.polygon[(i + 1) % sh.polygonSize], rec.centre}, delta);
    } else {
      rec.count = static_cast<std::int8_t>(sh.triangleCount);
      for (int i = 0; i < sh.triangleCount; ++i)
        rec.triangle[i] = newTriangle(sh.triangles[i], delta);
    }
    for (int i = 0; i < rec.count; ++i) tags_[static_cast<std::size_t>(rec.triangle[i])] = tag;
    sheets_[key] = rec;
  }
}

std::int32_t ContouredSurface::newVertex(const Vec3d& position, std::uint64_t voxel,
                                         SurfaceDelta& delta) {
  std::int32_t id;
  if (!freeVertices_.empty()) {
    id = freeVertices_.back();
    freeVertices_.pop_back();
    positions_[static_cast<std::size_t>(id)] = position;
    voxel_[static_cast<std::size_t>(id)] = voxel;
    alive_[static_cast<std::size_t>(id)] = 1;
  } else {
    id = static_cast<std::int32_t>(positions_.size());
    positions_.push_back(position);
    voxel_.push_back(voxel);
    alive_.push_back(1);
  }
  ++vertexCount_;
  delta.addedVertices.push_back(id);
  return id;
}

void ContouredSurface::dropVertex(std::int32_t v, SurfaceDelta& delta) {
  VOXCUT_ASSERT(alive(v), "dropping a dead vertex");
  alive_[static_cast<std::size_t>(v)] = 0;
  --vertexCount_;
  delta.removedVertices.push_back(v);
}

std::int32_t ContouredSurface::newTriangle(const std::array<int, 3>& t, SurfaceDelta& delta) {
  std::int32_t id;
  if (!freeTriangles_.empty()) {
    id = freeTriangles_.back();
    freeTriangles_.pop_back();
    triangles_[static_cast<std::size_t>(id)] = t;
  } else {
    id = static_cast<std::int32_t>(triangles_.size());
    triangles_.push_back(t);
    tags_.emplace_back();
  }
  ++triangleCount_;
  delta.addedTriangles.push_back(id);
  return id;
}

void ContouredSurface::dropTriangle(std::int32_t t, SurfaceDelta& delta) {
  auto& tri = triangles_[static_cast<std::size_t>(t)];
  VOXCUT_ASSERT(tri[0] >= 0, "dropping a dead triangle");
  tri = {-1, -1, -1};
  --triangleCount_;
  delta.removedTriangles.push_back(t);
}

void ContouredSurface::dropSheet(const SheetRecord& sheet, SurfaceDelta& delta) {
  for (int i = 0; i < sheet.count; ++i) dropTriangle(sheet.triangle[i], delta);
  if (sheet.centre >= 0) dropVertex(sheet.centre, delta);
}

void ContouredSurface::finish(SurfaceDelta& delta) {
  for (auto* list : {&delta.removedVertices, &delta.addedVertices, &delta.removedTriangles,
                     &delta.addedTriangles})
    std::sort(list->begin(), list->end());
  // Freed ids become reusable only now, so that no id is both removed and added in one update.
  // Highest ids are pushed first and so reused last.
  freeVertices_.insert(freeVertices_.end(), delta.removedVertices.rbegin(),
                       delta.removedVertices.rend());
  freeTriangles_.insert(freeTriangles_.end(), delta.removedTriangles.rbegin(),
                        delta.removedTriangles.rend());
}

SurfaceMesh ContouredSurface::mesh() const {
  SurfaceMesh m;
  std::vector<int> index(positions_.size(), -1);
  m.positions.reserve(vertexCount_);
  m.vertexVoxel.reserve(vertexCount_);
  for (std::size_t v = 0; v < positions_.size(); ++v) {
    if (!alive_[v]) continue;
    index[v] = static_cast<int>(m.positions.size());
    m.positions.push_back(positions_[v]);
    m.vertexVoxel.push_back(voxel_[v]);
  }
  m.triangles.reserve(triangleCount_);
  m.triangleTags.reserve(triangleCount_);
  for (std::size_t i = 0; i < triangles_.size(); ++i) {
    const auto& t = triangles_[i];
    if (t[0] < 0) continue;
    m.triangles.push_back({index[t[0]], index[t[1]], index[t[2]]});
    m.triangleTags.push_back(tags_[i]);
  }
  m.normals = vertexNormals(m.positions, m.triangles);
  return m;
}

}  // namespace voxcut
