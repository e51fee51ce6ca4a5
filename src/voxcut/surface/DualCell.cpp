#include "voxcut/surface/DualCell.h"

#include <Eigen/Eigenvalues>
#include <algorithm>

namespace voxcut {
namespace {

struct Tables {
  int edgeCorner[12][2];
  int faceCorner[6][4];  // face 2*a + s: corners in cycle order
  int faceEdge[6][4];    // edge between faceCorner[i] and faceCorner[i+1]
  Tables() {
    for (int e = 0; e < 12; ++e) {
      const int a = e / 4, u = (a + 1) % 3, w = (a + 2) % 3;
      for (int side = 0; side < 2; ++side)
        edgeCorner[e][side] = (side << a) | ((e & 1) << u) | (((e >> 1) & 1) << w);
    }
    for (int a = 0; a < 3; ++a)
      for (int s = 0; s < 2; ++s) {
        const int u = (a + 1) % 3, w = (a + 2) % 3, f = 2 * a + s;
        const int cyc[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        for (int i = 0; i < 4; ++i)
          faceCorner[f][i] = (s << a) | (cyc[i][0] << u) | (cyc[i][1] << w);
        for (int i = 0; i < 4; ++i) {
          const int c0 = faceCorner[f][i], c1 = faceCorner[f][(i + 1) % 4];
          const int diff = c0 ^ c1;
          const int ea = diff == 1 ? 0 : (diff == 2 ? 1 : 2);
          const int lo = c0 & c1;
          const int eu = (ea + 1) % 3, ew = (ea + 2) % 3;
          faceEdge[f][i] = 4 * ea + cornerBit(lo, eu) + 2 * cornerBit(lo, ew);
        }
      }
  }
};
const Tables kTables;

int find(std::array<std::int8_t, 24>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

}  // namespace

int edgeCorner(int edge, int side) {
  return kTables.edgeCorner[edge][side];
}

bool DualCell::hasSurface() const {
  if (occupied == 0) return false;
  for (int e = 0; e < 12; ++e) {
    if ((connected >> e) & 1) continue;
    if ((occupied >> kTables.edgeCorner[e][0]) & 1 || (occupied >> kTables.edgeCorner[e][1]) & 1)
      return true;
  }
  return false;
}

DualCell gatherDualCell(const VoxelGrid& grid, const Index3& m) {
  DualCell cell;
  const std::size_t base = grid.index(m);
  const std::size_t sx = grid.stride(0), sy = grid.stride(1), sz = grid.stride(2);
  std::size_t v[8];
  for (int c = 0; c < 8; ++c) {
    v[c] = base + cornerBit(c, 0) * sx + cornerBit(c, 1) * sy + cornerBit(c, 2) * sz;
    if (grid.occupied(v[c])) cell.occupied = static_cast<std::uint8_t>(cell.occupied | (1u << c));
  }
  for (int e = 0; e < 12; ++e)
    if (grid.connected(v[kTables.edgeCorner[e][0]], e / 4))
      cell.connected = static_cast<std::uint16_t>(cell.connected | (1u << e));
  return cell;
}

int dualCellComponents(const DualCell& cell, std::array<std::int8_t, 8>& comp) {
  std::array<std::int8_t, 24> parent{};
  for (int c = 0; c < 8; ++c) parent[c] = static_cast<std::int8_t>(c);
  for (int e = 0; e < 12; ++e)
    if ((cell.connected >> e) & 1) {
      const int a = find(parent, kTables.edgeCorner[e][0]),
                b = find(parent, kTables.edgeCorner[e][1]);
      if (a != b) parent[std::max(a, b)] = static_cast<std::int8_t>(std::min(a, b));
    }
  int n = 0;
  std::array<std::int8_t, 8> label;
  label.fill(-1);
  for (int c = 0; c < 8; ++c) {
    comp[c] = -1;
    if (!((cell.occupied >> c) & 1)) continue;
    const int r = find(parent, c);
    if (label[r] < 0) label[r] = static_cast<std::int8_t>(n++);
    comp[c] = label[r];
  }
  return n;
}

int dualCellPatches(const DualCell& cell, std::array<std::int8_t, 24>& patch,
                    const NeighbourCell& neighbour, std::array<FaceSegments, 6>* segments) {
  auto occ = [&](int c) { return (cell.occupied >> c) & 1; };
  auto conn = [&](int e) { return (cell.connected >> e) & 1; };
  auto slot = [](int e, int corner) { return 2 * e + cornerBit(corner, e / 4); };
  std::array<std::int8_t, 24> parent;
  for (int s = 0; s < 24; ++s) parent[s] = static_cast<std::int8_t>(s);
  auto join = [&](int s0, int s1) {
    const int a = find(parent, s0), b = find(parent, s1);
    if (a != b) parent[std::max(a, b)] = static_cast<std::int8_t>(std::min(a, b));
  };
  std::array<std::int8_t, 8> comp{};
  bool haveComp = false;
  for (int f = 0; f < 6; ++f) {
    const int* q = kTables.faceCorner[f];
    const int* ed = kTables.faceEdge[f];  // ed[i] joins q[i] and q[i+1]
    // Runs: (first corner, start slot, last corner, end slot).
    int nRuns = 0;
    int runCorner[4], runStart[4], runEnd[4];
    for (int i = 0; i < 4; ++i) {
      const int prev = ed[(i + 3) % 4];
      if (!occ(q[i]) || conn(prev)) continue;
      int j = i;
      while (conn(ed[j])) j = (j + 1) % 4;
      runCorner[nRuns] = q[i];
      runStart[nRuns] = slot(prev, q[i]);
      runEnd[nRuns] = slot(ed[j], q[j]);
      ++nRuns;
    }
    bool ring = false;
    if (nRuns == 2) {
      if (!haveComp) {
        dualCellComponents(cell, comp);
        haveComp = true;
      }
      if (comp[runCorner[0]] == comp[runCorner[1]]) {
        const DualCell other = neighbour(f);
        std::array<std::int8_t, 8> otherComp;
        dualCellComponents(other, otherComp);
        const int flip = 1 << (f / 2);  // the same corner seen from the other cell
        const int c0 = otherComp[runCorner[0] ^ flip], c1 = otherComp[runCorner[1] ^ flip];
        ring = c0 >= 0 && c0 == c1;
      }
    }
    if (segments) (*segments)[f].count = nRuns;
    for (int r = 0; r < nRuns; ++r) {
      const int start = ring ? runStart[(r + 1) % 2] : runStart[r];
      join(runEnd[r], start);
      if (segments)
        (*segments)[f].slots[r] = {static_cast<std::int8_t>(runEnd[r]),
                                   static_cast<std::int8_t>(start)};
    }
  }
  int n = 0;
  std::array<std::int8_t, 24> label;
  label.fill(-1);
  for (int s = 0; s < 24; ++s) {
    patch[s] = -1;
    const int e = s / 2;
    if (conn(e) || !occ(kTables.edgeCorner[e][s % 2])) continue;
    const int r = find(parent, s);
    if (label[r] < 0) label[r] = static_cast<std::int8_t>(n++);
    patch[s] = label[r];
  }
  return n;
}

NeighbourCell gridNeighbour(const VoxelGrid& grid, const Index3& m) {
  // Two words of capture, so that std::function needs no heap allocation.
  return [g = &grid, cell = grid.index(m)](int face) {
    Index3 o = g->coord(cell);
    const int a = face / 2;
    o[a] += (face & 1) ? 1 : -1;
    if (o[a] < 0 || o[a] + 1 >= g->dims()[a]) return DualCell{};
    return gatherDualCell(*g, o);
  };
}

namespace {

// Whether the patch of edge e's incidences is exactly those two: both faces of the cell that
// hold e join them to each other (each incidence has one segment on each of its two faces, so
// the patches are cycles).
bool crackTip(const std::array<std::int8_t, 24>& patch, int e) {
  const int p = patch[2 * e];
  if (p < 0 || patch[2 * e + 1] != p) return false;
  for (int s = 0; s < 24; ++s)
    if (patch[s] == p && s / 2 != e) return false;
  return true;
}

// Whether edge e of the cell with min corner m is a crack tip there (m inside the grid).
bool crackTipIn(const VoxelGrid& grid, const Index3& m, int e) {
  std::array<std::int8_t, 24> patch;
  (void)dualCellPatches(gatherDualCell(grid, m), patch, gridNeighbour(grid, m));
  return crackTip(patch, e);
}

bool cellInGrid(const VoxelGrid& grid, const Index3& m) {
  for (int a = 0; a < 3; ++a)
    if (m[a] < 0 || m[a] + 1 >= grid.dims()[a]) return false;
  return true;
}

}  // namespace

bool isSealedLink(const VoxelGrid& grid, std::size_t v, int a) {
  if (!grid.hasLink(v, a) || grid.connected(v, a) || !grid.occupied(v) ||
      !grid.occupied(v + grid.stride(a)))
    return false;
  const int u = (a + 1) % 3, w = (a + 2) % 3;
  const Index3 c = grid.coord(v);
  Index3 m0 = c;
  m0[u] -= 1;
  m0[w] -= 1;
  if (!cellInGrid(grid, m0) || !cellInGrid(grid, c)) return false;
  // Cells 0 and 2 around the link hold all 4 faces around it between them.
  return crackTipIn(grid, m0, 4 * a + 3) && crackTipIn(grid, c, 4 * a);
}

int dropSealedPatches(const VoxelGrid& grid, const Index3& m, std::array<std::int8_t, 24>& patch,
                      int count) {
  std::array<bool, 12> sealed{};
  bool any = false;
  for (int e = 0; e < 12; ++e) {
    if (!crackTip(patch, e)) continue;
    // This cell holds 2 of the 4 faces around the link; the cell diagonally across the link
    // holds the other 2.
    const int a = e / 4, u = (a + 1) % 3, w = (a + 2) % 3, ou = e & 1, ow = (e >> 1) & 1;
    Index3 across = m;
    across[u] += 2 * ou - 1;
    across[w] += 2 * ow - 1;
    if (!cellInGrid(grid, across) || !crackTipIn(grid, across, 4 * a + (1 - ou) + 2 * (1 - ow)))
      continue;
    sealed[static_cast<std::size_t>(patch[2 * e])] = true;
    any = true;
  }
  if (!any) return count;
  // Patches are numbered in order of their lowest slot; dropping some keeps that order.
  std::array<std::int8_t, 12> renumber;
  int n = 0;
  for (int p = 0; p < count; ++p)
    renumber[static_cast<std::size_t>(p)] = static_cast<std::int8_t>(sealed[p] ? -1 : n++);
  for (int s = 0; s < 24; ++s)
    if (patch[s] >= 0) patch[s] = renumber[static_cast<std::size_t>(patch[s])];
  return n;
}

namespace {

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

}  // namespace

DualCellVertices dualCellVertices(const VoxelGrid& grid, const Index3& m, double qefThreshold,
                                  std::array<FaceSegments, 6>* segments,
                                  std::uint8_t* neighbourFaces) {
  DualCellVertices out;
  const DualCell cell = gatherDualCell(grid, m);
  if (neighbourFaces) {
    *neighbourFaces = 0;
    const NeighbourCell across = gridNeighbour(grid, m);
    out.count = dualCellPatches(
        cell, out.patch,
        [&](int f) {
          *neighbourFaces = static_cast<std::uint8_t>(*neighbourFaces | (1u << f));
          return across(f);
        },
        segments);
  } else {
    out.count = dualCellPatches(cell, out.patch, gridNeighbour(grid, m), segments);
  }
  VOXCUT_ASSERT(out.count <= 12, "a dual cell has at most 12 patches");
  out.count = dropSealedPatches(grid, m, out.patch, out.count);
  const std::size_t base = grid.index(m);
  for (int p = 0; p < out.count; ++p) {
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Vec3d atb = Vec3d::Zero(), mass = Vec3d::Zero();
    int count = 0;
    std::uint64_t voxel = ~std::uint64_t{0};
    for (int s = 0; s < 24; ++s) {
      if (out.patch[s] != p) continue;
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
    const Vec3d local = solveQef(ata, atb, mass, qefThreshold);
    out.position[p] = grid.origin() + grid.voxelSize() * (Vec3d(m.x, m.y, m.z) + local);
    out.voxel[p] = voxel;
  }
  return out;
}

void cellsAroundLink(const VoxelGrid& grid, std::size_t v, int a, std::array<std::size_t, 4>& cells,
                     std::array<int, 4>& edges) {
  const int u = (a + 1) % 3, w = (a + 2) % 3;
  constexpr int kOff[4][2] = {{-1, -1}, {0, -1}, {0, 0}, {-1, 0}};
  for (int k = 0; k < 4; ++k) {
    cells[k] = v;
    if (kOff[k][0]) cells[k] -= grid.stride(u);
    if (kOff[k][1]) cells[k] -= grid.stride(w);
    edges[k] = 4 * a + (-kOff[k][0]) + 2 * (-kOff[k][1]);
  }
}

LinkFace linkFace(int a, int k) {
  const int u = (a + 1) % 3, w = (a + 2) % 3;
  return {(k == 0 || k == 3) ? 0 : (k == 1 ? 1 : 3), (k % 2 == 0) ? u : w};
}

int slotAcross(int slot, int a) {
  const int e = slot / 2, ea = e / 4;
  const int bit = ((ea + 1) % 3 == a) ? 1 : 2;
  return 2 * (e & ~bit) + slot % 2;
}

int doubledSegments(const FaceSegments& fs, int a, const std::array<std::int8_t, 24>& lower,
                    const std::array<std::int8_t, 24>& upper, std::array<DoubledSegment, 4>& out) {
  int n = 0;
  for (int r = 1; r < fs.count; ++r)
    for (int q = 0; q < r; ++q) {
      const int s0 = fs.slots[r][0], t0 = fs.slots[q][0];
      if (lower[s0] < 0 || lower[s0] != lower[t0] ||
          upper[slotAcross(s0, a)] != upper[slotAcross(t0, a)])
        continue;
      out[n++] = {fs.slots[r], lower[s0], upper[slotAcross(s0, a)]};
      break;
    }
  return n;
}

namespace {

// Whether splitting quad q (cells in order around the link) along cells 0-2 bends less than
// along 1-3: the split whose triangle normals agree better; ties go to 0-2. Symmetric in the
// quad's orientation, so both sheets of a cut link choose alike.
bool preferDiagonal02(const std::vector<Vec3d>& pos, const std::array<int, 4>& q) {
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

void triangulateLink(const LinkRing& ring, const std::vector<Vec3d>& positions,
                     std::array<LinkSheet, 2>& out) {
  bool quad[2] = {false, false};
  for (int side = 0; side < 2; ++side) {
    LinkSheet& sh = out[side];
    sh = LinkSheet{};
    if (!ring.sheet[side]) continue;
    bool split = false;
    for (int k = 0; k < 4; ++k) split = split || ring.split[side][k] >= 0;
    if (!split) {
      quad[side] = true;
      continue;
    }
    // Rare: a polygon with split edges, fanned around its own centre.
    for (int k = 0; k < 4; ++k) {
      sh.polygon[sh.polygonSize++] = ring.vertex[side][k];
      if (ring.split[side][k] >= 0) sh.polygon[sh.polygonSize++] = ring.split[side][k];
    }
    if (side) std::reverse(sh.polygon.begin(), sh.polygon.begin() + sh.polygonSize);
  }
  // Split along the diagonal (cells 0-2 or 1-3) whose two triangles bend least.
  bool diag02[2] = {true, true};
  for (int side = 0; side < 2; ++side)
    if (quad[side]) diag02[side] = preferDiagonal02(positions, ring.vertex[side]);
  // At a crack front both sheets of a cut link can share the vertices of a diagonal; then the
  // second sheet takes the other diagonal, or that edge would carry four triangles.
  if (quad[0] && quad[1] && diag02[0] == diag02[1]) {
    const int i = diag02[0] ? 0 : 1;
    const auto& q = ring.vertex;
    if (q[0][i] == q[1][i] && q[0][i + 2] == q[1][i + 2]) diag02[1] = !diag02[1];
  }
  for (int side = 0; side < 2; ++side) {
    if (!quad[side]) continue;
    std::array<int, 4> r = ring.vertex[side];
    // Counter-clockwise about +a for the low side; reversed for the high side.
    if (side) std::swap(r[1], r[3]);
    LinkSheet& sh = out[side];
    sh.triangleCount = 2;
    if (diag02[side]) {
      sh.triangles[0] = {r[0], r[1], r[2]};
      sh.triangles[1] = {r[0], r[2], r[3]};
    } else {
      sh.triangles[0] = {r[0], r[1], r[3]};
      sh.triangles[1] = {r[1], r[2], r[3]};
    }
  }
}

Vec3d polygonCentre(const LinkSheet& sheet, const std::vector<Vec3d>& positions) {
  Vec3d p = Vec3d::Zero();
  for (int i = 0; i < sheet.polygonSize; ++i) p += positions[sheet.polygon[i]];
  return p / static_cast<double>(sheet.polygonSize);
}

}  // namespace voxcut
