#include "voxcut/voxel/Voxelizer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>

#include "voxcut/core/Parallel.h"
#include "voxcut/voxel/GridLinks.h"
#include "voxcut/voxel/ScanConvert.h"
#include "voxcut/voxel/WindingNumber.h"

namespace voxcut {
namespace {

constexpr float kMinT = 1e-3f;

void validate(const std::vector<MaterialMesh>& materials) {
  if (materials.empty()) throw InputError("no material meshes given");
  if (materials.size() > 255) throw InputError("at most 255 materials are supported");
  for (const auto& m : materials) {
    if (m.mesh.faces.empty()) throw InputError("mesh '" + m.name + "' has no triangles");
    for (const auto& v : m.mesh.vertices)
      if (!v.allFinite()) throw InputError("mesh '" + m.name + "' has non-finite coordinates");
    for (const auto& f : m.mesh.faces)
      for (int k = 0; k < 3; ++k)
        if (f[k] < 0 || f[k] >= static_cast<int>(m.mesh.vertices.size()))
          throw InputError("mesh '" + m.name + "' has a face with an invalid vertex index");
  }
}

// One material mesh prepared for labelling and Hermite look-ups.
struct PreparedMesh {
  TriangleMesh mesh;
  std::array<AxisCrossings, 3> crossings;
  std::unique_ptr<WindingNumberTree> gwn;  // only when not watertight
  std::vector<Vec3f> faceNormals;
};

// Inside flags (1 byte per voxel) along z lines.
void labelInside(const PreparedMesh& pm, const GridFrame& frame, bool threaded,
                 std::vector<std::uint8_t>& inside) {
  const AxisCrossings& zc = pm.crossings[2];
  const int nx = frame.dims.x, ny = frame.dims.y, nz = frame.dims.z;
  const std::size_t sz = static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny);
  auto pos = [&](int x, int y, int z) {
    return Vec3d(frame.origin + frame.voxelSize * Vec3d(x, y, z));
  };
  parallelFor(
      0, static_cast<std::size_t>(ny), 1,
      [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
          for (int x = 0; x < nx; ++x) {
            const std::size_t line = static_cast<std::size_t>(x) + static_cast<std::size_t>(nx) * y;
            const LineCrossing* c = zc.begin(line);
            const LineCrossing* e = zc.end(line);
            auto at = [&](int z) -> std::uint8_t& {
              return inside[line + sz * static_cast<std::size_t>(z)];
            };
            if (!pm.gwn) {
              // Watertight: the winding number is the signed count of crossings below.
              int wind = 0;
              for (int z = 0; z < nz; ++z) {
                for (; c != e && c->s < z; ++c) wind -= c->sign;
                at(z) = wind != 0;
              }
              continue;
            }
            // Open mesh: w is continuous between crossings except near holes; sample each
            // segment at its ends and middle and subdivide where the samples disagree.
            auto label = [&](int z) -> std::uint8_t {
              return std::abs((*pm.gwn)(pos(x, static_cast<int>(y), z))) > 0.5;
            };
            int z = 0;
            while (z < nz) {
              for (; c != e && c->s < z; ++c) {
              }
              int zEnd = nz - 1;  // last voxel before the next crossing
              if (c != e) zEnd = std::min(nz - 1, static_cast<int>(std::ceil(c->s)) - 1);
              if (zEnd < z) zEnd = z;
              // Recursive fill of [z, zEnd].
              struct Seg {
                int a, b;
                std::uint8_t la, lb;
              };
              std::vector<Seg> stack{
                  {z, zEnd, label(z), z == zEnd ? std::uint8_t{0} : label(zEnd)}};
              if (z == zEnd) stack.back().lb = stack.back().la;
              while (!stack.empty()) {
                Seg s = stack.back();
                stack.pop_back();
                at(s.a) = s.la;
                at(s.b) = s.lb;
                if (s.b - s.a <= 1) continue;
                const int m = (s.a + s.b) / 2;
                const std::uint8_t lm = label(m);
                if (s.la == lm && lm == s.lb) {
                  for (int k = s.a + 1; k < s.b; ++k) at(k) = lm;
                  continue;
                }
                stack.push_back({s.a, m, s.la, lm});
                stack.push_back({m, s.b, lm, s.lb});
              }
              z = zEnd + 1;
            }
          }
      },
      threaded);
}

// Hermite data of link (voxel c, axis a) of mesh pm, whose inside flags at the two ends differ.
Hermite linkHermite(const PreparedMesh& pm, const GridFrame& frame, const Index3& c, int a,
                    bool& fromHole) {
  const AxisCrossings& ac = pm.crossings[a];
  const std::size_t line = ac.line(c);
  const double k = c[a];
  const LineCrossing* best = nullptr;
  for (const LineCrossing* it = ac.begin(line); it != ac.end(line); ++it) {
    if (it->s < k || it->s > k + 1) continue;
    if (!best || std::abs(it->s - (k + 0.5)) < std::abs(best->s - (k + 0.5))) best = &*it;
  }
  Hermite h;
  fromHole = false;
  if (best) {
    h.t = static_cast<float>(best->s - k);
    const Vec3f& n = pm.faceNormals[best->face];
    const float s = n[a] < 0 ? -1.f : 1.f;
    for (int i = 0; i < 3; ++i) h.n[i] = s * n[i];
  } else {
    fromHole = true;
    h.n[a] = 1.f;
    if (pm.gwn) {
      Vec3d p0 = frame.origin + frame.voxelSize * Vec3d(c.x, c.y, c.z);
      Vec3d p1 = p0;
      p1[a] += frame.voxelSize;
      const double w0 = std::abs((*pm.gwn)(p0)) - 0.5, w1 = std::abs((*pm.gwn)(p1)) - 0.5;
      if (w0 != w1) h.t = static_cast<float>(w0 / (w0 - w1));
    }
  }
  h.t = std::clamp(h.t, kMinT, 1.f - kMinT);
  return h;
}

// The bounding box of all material meshes.
std::array<Vec3d, 2> meshBounds(const std::vector<MaterialMesh>& materials) {
  std::array<Vec3d, 2> bounds{Vec3d::Constant(std::numeric_limits<double>::infinity()),
                              Vec3d::Constant(-std::numeric_limits<double>::infinity())};
  for (const auto& m : materials) {
    const auto b = m.mesh.bounds();
    bounds[0] = bounds[0].cwiseMin(b[0]);
    bounds[1] = bounds[1].cwiseMax(b[1]);
  }
  return bounds;
}

// Repairs a material's mesh into `pm` (noting the repair in `rep`), with its face normals,
// crossings with the grid lines and, when it is not watertight, its winding-number tree.
void prepareMesh(const MaterialMesh& material, const GridFrame& frame, bool threaded,
                 PreparedMesh& pm, VoxelizeReport& rep) {
  RepairReport rr;
  pm.mesh = repairMesh(material.mesh, &rr);
  rep.repairs.push_back(rr);
  rep.usedWindingNumber.push_back(!rr.watertight);
  if (pm.mesh.faces.empty())
    throw InputError("mesh '" + material.name + "' has no non-degenerate triangles");
  pm.faceNormals.resize(pm.mesh.faces.size());
  for (std::size_t f = 0; f < pm.mesh.faces.size(); ++f) {
    const auto& t = pm.mesh.faces[f];
    const Vec3d n = (pm.mesh.vertices[t[1]] - pm.mesh.vertices[t[0]])
                        .cross(pm.mesh.vertices[t[2]] - pm.mesh.vertices[t[0]]);
    const double len = n.norm();
    pm.faceNormals[f] = len > 0 ? Vec3f((n / len).cast<float>()) : Vec3f::Zero();
  }
  pm.crossings = scanConvert(pm.mesh, frame, threaded);
  if (!rr.watertight) pm.gwn = std::make_unique<WindingNumberTree>(pm.mesh);
}

}  // namespace

VoxelGrid voxelize(const std::vector<MaterialMesh>& materials, const VoxelizeParams& params,
                   VoxelizeReport* report) {
  validate(materials);
  const GridFrame frame = gridFrameFor(meshBounds(materials), params.resolution, params.maxVoxels);
  VoxelGrid grid(frame.dims, frame.origin, frame.voxelSize, params.maxVoxels);
  std::vector<std::string> names;
  for (const auto& m : materials) names.push_back(m.name);
  grid.setMaterialNames(names);

  VoxelizeReport rep;
  const std::size_t nVox = grid.voxelCount();
  const int nMat = static_cast<int>(materials.size());
  std::vector<PreparedMesh> prepared(materials.size());
  std::vector<std::uint8_t> inside(nVox);
  std::uint8_t* mat = grid.materialData();
  const double steps = 2.0 * nMat + 1.0;
  for (int m = 0; m < nMat; ++m) {
    reportProgress(params.progress, "voxelize", (2.0 * m) / steps);
    PreparedMesh& pm = prepared[m];
    prepareMesh(materials[m], frame, params.threaded, pm, rep);
    reportProgress(params.progress, "voxelize", (2.0 * m + 1.0) / steps);
    labelInside(pm, frame, params.threaded, inside);
    const auto id = static_cast<std::uint8_t>(m + 1);
    parallelFor(
        0, nVox, 1 << 16,
        [&](std::size_t b, std::size_t e) {
          for (std::size_t v = b; v < e; ++v)
            if (inside[v]) mat[v] = id;
        },
        params.threaded);
  }
  reportProgress(params.progress, "voxelize", (2.0 * nMat) / steps);
  clearPadding(grid);
  // Links whose crossing came from the winding number, counted per z slice (one task each).
  std::vector<std::size_t> holeLinks(static_cast<std::size_t>(frame.dims.z), 0);
  buildLinks(
      grid,
      [&](const Index3& c, int a, std::uint8_t m0, std::uint8_t m1) {
        bool hole = false;
        const Hermite h = linkHermite(prepared[std::max(m0, m1) - 1], frame, c, a, hole);
        holeLinks[static_cast<std::size_t>(c.z)] += hole;
        return h;
      },
      params.threaded);
  for (std::size_t n : holeLinks) rep.holeLinks += n;
  reportProgress(params.progress, "voxelize", 1.0);
  if (report) *report = std::move(rep);
  return grid;
}

}  // namespace voxcut
