#include "voxcut/surface/DualCell.h"

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
        for (int i = 0; i < 4; ++i) faceCorner[f][i] = (s << a) | (cyc[i][0] << u) | (cyc[i][1] << w);
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

int edgeCorner(int edge, int side) { return kTables.edgeCorner[edge][side]; }

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
      const int a = find(parent, kTables.edgeCorner[e][0]), b = find(parent, kTables.edgeCorner[e][1]);
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
        (*segments)[f].slots[r] = {static_cast<std::int8_t>(runEnd[r]), static_cast<std::int8_t>(start)};
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

}  // namespace voxcut
