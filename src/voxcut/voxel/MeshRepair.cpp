#include "voxcut/voxel/MeshRepair.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <tuple>

#include "voxcut/core/Predicates.h"

namespace voxcut {
namespace {

/// Whether the triangle a b c has exactly zero area: its corners are collinear (or equal)
/// exactly when each of its three axis-aligned 2D projections is, which the exact orient2d
/// decides without rounding.
bool isCollinear(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  for (int u = 0; u < 3; ++u) {
    const int v = (u + 1) % 3;
    if (orient2d(Vec2d(a[u], a[v]), Vec2d(b[u], b[v]), Vec2d(c[u], c[v])) != 0) return false;
  }
  return true;
}

struct EdgeUse {
  int a, b;  // sorted vertex pair
  int face;
  bool forward;  // face uses a->b
  bool operator<(const EdgeUse& o) const {
    return std::tie(a, b, face) < std::tie(o.a, o.b, o.face);
  }
};

std::vector<EdgeUse> edgeUses(const std::vector<std::array<int, 3>>& faces) {
  std::vector<EdgeUse> uses;
  uses.reserve(faces.size() * 3);
  for (int f = 0; f < static_cast<int>(faces.size()); ++f)
    for (int k = 0; k < 3; ++k) {
      const int i = faces[f][k], j = faces[f][(k + 1) % 3];
      uses.push_back({std::min(i, j), std::max(i, j), f, i < j});
    }
  std::sort(uses.begin(), uses.end());
  return uses;
}

}  // namespace

TriangleMesh repairMesh(const TriangleMesh& in, RepairReport* report) {
  RepairReport rep;
  TriangleMesh out;

  // Weld vertices with bit-identical coordinates (order of first appearance kept).
  std::vector<int> order(in.vertices.size());
  std::iota(order.begin(), order.end(), 0);
  auto less = [&](int i, int j) {
    const Vec3d &p = in.vertices[i], &q = in.vertices[j];
    return std::tie(p.x(), p.y(), p.z(), i) < std::tie(q.x(), q.y(), q.z(), j);
  };
  std::sort(order.begin(), order.end(), less);
  std::vector<int> remap(in.vertices.size());
  std::vector<int> firstOf(in.vertices.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const bool same = k > 0 && in.vertices[order[k]] == in.vertices[order[k - 1]];
    firstOf[order[k]] = same ? firstOf[order[k - 1]] : order[k];
  }
  std::vector<int> newIndex(in.vertices.size(), -1);
  for (std::size_t i = 0; i < in.vertices.size(); ++i) {
    const int rep0 = firstOf[i];
    if (newIndex[rep0] < 0) {
      newIndex[rep0] = static_cast<int>(out.vertices.size());
      out.vertices.push_back(in.vertices[rep0]);
    } else if (static_cast<int>(i) != rep0) {
      ++rep.weldedVertices;
    }
    remap[i] = newIndex[rep0];
  }

  // Drop degenerate faces (a repeated vertex, or collinear corners: zero area, no normal) and
  // duplicates (same vertex set, either winding): keep the first.
  std::map<std::array<int, 3>, int> seen;
  for (const auto& f : in.faces) {
    const std::array<int, 3> g{remap[f[0]], remap[f[1]], remap[f[2]]};
    if (g[0] == g[1] || g[1] == g[2] || g[0] == g[2] ||
        isCollinear(out.vertices[g[0]], out.vertices[g[1]], out.vertices[g[2]])) {
      ++rep.degenerateFaces;
      continue;
    }
    std::array<int, 3> key = g;
    std::sort(key.begin(), key.end());
    if (!seen.emplace(key, 0).second) {
      ++rep.duplicateFaces;
      continue;
    }
    out.faces.push_back(g);
  }

  // Orientation: breadth-first over manifold edges, flipping neighbours to agree.
  const int nf = static_cast<int>(out.faces.size());
  const std::vector<EdgeUse> uses = edgeUses(out.faces);
  std::vector<std::vector<std::pair<int, int>>> adj(nf);  // (neighbour face, use index pair)
  for (std::size_t s = 0; s < uses.size();) {
    std::size_t e = s;
    while (e < uses.size() && uses[e].a == uses[s].a && uses[e].b == uses[s].b) ++e;
    if (e - s == 1) ++rep.boundaryEdges;
    if (e - s > 2) ++rep.nonManifoldEdges;
    if (e - s == 2) {
      adj[uses[s].face].push_back({uses[s + 1].face, static_cast<int>(s)});
      adj[uses[s + 1].face].push_back({uses[s].face, static_cast<int>(s)});
    }
    s = e;
  }
  std::vector<int> flip(nf, -1);  // -1 unvisited, 0 keep, 1 flip (relative to original)
  std::vector<int> queue;
  for (int seed = 0; seed < nf; ++seed) {
    if (flip[seed] >= 0) continue;
    flip[seed] = 0;
    queue.assign(1, seed);
    double keptArea = 0.0, flippedArea = 0.0;
    std::vector<int> patch;
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const int f = queue[q];
      patch.push_back(f);
      const auto& t = out.faces[f];
      const double area = (out.vertices[t[1]] - out.vertices[t[0]])
                              .cross(out.vertices[t[2]] - out.vertices[t[0]])
                              .norm();
      (flip[f] ? flippedArea : keptArea) += area;
      for (const auto& [g, s] : adj[f]) {
        // Two faces agree when they use their shared edge in opposite directions.
        const bool fFwd = (uses[s].face == f ? uses[s] : uses[s + 1]).forward != (flip[f] == 1);
        const EdgeUse& ug = uses[s].face == g ? uses[s] : uses[s + 1];
        const int want = (ug.forward == !fFwd) ? 0 : 1;
        if (flip[g] < 0) {
          flip[g] = want;
          queue.push_back(g);
        }
      }
    }
    if (flippedArea > keptArea)
      for (int f : patch) flip[f] = 1 - flip[f];
  }
  for (int f = 0; f < nf; ++f)
    if (flip[f] == 1) {
      std::swap(out.faces[f][1], out.faces[f][2]);
      ++rep.flippedFaces;
    }

  // Watertight: every edge has two faces using it in opposite directions.
  bool watertight = rep.boundaryEdges == 0 && rep.nonManifoldEdges == 0;
  if (watertight) {
    const std::vector<EdgeUse> finalUses = edgeUses(out.faces);
    for (std::size_t s = 0; s + 1 < finalUses.size(); s += 2)
      if (finalUses[s].forward == finalUses[s + 1].forward) watertight = false;
  }
  rep.watertight = watertight && nf > 0;
  if (report) *report = rep;
  return out;
}

}  // namespace voxcut
