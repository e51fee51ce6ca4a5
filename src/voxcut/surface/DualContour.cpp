#include "voxcut/surface/DualContour.h"

#include <algorithm>
#include <unordered_map>

#include "voxcut/core/Parallel.h"
#include "voxcut/surface/DualCell.h"
#include "voxcut/surface/VertexNormals.h"

namespace voxcut {
namespace {

// Vertices of the cells of one z slice of cells.
struct SliceVertices {
  std::vector<std::size_t> cells;                  // cell index (= index of its min voxel)
  std::vector<std::array<std::int8_t, 24>> patch;  // per cell
  std::vector<Vec3d> positions;                    // per vertex, in cell order then patch order
  std::vector<std::uint64_t> voxel;                // per vertex
  std::vector<std::uint8_t> doubledFaces;          // per cell: bit a, +a face has 2+ segments
};

// Cells that hold vertices, numbered in slice order.
struct ContourCells {
  std::vector<std::int32_t> ordinal;  // per cell index (= its min voxel), -1 if no vertex
  std::vector<std::size_t> cell;      // per ordinal
  std::vector<std::int32_t> firstVertex;
  std::vector<std::array<std::int8_t, 24>> patches;
  std::vector<std::uint8_t> doubledFaces;  // bit a: the +a face has two or more segments
  std::vector<std::uint8_t> splitFaces;    // bit a: the +a face has split segments
  std::unordered_map<std::uint64_t, std::int32_t> splitVertex;  // faceSlotKey -> vertex
};

// Two surface segments on one face can join the same two patches (the vertex of each cell);
// their dual edges would then coincide and carry four triangles. Every such segment but the
// first gets its own vertex, at the middle of the two, so that the edges stay apart.
void splitDoubledSegments(const VoxelGrid& grid, ContourCells& cc, SurfaceMesh& mesh,
                          bool threaded) {
  struct Split {
    std::uint64_t key[2];
    Vec3d position;
    std::uint64_t voxel;
    std::size_t cell;
    int axis;
  };
  constexpr std::size_t kChunk = 4096;
  const std::size_t n = cc.cell.size();
  std::vector<std::vector<Split>> chunks((n + kChunk - 1) / kChunk);
  parallelFor(
      0, chunks.size(), 1,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t c = c0; c < c1; ++c)
          for (std::size_t o = c * kChunk; o < std::min(n, (c + 1) * kChunk); ++o) {
            if (!cc.doubledFaces[o]) continue;  // one segment per face at most: nothing doubles
            const std::size_t cell = cc.cell[o];
            const Index3 m = grid.coord(cell);
            std::array<std::int8_t, 24> raw;
            std::array<FaceSegments, 6> seg;
            (void)dualCellPatches(gatherDualCell(grid, m), raw, gridNeighbour(grid, m), &seg);
            // The vertices' patches (sealed links' dropped), not the raw ones.
            const std::array<std::int8_t, 24>& patch = cc.patches[o];
            for (int a = 0; a < 3; ++a) {
              const FaceSegments& fs = seg[2 * a + 1];
              if (fs.count < 2) continue;
              const std::int32_t other = cc.ordinal[cell + grid.stride(a)];
              std::array<DoubledSegment, 4> doubled;
              const int nd = doubledSegments(fs, a, patch, cc.patches[other], doubled);
              for (int i = 0; i < nd; ++i) {
                const int v1 = cc.firstVertex[o] + doubled[i].lowerPatch;
                const int v2 = cc.firstVertex[other] + doubled[i].upperPatch;
                chunks[c].push_back({{faceSlotKey(cell, a, doubled[i].slots[0]),
                                      faceSlotKey(cell, a, doubled[i].slots[1])},
                                     0.5 * (mesh.positions[v1] + mesh.positions[v2]),
                                     mesh.vertexVoxel[v1],
                                     o,
                                     a});
              }
            }
          }
      },
      threaded);
  for (const auto& chunk : chunks)
    for (const Split& sp : chunk) {
      const auto id = static_cast<std::int32_t>(mesh.positions.size());
      mesh.positions.push_back(sp.position);
      mesh.vertexVoxel.push_back(sp.voxel);
      cc.splitVertex[sp.key[0]] = id;
      cc.splitVertex[sp.key[1]] = id;
      cc.splitFaces[sp.cell] = static_cast<std::uint8_t>(cc.splitFaces[sp.cell] | (1u << sp.axis));
    }
}

// Per voxel, bit a: link (v, a) is disconnected with material on at least one side; and per
// voxel row (y, z), whether any of its voxels has such a link. Most cells and rows have none.
struct SurfaceLinks {
  std::vector<std::uint8_t> bits;
  std::vector<std::uint8_t> rowAny;
};

SurfaceLinks findSurfaceLinks(const VoxelGrid& grid, bool threaded) {
  const Index3 d = grid.dims();
  SurfaceLinks s;
  s.bits.assign(grid.voxelCount(), 0);
  s.rowAny.assign(static_cast<std::size_t>(d.y) * static_cast<std::size_t>(d.z), 0);
  const std::size_t sy = grid.stride(1), sz = grid.stride(2);
  parallelFor(
      0, static_cast<std::size_t>(d.z), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z)
          for (int y = 0; y < d.y; ++y) {
            const std::size_t row = static_cast<std::size_t>(y) + static_cast<std::size_t>(d.y) * z;
            const std::size_t v0 = grid.index(0, y, static_cast<int>(z));
            // A link leaves the row's voxels along +x, +y or +z: with no material in this row
            // or the rows it reaches, it has no surface link.
            const bool hasY = y + 1 < d.y, hasZ = static_cast<int>(z) + 1 < d.z;
            const auto rowEmpty = [&](std::size_t start) {
              for (std::size_t v = start; v < start + static_cast<std::size_t>(d.x); ++v)
                if (grid.occupied(v)) return false;
              return true;
            };
            if (rowEmpty(v0) && (!hasY || rowEmpty(v0 + sy)) && (!hasZ || rowEmpty(v0 + sz)))
              continue;
            std::uint8_t any = 0;
            for (int x = 0; x < d.x; ++x) {
              const std::size_t v = v0 + static_cast<std::size_t>(x);
              const bool occ = grid.occupied(v);
              unsigned b = 0;
              if (x + 1 < d.x && !grid.connected(v, 0) && (occ || grid.occupied(v + 1))) b |= 1u;
              if (hasY && !grid.connected(v, 1) && (occ || grid.occupied(v + sy))) b |= 2u;
              if (hasZ && !grid.connected(v, 2) && (occ || grid.occupied(v + sz))) b |= 4u;
              s.bits[v] = static_cast<std::uint8_t>(b);
              any = static_cast<std::uint8_t>(any | b);
            }
            s.rowAny[row] = any != 0;
          }
      },
      threaded);
  return s;
}

void contourCellSlice(const VoxelGrid& grid, const SurfaceLinks& sl, int z, double threshold,
                      SliceVertices& out) {
  const Index3 d = grid.dims();
  const std::size_t sy = grid.stride(1), sz = grid.stride(2);
  const auto ny = static_cast<std::size_t>(d.y);
  for (int y = 0; y + 1 < d.y; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) + ny * static_cast<std::size_t>(z);
    if (!(sl.rowAny[row] | sl.rowAny[row + 1] | sl.rowAny[row + ny] | sl.rowAny[row + ny + 1]))
      continue;
    const std::uint8_t* b = sl.bits.data() + grid.index(0, y, z);
    for (int x = 0; x + 1 < d.x; ++x, ++b) {
      // The cell's 12 edges are links of its corners: all 3 of corner 0, two of each corner
      // one step away, one of each corner two steps away.
      const unsigned mask = (b[0] & 7u) | (b[1] & 6u) | (b[sy] & 5u) | (b[sz] & 3u) |
                            (b[sy + 1] & 4u) | (b[sz + 1] & 2u) | (b[sy + sz] & 1u);
      if (!mask) continue;
      const Index3 m{x, y, z};
      std::array<FaceSegments, 6> seg;
      const DualCellVertices cv = dualCellVertices(grid, m, threshold, &seg);
      std::uint8_t doubled = 0;
      for (int a = 0; a < 3; ++a)
        if (seg[static_cast<std::size_t>(2 * a + 1)].count >= 2)
          doubled = static_cast<std::uint8_t>(doubled | (1u << a));
      out.doubledFaces.push_back(doubled);
      out.cells.push_back(grid.index(m));
      out.patch.push_back(cv.patch);
      out.positions.insert(out.positions.end(), cv.position.begin(),
                           cv.position.begin() + cv.count);
      out.voxel.insert(out.voxel.end(), cv.voxel.begin(), cv.voxel.begin() + cv.count);
    }
  }
}

}  // namespace

SurfaceMesh dualContour(const VoxelGrid& grid, const DualContourParams& params) {
  const Index3 d = grid.dims();
  SurfaceMesh mesh;
  if (d.x < 2 || d.y < 2 || d.z < 2) return mesh;

  const SurfaceLinks sl = findSurfaceLinks(grid, params.threaded);

  // Pass 1: vertices, one z slice of cells per task.
  std::vector<SliceVertices> slices(static_cast<std::size_t>(d.z - 1));
  parallelFor(
      0, slices.size(), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z)
          contourCellSlice(grid, sl, static_cast<int>(z), params.qefThreshold, slices[z]);
      },
      params.threaded);

  // Global numbering in slice order.
  ContourCells cc;
  cc.ordinal.assign(grid.voxelCount(), -1);
  for (const auto& s : slices) {
    std::size_t local = 0;
    for (std::size_t i = 0; i < s.cells.size(); ++i) {
      cc.ordinal[s.cells[i]] = static_cast<std::int32_t>(cc.patches.size());
      cc.cell.push_back(s.cells[i]);
      cc.firstVertex.push_back(static_cast<std::int32_t>(mesh.positions.size() + local));
      cc.patches.push_back(s.patch[i]);
      cc.doubledFaces.push_back(s.doubledFaces[i]);
      local +=
          static_cast<std::size_t>(*std::max_element(s.patch[i].begin(), s.patch[i].end()) + 1);
    }
    mesh.positions.insert(mesh.positions.end(), s.positions.begin(), s.positions.end());
    mesh.vertexVoxel.insert(mesh.vertexVoxel.end(), s.voxel.begin(), s.voxel.end());
  }
  slices.clear();
  cc.splitFaces.assign(cc.cell.size(), 0);
  splitDoubledSegments(grid, cc, mesh, params.threaded);

  // Pass 2: quads of disconnected links, one z slice of voxels per task.
  std::vector<std::vector<std::array<int, 3>>> tris(static_cast<std::size_t>(d.z));
  std::vector<std::vector<TriangleTag>> tags(static_cast<std::size_t>(d.z));
  std::vector<std::vector<LinkSheet>> polygons(static_cast<std::size_t>(d.z));
  std::vector<std::vector<TriangleTag>> polygonTags(static_cast<std::size_t>(d.z));
  parallelFor(
      0, static_cast<std::size_t>(d.z), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z)
          for (int y = 0; y < d.y; ++y) {
            if (!sl.rowAny[static_cast<std::size_t>(y) + static_cast<std::size_t>(d.y) * z])
              continue;
            for (int x = 0; x < d.x; ++x) {
              const Index3 c{x, y, static_cast<int>(z)};
              const std::size_t v = grid.index(c);
              if (!sl.bits[v]) continue;
              for (int a = 0; a < 3; ++a) {
                if (!((sl.bits[v] >> a) & 1)) continue;
                const std::size_t nb = v + grid.stride(a);
                bool occ[2] = {grid.occupied(v), grid.occupied(nb)};
                if (!occ[0] && !occ[1]) continue;
                const int u = (a + 1) % 3, w = (a + 2) % 3;
                // Material never reaches the padding layer, so the 4 cells exist.
                VOXCUT_ASSERT(c[u] >= 1 && c[w] >= 1 && c[u] + 1 < d[u] && c[w] + 1 < d[w],
                              "material in the padding layer");
                std::array<std::size_t, 4> cells;
                std::array<int, 4> edges;
                cellsAroundLink(grid, v, a, cells, edges);
                // A sealed link's patches have no vertices, and it has no sheets.
                if (occ[0] && occ[1] && cc.patches[cc.ordinal[cells[0]]][2 * edges[0]] < 0)
                  continue;
                LinkRing ring;
                for (int side = 0; side < 2; ++side) {
                  ring.sheet[side] = occ[side];
                  ring.split[side].fill(-1);
                  if (!occ[side]) continue;
                  for (int k = 0; k < 4; ++k) {
                    const std::int32_t ord = cc.ordinal[cells[k]];
                    ring.vertex[side][k] =
                        cc.firstVertex[ord] + cc.patches[ord][2 * edges[k] + side];
                  }
                  for (int k = 0; k < 4; ++k) {
                    const LinkFace f = linkFace(a, k);
                    const std::int32_t ord = cc.ordinal[cells[f.lower]];
                    if (!((cc.splitFaces[ord] >> f.axis) & 1)) continue;
                    const auto it = cc.splitVertex.find(
                        faceSlotKey(cells[f.lower], f.axis, 2 * edges[f.lower] + side));
                    if (it != cc.splitVertex.end()) ring.split[side][k] = it->second;
                  }
                }
                std::array<LinkSheet, 2> sheets;
                triangulateLink(ring, mesh.positions, sheets);
                for (int side = 0; side < 2; ++side) {
                  const LinkSheet& sh = sheets[side];
                  // A sheet shows the material on its side; a link with material on both
                  // sides is a cut.
                  const TriangleTag tag{grid.material(side ? nb : v),
                                        static_cast<std::uint8_t>(occ[0] && occ[1])};
                  if (sh.polygonSize > 0) {
                    polygons[z].push_back(sh);
                    polygonTags[z].push_back(tag);
                  }
                  for (int t = 0; t < sh.triangleCount; ++t) {
                    tris[z].push_back(sh.triangles[t]);
                    tags[z].push_back(tag);
                  }
                }
              }
            }
          }
      },
      params.threaded);
  for (const auto& t : tris) mesh.triangles.insert(mesh.triangles.end(), t.begin(), t.end());
  for (const auto& t : tags) mesh.triangleTags.insert(mesh.triangleTags.end(), t.begin(), t.end());
  for (std::size_t z = 0; z < polygons.size(); ++z)
    for (std::size_t p = 0; p < polygons[z].size(); ++p) {
      const LinkSheet& poly = polygons[z][p];
      // Rare: a polygon with split edges, fanned around its own centre.
      const auto centre = static_cast<int>(mesh.positions.size());
      mesh.positions.push_back(polygonCentre(poly, mesh.positions));
      mesh.vertexVoxel.push_back(mesh.vertexVoxel[poly.polygon[0]]);
      for (int i = 0; i < poly.polygonSize; ++i) {
        mesh.triangles.push_back(
            {poly.polygon[i], poly.polygon[(i + 1) % poly.polygonSize], centre});
        mesh.triangleTags.push_back(polygonTags[z][p]);
      }
    }

  mesh.normals = vertexNormals(mesh.positions, mesh.triangles);
  return mesh;
}

}  // namespace voxcut
