#pragma once
/// @file MemoryEstimate.h
/// How much memory a model will take before it is built, so that a request far beyond the
/// machine (a box at resolution 1024 needs about 40 GiB) is refused at once with a clear line
/// instead of paging or dying half-way. The estimate reads only the meshes' bounds, areas and
/// volumes and the grid frame they imply (O(#faces), well under a second for any mesh the
/// readers take); nothing grid-sized is allocated.
///
/// The formula. With the grid frame of voxelize (GridFrame.h) and h its voxel size:
///   N = nx ny nz                      grid voxels (padding included)
///   S = sum over faces of (|nx| + |ny| + |nz|) area / h^2
///                                     surface links: the crossings of the faces with the
///                                     grid lines (exact for one plane; Hermite entries,
///                                     surface vertices and quads are about one per crossing)
///   V = min((nx-2)(ny-2)(nz-2), sum over materials of |signed volume| / h^3 + S)
///                                     occupied voxels, an upper bound
///   E = prod_a ceil((n_a - 2) / 2^L), P = prod_a (ceil((n_a - 2) / 2^L) + 1)
///                                     elements and nodes of the deformation octree at start
///                                     level L (every cube occupied: an upper bound before
///                                     cuts refine it)
///   bytes = copies * (N * dense + V * occupied + S * surface + E * element + P * node)
///           + factor
/// with the per-item sizes below (bytes), read off the data structures:
///   dense per grid voxel: VoxelGrid material and link bits (2) and the largest build
///     scratch (inside flags, contour bits and ordinals, piece labels: 10); with the octrees
///     the voxel octree's cube map, state and active index (9, plus 1 of build flags) and the
///     deformation octree's voxel embedding (8, plus 8 of build scratch);
///   per occupied voxel, with the octrees: the active voxel table and its neighbours (16) and
///     the spare copy a rebuild keeps (20), for every occupied voxel in the baseline and half
///     of them with the octree; when cutting, per active voxel also its position (24),
///     embedding (8) and mark (1);
///   per surface link: Hermite entry at the table's lowest load (48), voxelizer staging and
///     crossings (40), surface vertex (56), two triangles (24), topology check (132) = 300;
///     a simulation adds its contoured surface's records, vertex embeddings and positions and
///     the exported mesh (400);
///   per element: the octree element and cube index (100); a simulation adds the element
///     matrices (24 x 24 stiffness and lumped masses, 4,752) and assembly sources (1,150);
///   per node: positions and flags (100); a simulation adds its masses, velocities, and about
///     27 3x3 blocks of the reduced matrix with their sparsity (2,900);
///   factor (a simulation with the Cholesky preconditioner): 4 P^(4/3) 3x3 blocks of 80
///     bytes, the fill of a sparse factor of a 3-D mesh.
///   a simulation also keeps a copy of its world to roll a failed step back: all of the above
///     but the build's scratch (19 per grid voxel, 528 per surface link).
/// Each size is what the structure holds at its largest for the model as it is built. Cuts
/// refine and duplicate elements as a scene runs, which the estimate does not foresee: the
/// peak of a cutting scene can exceed it (by up to about 1.6x on the shipped scenes,
/// docs/performance.md, "Input and limits"); running out of memory later still ends with one
/// error line and exit 2.
///
/// Thread-safety: pure functions, except availableMemory, which reads the system.

#include <cstddef>
#include <string>
#include <vector>

#include "voxcut/core/TriangleMesh.h"
#include "voxcut/voxel/GridFrame.h"
#include "voxcut/voxel/LabelResample.h"
#include "voxcut/voxel/LabelVolume.h"
#include "voxcut/voxel/VoxelGrid.h"

namespace voxcut {

/// What is built from the meshes.
struct MemoryEstimateParams {
  Resolution resolution;                                 ///< as given to voxelize
  std::size_t maxVoxels = VoxelGrid::kDefaultMaxVoxels;  ///< as given to voxelize
  bool octrees = true;      ///< the voxel octree and the deformation octree
  bool cutting = false;     ///< a CutBody: per active voxel positions and embeddings
  bool allActive = false;   ///< the baseline: every occupied voxel active
  bool simulation = false;  ///< element matrices, solver, contoured surface (sim/World)
  bool factor = false;      ///< with simulation: a sparse Cholesky factor
  int elementLevel = 3;     ///< start level of the deformation octree, 0..7
  /// Its surface level (DeformationOctreeParams::surfaceLevel; -1: the default for the grid):
  /// elements are counted at the level of the finest the build starts with.
  int surfaceLevel = -1;
  int copies = 1;  ///< models held at once (a benchmark's octree and baseline bodies)
};

/// The estimate and the figures it came from.
struct MemoryEstimate {
  std::size_t bytes = 0;           ///< the estimate; 0 when the meshes are unusable (see below)
  GridFrame frame;                 ///< the grid voxelize would make
  int resolution = 0;              ///< voxels along the longest side, padding included
  std::size_t gridVoxels = 0;      ///< N
  std::size_t occupiedVoxels = 0;  ///< V, an upper bound
  std::size_t surfaceLinks = 0;    ///< S
  std::size_t elements = 0;        ///< E
  std::size_t nodes = 0;           ///< P
};

/// Estimates the memory that voxelizing `materials` and building what `params` asks for will
/// take (file comment). Meshes that voxelize would refuse (no faces, non-finite coordinates,
/// bad indices) give bytes 0, so that voxelize reports them; faces with bad indices are
/// skipped. Throws InputError when the grid frame cannot be made (gridFrameFor: a resolution
/// below 3, a grid over maxVoxels).
[[nodiscard]] MemoryEstimate estimateModelMemory(const std::vector<MaterialMesh>& materials,
                                                 const MemoryEstimateParams& params);

/// The same for a label volume resampled with `labels` chosen (empty: all): bounds, volume and
/// boundary from the chosen voxels. 0 bytes when no voxel holds a chosen label. Linear in the
/// volume's voxels.
[[nodiscard]] MemoryEstimate estimateModelMemory(const LabelVolume& volume,
                                                 const std::vector<LabelChoice>& labels,
                                                 const MemoryEstimateParams& params);

/// Memory the program may still take (bytes): /proc/meminfo's MemAvailable, lowered to what
/// the control group leaves (memory.max - memory.current) when it is limited; the free
/// physical pages (sysconf) where /proc is missing; 0 when nothing says.
[[nodiscard]] std::size_t availableMemory();

/// Reads a memory size: a number of bytes with an optional suffix K, M, G or T (powers of
/// 1024, case-insensitive, optionally followed by "B" or "iB"): "512M", "8G", "1.5G",
/// "1048576". Throws InputError naming `option` for anything else, for 0 and for sizes over
/// 2^60 bytes.
[[nodiscard]] std::size_t parseMemorySize(const std::string& text, const std::string& option);

/// Bytes for people: "812 B", "3.4 KiB", "41.3 GiB" (three significant digits at most).
[[nodiscard]] std::string formatBytes(std::size_t bytes);

/// Throws InputError when `estimate` exceeds `limit` (bytes; 0: no limit):
/// "<what> needs about 41.3 GiB at resolution 1024 (grid 1024 x 1024 x 1024); the limit is
/// 23.1 GiB; use --max-memory or a lower resolution".
void checkMemory(const MemoryEstimate& estimate, std::size_t limit, const std::string& what);

}  // namespace voxcut
