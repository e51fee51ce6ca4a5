#include "voxcut/surface/DualContour.h"

#include <Eigen/Eigenvalues>
#include <algorithm>

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

void contourCellSlice(const VoxelGrid& grid, int z, double threshold, SliceVertices& out) {
  const Index3 d = grid.dims();
  for (int y = 0; y + 1 < d.y; ++y)
    for (int x = 0; x + 1 < d.x; ++x) {
      const Index3 m{x, y, z};
      const DualCell cell = gatherDualCell(grid, m);
      if (!cell.hasSurface()) continue;
      std::array<std::int8_t, 24> patch;
      const int n = dualCellPatches(cell, patch);
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

}  // namespace

SurfaceMesh dualContour(const VoxelGrid& grid, const DualContourParams& params) {
  const Index3 d = grid.dims();
  SurfaceMesh mesh;
  if (d.x < 2 || d.y < 2 || d.z < 2) return mesh;

  // Pass 1: vertices, one z slice of cells per task.
  std::vector<SliceVertices> slices(static_cast<std::size_t>(d.z - 1));
  parallelFor(0, slices.size(), 1, [&](std::size_t z0, std::size_t z1) {
    for (std::size_t z = z0; z < z1; ++z)
      contourCellSlice(grid, static_cast<int>(z), params.qefThreshold, slices[z]);
  }, params.threaded);

  // Global numbering in slice order.
  std::vector<std::int32_t> cellOrdinal(grid.voxelCount(), -1);
  std::vector<std::int32_t> firstVertex;
  std::vector<std::array<std::int8_t, 24>> patches;
  for (const auto& s : slices) {
    std::size_t local = 0;
    for (std::size_t i = 0; i < s.cells.size(); ++i) {
      cellOrdinal[s.cells[i]] = static_cast<std::int32_t>(patches.size());
      firstVertex.push_back(static_cast<std::int32_t>(mesh.positions.size() + local));
      patches.push_back(s.patch[i]);
      local += static_cast<std::size_t>(*std::max_element(s.patch[i].begin(), s.patch[i].end()) + 1);
    }
    mesh.positions.insert(mesh.positions.end(), s.positions.begin(), s.positions.end());
    mesh.vertexVoxel.insert(mesh.vertexVoxel.end(), s.voxel.begin(), s.voxel.end());
  }
  slices.clear();

  // Pass 2: quads of disconnected links, one z slice of voxels per task.
  std::vector<std::vector<std::array<int, 3>>> tris(static_cast<std::size_t>(d.z));
  parallelFor(0, static_cast<std::size_t>(d.z), 1, [&](std::size_t z0, std::size_t z1) {
    for (std::size_t z = z0; z < z1; ++z)
      for (int y = 0; y < d.y; ++y)
        for (int x = 0; x < d.x; ++x) {
          const Index3 c{x, y, static_cast<int>(z)};
          const std::size_t v = grid.index(c);
          for (int a = 0; a < 3; ++a) {
            if (c[a] + 1 >= d[a] || grid.connected(v, a)) continue;
            const std::size_t nb = v + grid.stride(a);
            const bool occ[2] = {grid.occupied(v), grid.occupied(nb)};
            if (!occ[0] && !occ[1]) continue;
            const int u = (a + 1) % 3, w = (a + 2) % 3;
            // Material never reaches the padding layer, so the 4 cells exist.
            VOXCUT_ASSERT(c[u] >= 1 && c[w] >= 1 && c[u] + 1 < d[u] && c[w] + 1 < d[w],
                          "material in the padding layer");
            // Cells around the link, counter-clockwise about +a.
            const int off[4][2] = {{-1, -1}, {0, -1}, {0, 0}, {-1, 0}};
            for (int side = 0; side < 2; ++side) {
              if (!occ[side]) continue;
              int q[4];
              for (int k = 0; k < 4; ++k) {
                std::size_t cell = v;
                if (off[k][0]) cell -= grid.stride(u);
                if (off[k][1]) cell -= grid.stride(w);
                const int e = 4 * a + (-off[k][0]) + 2 * (-off[k][1]);
                const std::int32_t ord = cellOrdinal[cell];
                q[k] = firstVertex[ord] + patches[ord][2 * e + side];
              }
              if (side) std::swap(q[1], q[3]);
              const Vec3d &p0 = mesh.positions[q[0]], &p1 = mesh.positions[q[1]],
                          &p2 = mesh.positions[q[2]], &p3 = mesh.positions[q[3]];
              // Diagonal 0-2 or 1-3: keep the split whose triangles bend least.
              auto bend = [](const Vec3d& n0, const Vec3d& n1) {
                const double l = n0.norm() * n1.norm();
                return l > 0 ? n0.dot(n1) / l : -2.0;
              };
              const double b02 = bend((p1 - p0).cross(p2 - p0), (p2 - p0).cross(p3 - p0));
              const double b13 = bend((p2 - p1).cross(p3 - p1), (p3 - p1).cross(p0 - p1));
              auto& out = tris[z];
              if (b02 >= b13) {
                out.push_back({q[0], q[1], q[2]});
                out.push_back({q[0], q[2], q[3]});
              } else {
                out.push_back({q[0], q[1], q[3]});
                out.push_back({q[1], q[2], q[3]});
              }
            }
          }
        }
  }, params.threaded);
  for (const auto& t : tris) mesh.triangles.insert(mesh.triangles.end(), t.begin(), t.end());

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
