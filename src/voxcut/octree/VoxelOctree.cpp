#include "voxcut/octree/VoxelOctree.h"

#include <algorithm>
#include <atomic>

#include "voxcut/core/Parallel.h"

namespace voxcut {
namespace {

// A potential cube of some level: geometrically valid (all voxels occupied, all links
// connected), and which materials it holds.
struct Candidate {
  bool valid = false;
  bool mixed = false;
  std::uint8_t material = 0;     // when not mixed
  std::int16_t minBoundary = 0;  // when mixed: smallest boundary limit of its materials
};

struct LevelGrid {
  Index3 n;  // candidates per axis
  std::vector<Candidate> cand;
  [[nodiscard]] std::size_t index(int x, int y, int z) const {
    return static_cast<std::size_t>(x) +
           static_cast<std::size_t>(n.x) *
               (static_cast<std::size_t>(y) +
                static_cast<std::size_t>(n.y) * static_cast<std::size_t>(z));
  }
};

void orInto(std::uint8_t& byte, std::uint8_t bits) {
  std::atomic_ref<std::uint8_t>(byte).fetch_or(bits, std::memory_order_relaxed);
}

Candidate merge(const Candidate& a, const Candidate& b, const OctreeParams& p) {
  if (!a.valid || !b.valid) return {};
  auto boundaryOf = [&](const Candidate& c) {
    return c.mixed ? c.minBoundary : static_cast<std::int16_t>(p.maxBoundaryLevel[c.material - 1]);
  };
  Candidate out;
  out.valid = true;
  if (!a.mixed && !b.mixed && a.material == b.material) {
    out.material = a.material;
    return out;
  }
  out.mixed = true;
  out.minBoundary = std::min(boundaryOf(a), boundaryOf(b));
  return out;
}

bool passes(const Candidate& c, int level, const OctreeParams& p) {
  if (!c.valid) return false;
  if (c.mixed) return level <= c.minBoundary;
  return level <= p.maxInternalLevel[c.material - 1];
}

// Level-1 candidate with origin o: 27 voxels and the 54 links between them.
Candidate levelOne(const VoxelGrid& g, const Index3& o, const OctreeParams& p) {
  Candidate c;
  c.valid = true;
  for (int dz = 0; dz <= 2; ++dz)
    for (int dy = 0; dy <= 2; ++dy)
      for (int dx = 0; dx <= 2; ++dx) {
        const std::size_t v = g.index(o.x + dx, o.y + dy, o.z + dz);
        const std::uint8_t m = g.material(v);
        if (m == 0) return {};
        const int d[3] = {dx, dy, dz};
        for (int a = 0; a < 3; ++a)
          if (d[a] < 2 && !g.connected(v, a)) return {};
        Candidate single;
        single.valid = true;
        single.material = m;
        c = (dx | dy | dz) ? merge(c, single, p) : single;
      }
  return c;
}

}  // namespace

OctreeParams OctreeParams::uniform(std::size_t materials, int internal, int boundary) {
  OctreeParams p;
  p.maxInternalLevel.assign(materials, internal);
  p.maxBoundaryLevel.assign(materials, boundary);
  return p;
}

std::vector<std::size_t> VoxelOctree::cubesPerLevel() const {
  std::vector<std::size_t> n;
  for (const OctreeCube& c : cubes) {
    if (c.deleted) continue;
    if (n.size() < c.level) n.resize(c.level, 0);
    ++n[c.level - 1];
  }
  return n;
}

void VoxelOctree::setCubeCells(const Index3& origin, int level, std::int32_t value) {
  const int n = 1 << level;
  const auto dx = static_cast<std::size_t>(dims.x), dy = static_cast<std::size_t>(dims.y);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y) {
      const std::size_t row =
          static_cast<std::size_t>(origin.x) + dx * (static_cast<std::size_t>(origin.y + y) +
                                                     dy * static_cast<std::size_t>(origin.z + z));
      std::fill_n(cellCube.begin() + static_cast<std::ptrdiff_t>(row), n, value);
    }
}

std::size_t VoxelOctree::activeLinkCount() const {
  std::size_t n = 0;
  for (std::uint8_t s : state) n += (s & 1u) + ((s >> 1) & 1u) + ((s >> 2) & 1u);
  return n;
}

namespace {

// Calls fn(p, a) for the first voxel p of each of the cube's 12 edges, running along axis a.
template <class Fn>
void forEachCubeEdge(const OctreeCube& cube, Fn&& fn) {
  const int size = 1 << cube.level;
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    for (int cu = 0; cu <= size; cu += size)
      for (int cw = 0; cw <= size; cw += size) {
        Index3 p = cube.origin;
        p[u] += cu;
        p[w] += cw;
        fn(p, a);
      }
  }
}

}  // namespace

void activateCubeFrame(VoxelOctree& octree, const VoxelGrid& grid, const OctreeCube& cube) {
  const int size = 1 << cube.level;
  forEachCubeEdge(cube, [&](const Index3& start, int a) {
    std::size_t v = grid.index(start);
    for (int i = 0; i < size; ++i, v += grid.stride(a)) {
      orInto(octree.state[v], static_cast<std::uint8_t>((1u << a) | kActiveVoxel));
      orInto(octree.state[v + grid.stride(a)], kActiveVoxel);
    }
  });
}

namespace {

// Checks that `params` give levels in 0..16 for every material of the grid.
void checkLevels(const OctreeParams& params, std::size_t nMat) {
  if (params.maxInternalLevel.size() < nMat || params.maxBoundaryLevel.size() < nMat)
    throw InputError("octree levels must be given for every material");
  for (std::size_t m = 0; m < nMat; ++m)
    if (params.maxInternalLevel[m] < 0 || params.maxBoundaryLevel[m] < 0 ||
        params.maxInternalLevel[m] > 16 || params.maxBoundaryLevel[m] > 16)
      throw InputError("octree levels must lie in 0..16");
}

// The highest cube level worth trying: the largest material level, lowered while a cube of
// it does not fit the grid along any axis.
int topLevel(const OctreeParams& params, std::size_t nMat, const Index3& d) {
  int top = 0;
  for (std::size_t m = 0; m < nMat; ++m)
    top = std::max({top, params.maxInternalLevel[m], params.maxBoundaryLevel[m]});
  while (top > 0 && ((d.x - 1) >> top) < 1 && ((d.y - 1) >> top) < 1 && ((d.z - 1) >> top) < 1)
    --top;
  return top;
}

// Candidates, level by level up to `top`: level 1 from voxels and links, higher from 8
// children (index 0 unused).
std::vector<LevelGrid> candidateLevels(const VoxelGrid& grid, const OctreeParams& params,
                                       int top, bool threaded) {
  const Index3 d = grid.dims();
  std::vector<LevelGrid> levels(static_cast<std::size_t>(top) + 1);
  for (int L = 1; L <= top; ++L) {
    LevelGrid& lg = levels[L];
    for (int a = 0; a < 3; ++a) lg.n[a] = (d[a] - 1) >> L;
    lg.cand.assign(static_cast<std::size_t>(lg.n.x) * lg.n.y * lg.n.z, {});
    parallelFor(
        0, static_cast<std::size_t>(lg.n.z), 1,
        [&](std::size_t z0, std::size_t z1) {
          for (int z = static_cast<int>(z0); z < static_cast<int>(z1); ++z)
            for (int y = 0; y < lg.n.y; ++y)
              for (int x = 0; x < lg.n.x; ++x) {
                Candidate& c = lg.cand[lg.index(x, y, z)];
                if (L == 1) {
                  c = levelOne(grid, {2 * x, 2 * y, 2 * z}, params);
                  continue;
                }
                const LevelGrid& child = levels[L - 1];
                Candidate acc;
                for (int k = 0; k < 8; ++k) {
                  const Candidate& ch = child.cand[child.index(
                      2 * x + (k & 1), 2 * y + ((k >> 1) & 1), 2 * z + (k >> 2))];
                  acc = k == 0 ? ch : merge(acc, ch, params);
                  if (!acc.valid) break;
                }
                c = acc;
              }
        },
        threaded);
  }
  return levels;
}

// Keeps the largest cubes into `cubes`: top down, a cube inside a kept cube is not kept.
void keepLargestCubes(const std::vector<LevelGrid>& levels, const OctreeParams& params, int top,
                      std::vector<OctreeCube>& cubes) {
  std::vector<std::vector<std::uint8_t>> covered(static_cast<std::size_t>(top) + 2);
  for (int L = top; L >= 1; --L) {
    const LevelGrid& lg = levels[L];
    covered[L].assign(lg.cand.size(), 0);
    for (int z = 0; z < lg.n.z; ++z)
      for (int y = 0; y < lg.n.y; ++y)
        for (int x = 0; x < lg.n.x; ++x) {
          const std::size_t i = lg.index(x, y, z);
          bool cov = false;
          if (L < top) {
            const LevelGrid& up = levels[L + 1];
            if (x / 2 < up.n.x && y / 2 < up.n.y && z / 2 < up.n.z)
              cov = covered[L + 1][up.index(x / 2, y / 2, z / 2)];
          }
          if (!cov && passes(lg.cand[i], L, params)) {
            cubes.push_back({{x << L, y << L, z << L}, static_cast<std::uint8_t>(L), false});
            cov = true;
          }
          covered[L][i] = cov;
        }
  }
}

// Activation step (2): each voxel's connected links that are not surrounded (all 4 cells
// around the link exist and lie in cubes) are active.
void activateUncoveredLinks(VoxelOctree& oct, const VoxelGrid& grid, bool threaded) {
  const Index3 d = grid.dims();
  oct.state.assign(grid.voxelCount(), 0);
  parallelFor(
      0, static_cast<std::size_t>(d.z), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (int z = static_cast<int>(z0); z < static_cast<int>(z1); ++z)
          for (int y = 0; y < d.y; ++y)
            for (int x = 0; x < d.x; ++x) {
              const Index3 c{x, y, z};
              const std::size_t v = grid.index(c);
              std::uint8_t bits = 0;
              for (int a = 0; a < 3; ++a) {
                if (!grid.connected(v, a)) continue;
                // Surrounded: all 4 cells around the link exist and lie in cubes.
                int inCubes = 0;
                const int cells = forEachCellAroundLink(d, c, a, [&](const Index3& cell) {
                  inCubes += oct.cellCube[grid.index(cell)] >= 0;
                });
                if (cells < 4 || inCubes < 4) bits = static_cast<std::uint8_t>(bits | (1u << a));
              }
              oct.state[v] = bits;
            }
      },
      threaded);
}

// Step (4): voxels touching an active link (own links or links from the -a neighbours) are
// active.
void activateTouchedVoxels(VoxelOctree& oct, const VoxelGrid& grid, bool threaded) {
  const Index3 d = grid.dims();
  std::vector<std::uint8_t> touched(grid.voxelCount(), 0);
  parallelFor(
      0, static_cast<std::size_t>(d.z), 1,
      [&](std::size_t z0, std::size_t z1) {
        for (int z = static_cast<int>(z0); z < static_cast<int>(z1); ++z)
          for (int y = 0; y < d.y; ++y)
            for (int x = 0; x < d.x; ++x) {
              const Index3 c{x, y, z};
              const std::size_t v = grid.index(c);
              bool t = (oct.state[v] & 7u) != 0;
              for (int a = 0; a < 3 && !t; ++a)
                t = c[a] > 0 && ((oct.state[v - grid.stride(a)] >> a) & 1u);
              touched[v] = t;
            }
      },
      threaded);
  parallelFor(
      0, grid.voxelCount(), 1 << 16,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t v = b; v < e; ++v)
          if (touched[v]) oct.state[v] = static_cast<std::uint8_t>(oct.state[v] | kActiveVoxel);
      },
      threaded);
}

}  // namespace

VoxelOctree buildVoxelOctree(const VoxelGrid& grid, const OctreeParams& params, bool threaded) {
  const std::size_t nMat = grid.materialNames().size();
  checkLevels(params, nMat);
  VoxelOctree oct;
  oct.dims = grid.dims();
  const int top = topLevel(params, nMat, oct.dims);
  keepLargestCubes(candidateLevels(grid, params, top, threaded), params, top, oct.cubes);
  // Cube map over unit cells.
  oct.cellCube.assign(grid.voxelCount(), -1);
  parallelFor(
      0, oct.cubes.size(), 16,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t c = c0; c < c1; ++c)
          oct.setCubeCells(oct.cubes[c].origin, oct.cubes[c].level, static_cast<std::int32_t>(c));
      },
      threaded);
  // Activation steps (2)-(4): links not surrounded by cubes, every cube's frame, and the
  // voxels touching an active link.
  activateUncoveredLinks(oct, grid, threaded);
  parallelFor(
      0, oct.cubes.size(), 16,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t c = c0; c < c1; ++c) activateCubeFrame(oct, grid, oct.cubes[c]);
      },
      threaded);
  activateTouchedVoxels(oct, grid, threaded);
  rebuildActiveVoxels(oct, threaded);
  return oct;
}

VoxelOctree allActive(const VoxelGrid& grid, bool threaded) {
  VoxelOctree oct;
  oct.dims = grid.dims();
  oct.cellCube.assign(grid.voxelCount(), -1);
  oct.state.assign(grid.voxelCount(), 0);
  parallelFor(
      0, grid.voxelCount(), 1 << 16,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t v = b; v < e; ++v) {
          if (!grid.occupied(v)) continue;
          std::uint8_t s = kActiveVoxel;
          for (int a = 0; a < 3; ++a)
            if (grid.connected(v, a)) s = static_cast<std::uint8_t>(s | (1u << a));
          oct.state[v] = s;
        }
      },
      threaded);
  rebuildActiveVoxels(oct, threaded);
  return oct;
}

void compactCubes(VoxelOctree& oct, bool threaded) {
  VOXCUT_ASSERT(oct.unmappedCubes.empty(),
                "compaction before the cube map is written (activateNewCubeFrames)");
  // Each deleted slot, in ascending order, takes the last live cube; only the moved cubes'
  // cells are rewritten (a deleted cube covers no cell any more).
  const std::size_t before = oct.cubes.size();
  std::vector<std::int32_t> remap(before);
  for (std::size_t c = 0; c < before; ++c)
    remap[c] = oct.cubes[c].deleted ? -1 : static_cast<std::int32_t>(c);
  std::vector<std::uint32_t> moved;  // new slots of moved cubes
  std::size_t last = before;
  auto dropDeletedTail = [&] {
    while (last > 0 && oct.cubes[last - 1].deleted) --last;
  };
  dropDeletedTail();
  for (std::size_t c = 0; c < last; ++c) {
    if (!oct.cubes[c].deleted) continue;
    oct.cubes[c] = oct.cubes[last - 1];
    remap[last - 1] = static_cast<std::int32_t>(c);
    moved.push_back(static_cast<std::uint32_t>(c));
    --last;
    dropDeletedTail();
  }
  if (last == before) return;
  oct.cubes.resize(last);
  parallelFor(
      0, moved.size(), 4,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          const OctreeCube& cube = oct.cubes[moved[i]];
          oct.setCubeCells(cube.origin, cube.level, static_cast<std::int32_t>(moved[i]));
        }
      },
      threaded);
  std::vector<std::uint32_t> fresh;
  for (std::uint32_t c : oct.newCubes)
    if (remap[c] >= 0) fresh.push_back(static_cast<std::uint32_t>(remap[c]));
  oct.newCubes = std::move(fresh);
}

void activateNewCubeFrames(VoxelOctree& oct, const VoxelGrid& grid, bool threaded) {
  // The cube map: these cubes do not overlap one another.
  parallelFor(
      0, oct.unmappedCubes.size(), 16,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t i = c0; i < c1; ++i) {
          const std::uint32_t id = oct.unmappedCubes[i];
          const OctreeCube& cube = oct.cubes[id];
          VOXCUT_ASSERT(!cube.deleted, "an unmapped cube was split before its cells were written");
          oct.setCubeCells(cube.origin, cube.level, static_cast<std::int32_t>(id));
        }
      },
      threaded);
  oct.unmappedCubes.clear();
  parallelFor(
      0, oct.newCubes.size(), 16,
      [&](std::size_t c0, std::size_t c1) {
        for (std::size_t i = c0; i < c1; ++i) {
          const OctreeCube& cube = oct.cubes[oct.newCubes[i]];
          if (!cube.deleted) activateCubeFrame(oct, grid, cube);
        }
      },
      threaded);
  // The frames' voxels, for the incremental rebuild of the active tables.
  for (std::uint32_t id : oct.newCubes) {
    const OctreeCube& cube = oct.cubes[id];
    if (cube.deleted) continue;
    const int size = 1 << cube.level;
    forEachCubeEdge(cube, [&](const Index3& start, int a) {
      std::size_t v = grid.index(start);
      for (int i = 0; i <= size; ++i, v += grid.stride(a)) oct.markChanged(v);
    });
  }
  oct.newCubes.clear();
  // Split level-1 cubes: all 27 voxels and their 54 links inside the cube, and no cube over
  // their cells. Serial: the cubes share face voxels, and markChanged lists each voxel once.
  for (const Index3& o : oct.openedCubes) {
    oct.setCubeCells(o, 1, -1);
    for (int z = 0; z <= 2; ++z)
      for (int y = 0; y <= 2; ++y)
        for (int x = 0; x <= 2; ++x) {
          const int d[3] = {x, y, z};
          auto bits = static_cast<std::uint8_t>(kActiveVoxel);
          for (int a = 0; a < 3; ++a)
            if (d[a] < 2) bits = static_cast<std::uint8_t>(bits | (1u << a));
          const std::size_t v = grid.index(o.x + x, o.y + y, o.z + z);
          oct.state[v] |= bits;
          oct.markChanged(v);
        }
  }
  oct.openedCubes.clear();
}

namespace {

// Index steps of the grid's axes.
std::array<std::size_t, 3> axisStrides(const Index3& d) {
  return {1, static_cast<std::size_t>(d.x),
          static_cast<std::size_t>(d.x) * static_cast<std::size_t>(d.y)};
}

// The link-table row of voxel v (activeIndex must be current): per axis, the entry of the voxel
// across v's active link, or kNoActive. False if an active link ends at an inactive voxel.
bool linkRow(const VoxelOctree& oct, std::size_t v, const std::array<std::size_t, 3>& strides,
             std::array<std::uint32_t, 3>& row) {
  bool ok = true;
  for (std::size_t a = 0; a < 3; ++a) {
    row[a] = oct.linkActive(v, static_cast<int>(a)) ? oct.activeIndex[v + strides[a]] : kNoActive;
    ok = ok && (row[a] != kNoActive || !oct.linkActive(v, static_cast<int>(a)));
  }
  return ok;
}

void rebuildAllActive(VoxelOctree& oct, bool threaded) {
  const std::size_t n = oct.state.size();
  constexpr std::size_t kChunk = 1 << 16;
  std::vector<std::vector<std::uint32_t>> parts((n + kChunk - 1) / kChunk);
  oct.activeIndex.resize(n);
  parallelFor(
      0, parts.size(), 1,
      [&](std::size_t p0, std::size_t p1) {
        for (std::size_t p = p0; p < p1; ++p)
          for (std::size_t v = p * kChunk; v < std::min(n, (p + 1) * kChunk); ++v) {
            std::uint8_t& s = oct.state[v];
            s = static_cast<std::uint8_t>(s & ~kListedVoxel);
            oct.activeIndex[v] = kNoActive;
            if (s & kActiveVoxel) parts[p].push_back(static_cast<std::uint32_t>(v));
          }
      },
      threaded);
  std::vector<std::size_t> offset(parts.size() + 1, 0);
  for (std::size_t p = 0; p < parts.size(); ++p) offset[p + 1] = offset[p] + parts[p].size();
  oct.activeVoxels.resize(offset.back());
  parallelFor(
      0, parts.size(), 1,
      [&](std::size_t p0, std::size_t p1) {
        for (std::size_t p = p0; p < p1; ++p)
          for (std::size_t k = 0; k < parts[p].size(); ++k) {
            oct.activeVoxels[offset[p] + k] = parts[p][k];
            oct.activeIndex[parts[p][k]] = static_cast<std::uint32_t>(offset[p] + k);
          }
      },
      threaded);

  // Link table through the index map.
  const std::vector<std::uint32_t>& act = oct.activeVoxels;
  oct.activeNext.resize(act.size());
  const auto strides = axisStrides(oct.dims);
  std::atomic<bool> broken{false};
  parallelFor(
      0, act.size(), 4096,
      [&](std::size_t b, std::size_t e) {
        bool ok = true;
        for (std::size_t i = b; i < e; ++i)
          ok = linkRow(oct, act[i], strides, oct.activeNext[i]) && ok;
        if (!ok) broken.store(true, std::memory_order_relaxed);
      },
      threaded);
  VOXCUT_ASSERT(!broken.load(), "an active link ends at an inactive voxel");
}

// The same tables from the previous ones and the voxels listed in oct.changed: voxels only
// ever become active, and a link only becomes active on a listed voxel.
void updateActive(VoxelOctree& oct, bool threaded) {
  const std::vector<std::uint32_t>& changed = oct.changed;  // each voxel once
  std::vector<std::uint32_t> added;
  for (std::uint32_t v : changed) {
    std::uint8_t& s = oct.state[v];
    s = static_cast<std::uint8_t>(s & ~kListedVoxel);
    if ((s & kActiveVoxel) && oct.activeIndex[v] == kNoActive) added.push_back(v);
  }
  std::sort(added.begin(), added.end());
  // The previous tables move to the spare buffers, whose memory the new ones reuse.
  oct.spareVoxels.swap(oct.activeVoxels);
  oct.spareNext.swap(oct.activeNext);
  const std::vector<std::uint32_t>& old = oct.spareVoxels;
  const std::vector<std::array<std::uint32_t, 3>>& oldNext = oct.spareNext;
  // Merge: the added voxels go in before their successors; newPos maps old entries.
  std::vector<std::size_t> insertAt(added.size());
  for (std::size_t k = 0; k < added.size(); ++k)
    insertAt[k] =
        static_cast<std::size_t>(std::lower_bound(old.begin(), old.end(), added[k]) - old.begin());
  const std::size_t total = old.size() + added.size();
  oct.activeVoxels.resize(total);
  std::vector<std::uint32_t>& newPos = oct.spareMap;
  newPos.resize(old.size());
  std::size_t from = 0;
  for (std::size_t k = 0; k <= added.size(); ++k) {
    const std::size_t to = k < added.size() ? insertAt[k] : old.size();
    for (std::size_t i = from; i < to; ++i) {
      newPos[i] = static_cast<std::uint32_t>(i + k);
      oct.activeVoxels[i + k] = old[i];
    }
    if (k < added.size()) oct.activeVoxels[to + k] = added[k];
    from = to;
  }
  const std::size_t firstMoved = added.empty() ? total : insertAt[0];
  for (std::size_t p = firstMoved; p < total; ++p)
    oct.activeIndex[oct.activeVoxels[p]] = static_cast<std::uint32_t>(p);
  // Link table: old entries remapped, then the listed voxels' rows recomputed.
  oct.activeNext.resize(total);
  for (std::size_t k = 0; k < added.size(); ++k)
    oct.activeNext[insertAt[k] + k] = {kNoActive, kNoActive, kNoActive};
  parallelFor(
      0, old.size(), 4096,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i)
          for (std::size_t a = 0; a < 3; ++a) {
            const std::uint32_t j = oldNext[i][a];
            oct.activeNext[newPos[i]][a] = j == kNoActive ? kNoActive : newPos[j];
          }
      },
      threaded);
  const auto strides = axisStrides(oct.dims);
  for (std::uint32_t v : changed) {
    const std::uint32_t i = oct.activeIndex[v];
    if (i == kNoActive) continue;
    const bool ok = linkRow(oct, v, strides, oct.activeNext[i]);
    VOXCUT_ASSERT(ok, "an active link ends at an inactive voxel");
  }
}

}  // namespace

void rebuildActiveVoxels(VoxelOctree& oct, bool threaded) {
  const bool incremental = oct.activeIndex.size() == oct.state.size() &&
                           oct.activeNext.size() == oct.activeVoxels.size();
  if (incremental && oct.changed.empty()) return;  // nothing was raised: the tables stand
  if (incremental)
    updateActive(oct, threaded);
  else
    rebuildAllActive(oct, threaded);
  oct.changed.clear();
}

}  // namespace voxcut
