#include "voxcut/sim/MemoryEstimate.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "voxcut/core/Error.h"
#include "voxcut/topology/DeformationOctree.h"

namespace voxcut {
namespace {

// Per-item sizes in bytes; MemoryEstimate.h says where each comes from.
constexpr double kGridDense = 2 + 10;
constexpr double kOctreeDense = 9 + 1 + 8 + 8;
constexpr double kActiveTables = 16 + 20;
constexpr double kCuttingActive = 24 + 8 + 1;
constexpr double kSurfaceLink = 300;
constexpr double kSimulationSurfaceLink = 400;
constexpr double kElement = 100;
constexpr double kSimulationElement = 4752 + 1150;
constexpr double kNode = 100;
constexpr double kSimulationNode = 2900;
constexpr double kFactorBlocksPerNode43 = 4;
constexpr double kFactorBlock = 80;
// What a world's rollback copy holds per grid voxel (grid bits, the voxel octree's cube map and
// state, the deformation octree's voxel embedding) and per surface link (Hermite entry,
// surface vertex and triangles, the simulation's surface records): the sizes above less the
// build's scratch.
constexpr double kKeptDense = 2 + 9 + 8;
constexpr double kKeptSurfaceLink = 48 + 56 + 24 + 400;

// Whether voxelize would take the meshes (its own checks name what is wrong otherwise).
bool usable(const std::vector<MaterialMesh>& materials) {
  if (materials.empty()) return false;
  for (const MaterialMesh& m : materials) {
    if (m.mesh.faces.empty()) return false;
    for (const Vec3d& v : m.mesh.vertices)
      if (!v.allFinite()) return false;
  }
  return true;
}

// Adds, over the valid faces of `mesh`, (|nx| + |ny| + |nz|) * area to `crossingArea` and
// returns |signed volume|.
double surfaceAndVolume(const TriangleMesh& mesh, double& crossingArea) {
  const int n = static_cast<int>(mesh.vertices.size());
  double volume = 0.0;
  for (const auto& f : mesh.faces) {
    if (std::any_of(f.begin(), f.end(), [n](int i) { return i < 0 || i >= n; })) continue;
    const Vec3d& a = mesh.vertices[f[0]];
    const Vec3d& b = mesh.vertices[f[1]];
    const Vec3d& c = mesh.vertices[f[2]];
    const Vec3d twiceArea = (b - a).cross(c - a);  // |twiceArea| = 2 area, direction n
    crossingArea += 0.5 * twiceArea.lpNorm<1>();
    volume += a.dot(b.cross(c)) / 6.0;
  }
  return std::abs(volume);
}

std::size_t clampToSize(double x) {
  const double top = static_cast<double>(std::numeric_limits<std::size_t>::max() / 2);
  return x >= top ? static_cast<std::size_t>(top) : static_cast<std::size_t>(std::max(x, 0.0));
}

// Reads the first number of a small system file, or -1.
double readNumber(const char* path) {
  std::ifstream in(path);
  double x = -1;
  if (!(in >> x)) return -1;
  return x;
}

// The estimate from what a model's grid depends on: the bounds of the model, its volume and
// the sum over its boundary of |n_x| + |n_y| + |n_z| dA (the area that crosses grid links).
MemoryEstimate estimateFromExtent(const std::array<Vec3d, 2>& bounds, double volume,
                                  double crossingArea, const MemoryEstimateParams& params);

}  // namespace

MemoryEstimate estimateModelMemory(const std::vector<MaterialMesh>& materials,
                                   const MemoryEstimateParams& params) {
  if (!usable(materials)) return {};
  // The bounds of the faces the voxelizer would take (TriangleMesh::bounds trusts every index;
  // a face with an index out of range is left to the voxelizer's own check).
  std::array<Vec3d, 2> bounds{Vec3d::Constant(std::numeric_limits<double>::infinity()),
                              Vec3d::Constant(-std::numeric_limits<double>::infinity())};
  for (const MaterialMesh& m : materials) {
    const int n = static_cast<int>(m.mesh.vertices.size());
    for (const auto& f : m.mesh.faces) {
      if (std::any_of(f.begin(), f.end(), [n](int i) { return i < 0 || i >= n; })) continue;
      for (const int i : f) {
        bounds[0] = bounds[0].cwiseMin(m.mesh.vertices[static_cast<std::size_t>(i)]);
        bounds[1] = bounds[1].cwiseMax(m.mesh.vertices[static_cast<std::size_t>(i)]);
      }
    }
  }
  if (!(bounds[0].array() <= bounds[1].array()).all()) return {};
  double crossingArea = 0.0, volume = 0.0;
  for (const MaterialMesh& m : materials) volume += surfaceAndVolume(m.mesh, crossingArea);
  return estimateFromExtent(bounds, volume, crossingArea, params);
}

MemoryEstimate estimateModelMemory(const LabelVolume& volume,
                                   const std::vector<LabelChoice>& labels,
                                   const MemoryEstimateParams& params) {
  const std::vector<LabelChoice> chosen = labels.empty() ? defaultLabelChoices(volume) : labels;
  std::vector<std::uint8_t> isChosen(volume.labels.size() + 1, 0);
  for (const LabelChoice& c : chosen)
    for (std::size_t l = 0; l < volume.labels.size(); ++l)
      if (volume.labels[l].value == c.value) isChosen[l + 1] = 1;
  // Chosen voxels, and the faces between chosen and other voxels along each axis.
  std::size_t voxels = 0;
  std::array<std::size_t, 3> faces{};
  const Index3 d = volume.dims;
  for (int k = 0; k < d.z; ++k)
    for (int j = 0; j < d.y; ++j)
      for (int i = 0; i < d.x; ++i) {
        const std::size_t v = volume.linear(i, j, k);
        const bool in = isChosen[volume.index[v]] != 0;
        voxels += in;
        const Index3 c{i, j, k};
        for (int a = 0; a < 3; ++a) {
          const bool last = c[a] + 1 >= d[a];
          const std::size_t next =
              a == 0 ? v + 1 : (a == 1 ? v + static_cast<std::size_t>(d.x)
                                       : v + static_cast<std::size_t>(d.x) * d.y);
          if (last ? in : in != (isChosen[volume.index[next]] != 0)) ++faces[a];
          if (c[a] == 0 && in) ++faces[a];
        }
      }
  if (voxels == 0) return {};
  const Vec3d spacing = volume.spacing();
  double crossingArea = 0.0;
  for (int a = 0; a < 3; ++a)
    crossingArea += static_cast<double>(faces[a]) * spacing[(a + 1) % 3] * spacing[(a + 2) % 3];
  return estimateFromExtent(labelBounds(volume, chosen),
                            static_cast<double>(voxels) * std::abs(volume.axes.determinant()),
                            crossingArea, params);
}

namespace {

MemoryEstimate estimateFromExtent(const std::array<Vec3d, 2>& bounds, double volume,
                                  double crossingArea, const MemoryEstimateParams& params) {
  MemoryEstimate e;
  e.frame = gridFrameFor(bounds, params.resolution, params.maxVoxels);
  const Index3 d = e.frame.dims;
  const double h = e.frame.voxelSize;
  e.resolution = std::max({d.x, d.y, d.z});

  const double n = static_cast<double>(d.x) * d.y * d.z;
  const double s = crossingArea / (h * h);
  const double interior =
      static_cast<double>(std::max(d.x - 2, 0)) * std::max(d.y - 2, 0) * std::max(d.z - 2, 0);
  const double v = std::min(interior, volume / (h * h * h) + s);
  const int finest = initialFinestLevel(std::clamp(params.elementLevel, 0, 7),
                                        std::clamp(params.surfaceLevel, -1, 7), e.resolution);
  const double cube = std::ldexp(1.0, finest);
  double elements = 1.0, nodes = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double cubes = std::ceil(std::max(d[a] - 2, 1) / cube);
    elements *= cubes;
    nodes *= cubes + 1.0;
  }

  double dense = kGridDense, occupied = 0.0, surface = kSurfaceLink;
  double element = 0.0, node = 0.0;
  if (params.octrees || params.cutting || params.simulation) {
    dense += kOctreeDense;
    const double activeShare = params.allActive ? 1.0 : 0.5;
    occupied += activeShare * (kActiveTables + (params.cutting ? kCuttingActive : 0.0));
    element = kElement;
    node = kNode;
  }
  double factor = 0.0;
  if (params.simulation) {
    surface += kSimulationSurfaceLink;
    element += kSimulationElement;
    node += kSimulationNode;
    if (params.factor) factor = kFactorBlocksPerNode43 * std::pow(nodes, 4.0 / 3.0) * kFactorBlock;
  }
  double one =
      n * dense + v * occupied + s * surface + elements * element + nodes * node + factor;
  // A world keeps a copy of itself to roll a failed step back (docs/architecture.md,
  // "Snapshots"): all of the above but the build's scratch.
  if (params.simulation)
    one += n * kKeptDense + v * occupied + s * kKeptSurfaceLink + elements * element +
           nodes * node + factor;
  e.gridVoxels = clampToSize(n);
  e.occupiedVoxels = clampToSize(v);
  e.surfaceLinks = clampToSize(s);
  e.elements = params.octrees || params.simulation ? clampToSize(elements) : 0;
  e.nodes = params.octrees || params.simulation ? clampToSize(nodes) : 0;
  e.bytes = clampToSize(std::max(params.copies, 1) * one);
  return e;
}

}  // namespace

std::size_t availableMemory() {
  double available = -1;
  {
    std::ifstream in("/proc/meminfo");
    std::string key;
    double kib = 0;
    std::string unit;
    while (in >> key >> kib) {
      std::getline(in, unit);
      if (key == "MemAvailable:") {
        available = kib * 1024.0;
        break;
      }
    }
  }
  if (available < 0) {
    const long pages = sysconf(_SC_AVPHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages > 0 && page > 0) available = static_cast<double>(pages) * static_cast<double>(page);
  }
  // A control group's limit ("max" reads as no number) binds before the machine's memory.
  const double limit = readNumber("/sys/fs/cgroup/memory.max");
  const double current = readNumber("/sys/fs/cgroup/memory.current");
  if (limit > 0 && current >= 0) {
    const double left = std::max(limit - current, 0.0);
    available = available < 0 ? left : std::min(available, left);
  }
  return available < 0 ? 0 : clampToSize(available);
}

std::size_t parseMemorySize(const std::string& text, const std::string& option) {
  const auto bad = [&]() {
    return InputError(option + " '" + text +
                      "': expected a size in bytes with an optional K, M, G or T suffix "
                      "(e.g. 512M, 8G)");
  };
  std::size_t used = 0;
  double x = 0;
  try {
    x = std::stod(text, &used);
  } catch (const std::exception&) {
    throw bad();
  }
  // No hexadecimal, infinities or signs: digits and a decimal point only.
  if (used == 0 || !std::all_of(text.begin(), text.begin() + static_cast<long>(used), [](char c) {
        return std::isdigit(static_cast<unsigned char>(c)) || c == '.';
      }))
    throw bad();
  std::string suffix = text.substr(used);
  std::transform(suffix.begin(), suffix.end(), suffix.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  double scale = 1.0;
  if (!suffix.empty() && std::string("KMGT").find(suffix[0]) != std::string::npos) {
    scale = std::ldexp(1.0, 10 * (1 + static_cast<int>(std::string("KMGT").find(suffix[0]))));
    suffix.erase(0, 1);
    if (suffix == "IB" || suffix == "B") suffix.clear();
  } else if (suffix == "B") {
    suffix.clear();
  }
  if (!suffix.empty()) throw bad();
  const double bytes = x * scale;
  if (!(bytes >= 1.0) || bytes > std::ldexp(1.0, 60))
    throw InputError(option + " '" + text + "': must be between 1 byte and 1 EiB");
  return static_cast<std::size_t>(bytes);
}

std::string formatBytes(std::size_t bytes) {
  static const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  double x = static_cast<double>(bytes);
  int u = 0;
  while (x >= 1024.0 && u < 6) {
    x /= 1024.0;
    ++u;
  }
  char text[32];
  if (u == 0)
    std::snprintf(text, sizeof text, "%zu B", bytes);
  else
    std::snprintf(text, sizeof text, x < 100 ? "%.1f %s" : "%.0f %s", x, units[u]);
  return text;
}

void checkMemory(const MemoryEstimate& estimate, std::size_t limit, const std::string& what) {
  if (limit == 0 || estimate.bytes <= limit) return;
  const Index3& d = estimate.frame.dims;
  std::ostringstream os;
  os << what << " needs about " << formatBytes(estimate.bytes) << " at resolution "
     << estimate.resolution << " (grid " << d.x << " x " << d.y << " x " << d.z
     << "); the limit is " << formatBytes(limit) << "; use --max-memory or a lower resolution";
  throw InputError(os.str());
}

}  // namespace voxcut
