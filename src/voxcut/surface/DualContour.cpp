#include "voxcut/surface/DualContour.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <unordered_map>

#include "voxcut/core/Parallel.h"
#include "voxcut/surface/DualCell.h"

namespace voxcut {
namespace {

// Vertices of the cells of one z slice of cells.
struct SliceVertices {
  std::vector<std::size_t> cells;                 // cell index (= index of its min voxel)
  std::vector<std::array<std::int8_t, 24>> patch;  // per cell
  std::vector<Vec3d> positions;                   // per vertex, in cell order then patch order
  std::vector<std::uint64_t> voxel;               // per vertex
};

// QEF vertex of one patch, in cell-local coordinates.
Vec3d solveQef(const Eigen::Matrix3d& ata, const Vec3d& atb, const Vec3d& mass, double threshold) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(ata);
  const Vec3d ev = es.eigenvalues();
  const double cut = threshold * std::max(ev.maxCoeff(), 0.0);
  const Vec3d rhs = es.eigenvectors().transpose() * (atb - ata * mass);
  Vec3d y = Vec3d::Zero();
  for (int i = 0; i < 3; ++i)
    if (ev[i] > cut && ev[i] > 0) y[i] = rhs[i] / ev[i];
  const Vec3d x = mass + es.eigenvectors() * y;
  constexpr double kTol = 1e-9;
  if ((x.array() < -kTol).any() || (x.array() > 1 + kTol).any()) return mass;
  return x;
}

// The cell across a face of the cell with min corner m.
NeighbourCell neighbourOf(const VoxelGrid& grid, const Index3& m) {
  return [&grid, m](int face) {
    Index3 o = m;
    const int a = face / 2;
    o[a] += (face & 1) ? 1 : -1;
    if (o[a] < 0 || o[a] + 1 >= grid.dims()[a]) return DualCell{};
    return gatherDualCell(grid, o);
  };
}

// Cells that hold vertices, numbered in slice order.
struct ContourCells {
  std::vector<std::int32_t> ordinal;  // per cell index (= its min voxel), -1 if no vertex
  std::vector<std::size_t> cell;      // per ordinal
  std::vector<std::int32_t> firstVertex;
  std::vector<std::array<std::int8_t, 24>> patches;
  std::vector<std::uint8_t> splitFaces;  // bit a: the +a face has split segments
  std::unordered_map<std::uint64_t, std::int32_t> splitVertex;  // faceSlotKey -> vertex
};

// Key of incidence `slot` of cell `cell` on the cell's +a face.
std::uint64_t faceSlotKey(std::size_t cell, int a, int slot) {
  return (static_cast<std::uint64_t>(cell) * 3 + static_cast<std::uint64_t>(a)) * 24 +
         static_cast<std::uint64_t>(slot);
}

// The slot of the same incidence seen from the cell across the +a face.
int slotAcross(int slot, int a) {
  const int e = slot / 2, ea = e / 4;
  const int bit = ((ea + 1) % 3 == a) ? 1 : 2;
  return 2 * (e & ~bit) + slot % 2;
}

// Two surface segments on one face can join the same two patches (the vertex of each cell);
// their dual edges would then coincide and carry four triangles. Every such segment but the
// first gets its own vertex, at the middle of the two, so that the edges stay apart.
void splitDoubledSegments(const VoxelGrid& grid, ContourCells& cc, SurfaceMesh& mesh, bool threaded) {
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
  parallelFor(0, chunks.size(), 1, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c)
      for (std::size_t o = c * kChunk; o < std::min(n, (c + 1) * kChunk); ++o) {
        const std::size_t cell = cc.cell[o];
        const Index3 m = grid.coord(cell);
        std::array<std::int8_t, 24> patch;
        std::array<FaceSegments, 6> seg;
        (void)dualCellPatches(gatherDualCell(grid, m), patch, neighbourOf(grid, m), &seg);
        for (int a = 0; a < 3; ++a) {
          const FaceSegments& fs = seg[2 * a + 1];
          if (fs.count < 2) continue;
          const std::int32_t other = cc.ordinal[cell + grid.stride(a)];
          for (int r = 1; r < fs.count; ++r)
            for (int q = 0; q < r; ++q) {
              const int s0 = fs.slots[r][0], t0 = fs.slots[q][0];
              if (patch[s0] != patch[t0] ||
                  cc.patches[other][slotAcross(s0, a)] != cc.patches[other][slotAcross(t0, a)])
                continue;
              const int v1 = cc.firstVertex[o] + patch[s0];
              const int v2 = cc.firstVertex[other] + cc.patches[other][slotAcross(s0, a)];
              chunks[c].push_back({{faceSlotKey(cell, a, fs.slots[r][0]), faceSlotKey(cell, a, fs.slots[r][1])},
                                   0.5 * (mesh.positions[v1] + mesh.positions[v2]),
                                   mesh.vertexVoxel[v1], o, a});
              break;
            }
        }
      }
  }, threaded);
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
  parallelFor(0, static_cast<std::size_t>(d.z), 1, [&](std::size_t z0, std::size_t z1) {
    for (std::size_t z = z0; z < z1; ++z)
      for (int y = 0; y < d.y; ++y) {
        const std::size_t row = static_cast<std::size_t>(y) + static_cast<std::size_t>(d.y) * z;
        const std::size_t v0 = grid.index(0, y, static_cast<int>(z));
        std::uint8_t any = 0;
        for (int x = 0; x < d.x; ++x) {
          const std::size_t v = v0 + static_cast<std::size_t>(x);
          const Index3 c{x, y, static_cast<int>(z)};
          std::uint8_t b = 0;
          for (int a = 0; a < 3; ++a) {
            if (c[a] + 1 >= d[a] || grid.connected(v, a)) continue;
            if (grid.occupied(v) || grid.occupied(v + grid.stride(a))) b = static_cast<std::uint8_t>(b | (1u << a));
          }
          s.bits[v] = b;
          any |= b;
        }
        s.rowAny[row] = any != 0;
      }
  }, threaded);
  return s;
}

void contourCellSlice(const VoxelGrid& grid, const SurfaceLinks& sl, int z, double threshold,
                      SliceVertices& out) {
  const Index3 d = grid.dims();
  const std::size_t sy = grid.stride(1), sz = grid.stride(2);
  const auto ny = static_cast<std::size_t>(d.y);
  for (int y = 0; y + 1 < d.y; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) + ny * static_cast<std::size_t>(z);
    if (!(sl.rowAny[row] | sl.rowAny[row + 1] | sl.rowAny[row + ny] | sl.rowAny[row + ny + 1])) continue;
    const std::uint8_t* b = sl.bits.data() + grid.index(0, y, z);
    for (int x = 0; x + 1 < d.x; ++x, ++b) {
      // The cell's 12 edges are links of its corners: all 3 of corner 0, two of each corner
      // one step away, one of each corner two steps away.
      const unsigned mask = (b[0] & 7u) | (b[1] & 6u) | (b[sy] & 5u) | (b[sz] & 3u) |
                            (b[sy + 1] & 4u) | (b[sz + 1] & 2u) | (b[sy + sz] & 1u);
      if (!mask) continue;
      const Index3 m{x, y, z};
      const DualCell cell = gatherDualCell(grid, m);
      std::array<std::int8_t, 24> patch;
      const int n = dualCellPatches(cell, patch, neighbourOf(grid, m));
      const std::size_t base = grid.index(m);
      out.cells.push_back(base);
      out.patch.push_back(patch);
      for (int p = 0; p < n; ++p) {
        Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
        Vec3d atb = Vec3d::Zero(), mass = Vec3d::Zero();
        int count = 0;
        std::uint64_t voxel = ~std::uint64_t{0};
        for (int s = 0; s < 24; ++s) {
          if (patch[s] != p) continue;
          const int e = s / 2, side = s % 2, a = e / 4;
          const int lo = edgeCorner(e, 0);
          const std::size_t vlo = base + cornerBit(lo, 0) * grid.stride(0) +
                                  cornerBit(lo, 1) * grid.stride(1) + cornerBit(lo, 2) * grid.stride(2);
          const std::size_t vside = side ? vlo + grid.stride(a) : vlo;
          voxel = std::min<std::uint64_t>(voxel, vside);
          const Hermite* h = grid.hermite().find(VoxelGrid::linkId(vlo, a));
          Vec3d point(cornerBit(lo, 0), cornerBit(lo, 1), cornerBit(lo, 2));
          Vec3d normal = Vec3d::Zero();
          normal[a] = 1.0;
          if (h) {
            point[a] += h->t;
            normal = Vec3d(h->n[0], h->n[1], h->n[2]);
          } else {
            point[a] += 0.5;  // a disconnected link without data; should not happen
          }
          if (side) normal = -normal;
          ata += normal * normal.transpose();
          atb += normal * normal.dot(point);
          mass += point;
          ++count;
        }
        mass /= count;
        const Vec3d local = solveQef(ata, atb, mass, threshold);
        out.positions.push_back(grid.origin() + grid.voxelSize() * (Vec3d(x, y, z) + local));
        out.voxel.push_back(voxel);
      }
    }
  }
}

// Whether splitting quad q (cells in order around the link) along cells 0-2 bends less than
// along 1-3: the split whose triangle normals agree better; ties go to 0-2. Symmetric in the
// quad's orientation, so both sheets of a cut link choose alike.
bool preferDiagonal02(const std::vector<Vec3d>& pos, const int q[4]) {
  const Vec3d &p0 = pos[q[0]], &p1 = pos[q[1]], &p2 = pos[q[2]], &p3 = pos[q[3]];
  auto agreement = [](const Vec3d& n0, const Vec3d& n1) {
    const double l = n0.norm() * n1.norm();
    return l > 0 ? n0.dot(n1) / l : -2.0;
  };
  const double b02 = agreement((p1 - p0).cross(p2 - p0), (p2 - p0).cross(p3 - p0));
  const double b13 = agreement((p2 - p1).cross(p3 - p1), (p3 - p1).cross(p0 - p1));
  return b02 >= b13;
}

}  // namespace

SurfaceMesh dualContour(const VoxelGrid& grid, const DualContourParams& params) {
  const Index3 d = grid.dims();
  SurfaceMesh mesh;
  if (d.x < 2 || d.y < 2 || d.z < 2) return mesh;

  const SurfaceLinks sl = findSurfaceLinks(grid, params.threaded);

  // Pass 1: vertices, one z slice of cells per task.
  std::vector<SliceVertices> slices(static_cast<std::size_t>(d.z - 1));
  parallelFor(0, slices.size(), 1, [&](std::size_t z0, std::size_t z1) {
    for (std::size_t z = z0; z < z1; ++z)
      contourCellSlice(grid, sl, static_cast<int>(z), params.qefThreshold, slices[z]);
  }, params.threaded);

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
      local += static_cast<std::size_t>(*std::max_element(s.patch[i].begin(), s.patch[i].end()) + 1);
    }
    mesh.positions.insert(mesh.positions.end(), s.positions.begin(), s.positions.end());
    mesh.vertexVoxel.insert(mesh.vertexVoxel.end(), s.voxel.begin(), s.voxel.end());
  }
  slices.clear();
  cc.splitFaces.assign(cc.cell.size(), 0);
  splitDoubledSegments(grid, cc, mesh, params.threaded);

  // Pass 2: quads of disconnected links, one z slice of voxels per task.
  std::vector<std::vector<std::array<int, 3>>> tris(static_cast<std::size_t>(d.z));
  std::vector<std::vector<std::vector<int>>> polygons(static_cast<std::size_t>(d.z));
  parallelFor(0, static_cast<std::size_t>(d.z), 1, [&](std::size_t z0, std::size_t z1) {
    for (std::size_t z = z0; z < z1; ++z)
      for (int y = 0; y < d.y; ++y) {
        if (!sl.rowAny[static_cast<std::size_t>(y) + static_cast<std::size_t>(d.y) * z]) continue;
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
            // Cells around the link, counter-clockwise about +a.
            const int off[4][2] = {{-1, -1}, {0, -1}, {0, 0}, {-1, 0}};
            int q[2][4];
            std::size_t cells[4];
            int edges[4];
            for (int k = 0; k < 4; ++k) {
              cells[k] = v;
              if (off[k][0]) cells[k] -= grid.stride(u);
              if (off[k][1]) cells[k] -= grid.stride(w);
              edges[k] = 4 * a + (-off[k][0]) + 2 * (-off[k][1]);
            }
            bool split[2] = {false, false};
            int mid[2][4] = {{-1, -1, -1, -1}, {-1, -1, -1, -1}};
            for (int side = 0; side < 2; ++side) {
              if (!occ[side]) continue;
              for (int k = 0; k < 4; ++k) {
                const std::int32_t ord = cc.ordinal[cells[k]];
                q[side][k] = cc.firstVertex[ord] + cc.patches[ord][2 * edges[k] + side];
              }
              // Face between cells k and k+1: the +u or +w face of its lower cell.
              for (int k = 0; k < 4; ++k) {
                const int lower = (k == 0 || k == 3) ? 0 : (k == 1 ? 1 : 3);
                const int faceAxis = (k % 2 == 0) ? u : w;
                const std::int32_t ord = cc.ordinal[cells[lower]];
                if (!((cc.splitFaces[ord] >> faceAxis) & 1)) continue;
                const auto it = cc.splitVertex.find(
                    faceSlotKey(cells[lower], faceAxis, 2 * edges[lower] + side));
                if (it == cc.splitVertex.end()) continue;
                mid[side][k] = it->second;
                split[side] = true;
              }
            }
            for (int side = 0; side < 2; ++side)
              if (split[side]) {
                // Rare: a polygon with split edges, fanned around its own centre later.
                std::vector<int> poly;
                for (int k = 0; k < 4; ++k) {
                  poly.push_back(q[side][k]);
                  if (mid[side][k] >= 0) poly.push_back(mid[side][k]);
                }
                if (side) std::reverse(poly.begin(), poly.end());
                polygons[z].push_back(std::move(poly));
                occ[side] = false;
              }
            // Split along the diagonal (cells 0-2 or 1-3) whose two triangles bend least.
            bool diag02[2] = {true, true};
            for (int side = 0; side < 2; ++side)
              if (occ[side]) diag02[side] = preferDiagonal02(mesh.positions, q[side]);
            // At a crack front both sheets of a cut link can share the vertices of a diagonal;
            // then the second sheet takes the other diagonal, or that edge would carry four
            // triangles.
            if (occ[0] && occ[1] && diag02[0] == diag02[1]) {
              const int i = diag02[0] ? 0 : 1;
              if (q[0][i] == q[1][i] && q[0][i + 2] == q[1][i + 2]) diag02[1] = !diag02[1];
            }
            for (int side = 0; side < 2; ++side) {
              if (!occ[side]) continue;
              int* r = q[side];
              // Counter-clockwise about +a for the low side; reversed for the high side.
              if (side) std::swap(r[1], r[3]);
              auto& out = tris[z];
              if (diag02[side]) {
                out.push_back({r[0], r[1], r[2]});
                out.push_back({r[0], r[2], r[3]});
              } else {
                out.push_back({r[0], r[1], r[3]});
                out.push_back({r[1], r[2], r[3]});
              }
            }
          }
        }
      }
  }, params.threaded);
  for (const auto& t : tris) mesh.triangles.insert(mesh.triangles.end(), t.begin(), t.end());
  for (const auto& slice : polygons)
    for (const auto& poly : slice) {
      const auto centre = static_cast<int>(mesh.positions.size());
      Vec3d p = Vec3d::Zero();
      for (int i : poly) p += mesh.positions[i];
      mesh.positions.push_back(p / static_cast<double>(poly.size()));
      mesh.vertexVoxel.push_back(mesh.vertexVoxel[poly[0]]);
      for (std::size_t i = 0; i < poly.size(); ++i)
        mesh.triangles.push_back({poly[i], poly[(i + 1) % poly.size()], centre});
    }

  // Area-weighted vertex normals.
  mesh.normals.assign(mesh.positions.size(), Vec3d::Zero());
  for (const auto& t : mesh.triangles) {
    const Vec3d n = (mesh.positions[t[1]] - mesh.positions[t[0]])
                        .cross(mesh.positions[t[2]] - mesh.positions[t[0]]);
    for (int k = 0; k < 3; ++k) mesh.normals[t[k]] += n;
  }
  for (auto& n : mesh.normals) {
    const double l = n.norm();
    if (l > 0) n /= l;
  }
  return mesh;
}

}  // namespace voxcut
