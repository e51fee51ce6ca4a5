#pragma once
/// @file VoxelGrid.h
/// The linked voxel model (docs/algorithms.md, "Linked voxel model"): a uniform grid of
/// voxels, each empty (material 0) or holding a material, joined to its +x, +y, +z neighbours by
/// links that are connected or disconnected, with Hermite data on links crossed by a surface, an
/// interface or a cut.
///
/// Conventions: voxel index v = x + nx*(y + ny*z); link id 3*v + axis joins v and v + e_axis;
/// voxel v's centre is at origin + voxelSize * (x, y, z) in the rest frame (metres).
/// Memory: 2 bytes per voxel plus 24 bytes per Hermite entry (about 0.7 of the load factor).

#include <array>
#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "voxcut/core/Error.h"
#include "voxcut/core/Types.h"
#include "voxcut/voxel/HermiteMap.h"

namespace voxcut {

/// Link flag bits, stored per voxel for its three links.
enum LinkBits : std::uint8_t {
  kConnectedX = 1u << 0,
  kConnectedY = 1u << 1,
  kConnectedZ = 1u << 2,
};

/// The linked voxel grid. Owns its arrays; copyable on purpose (tests compare copies).
class VoxelGrid {
 public:
  VoxelGrid() = default;
  /// An all-empty grid of dims[0] x dims[1] x dims[2] voxels. Throws InputError when it would
  /// exceed `maxVoxels`.
  VoxelGrid(const Index3& dims, const Vec3d& origin, double voxelSize,
            std::size_t maxVoxels = kDefaultMaxVoxels);

  static constexpr std::size_t kDefaultMaxVoxels = std::size_t{1} << 30;

  [[nodiscard]] const Index3& dims() const { return dims_; }
  [[nodiscard]] const Vec3d& origin() const { return origin_; }
  [[nodiscard]] double voxelSize() const { return voxelSize_; }
  [[nodiscard]] std::size_t voxelCount() const { return material_.size(); }

  /// Linear index of voxel (x, y, z); no bounds check.
  [[nodiscard]] std::size_t index(int x, int y, int z) const {
    return static_cast<std::size_t>(x) +
           static_cast<std::size_t>(dims_.x) *
               (static_cast<std::size_t>(y) +
                static_cast<std::size_t>(dims_.y) * static_cast<std::size_t>(z));
  }
  [[nodiscard]] std::size_t index(const Index3& c) const { return index(c.x, c.y, c.z); }
  /// Grid coordinates of voxel v.
  [[nodiscard]] Index3 coord(std::size_t v) const {
    const auto nx = static_cast<std::size_t>(dims_.x), ny = static_cast<std::size_t>(dims_.y);
    return {static_cast<int>(v % nx), static_cast<int>((v / nx) % ny),
            static_cast<int>(v / (nx * ny))};
  }
  /// Linear-index step along axis a.
  [[nodiscard]] std::size_t stride(int a) const {
    return a == 0
               ? 1
               : (a == 1 ? static_cast<std::size_t>(dims_.x)
                         : static_cast<std::size_t>(dims_.x) * static_cast<std::size_t>(dims_.y));
  }
  /// Rest position of voxel v's centre (metres).
  [[nodiscard]] Vec3d position(std::size_t v) const {
    const Index3 c = coord(v);
    return origin_ + voxelSize_ * Vec3d(c.x, c.y, c.z);
  }

  /// Material of voxel v (0 = empty).
  [[nodiscard]] std::uint8_t material(std::size_t v) const { return material_[v]; }
  [[nodiscard]] bool occupied(std::size_t v) const { return material_[v] != 0; }
  void setMaterial(std::size_t v, std::uint8_t m) { material_[v] = m; }

  /// Link id of the link from v along axis a.
  [[nodiscard]] static std::uint64_t linkId(std::size_t v, int a) {
    return 3 * static_cast<std::uint64_t>(v) + static_cast<std::uint64_t>(a);
  }
  /// Whether the link from v along axis a is connected.
  [[nodiscard]] bool connected(std::size_t v, int a) const { return (links_[v] >> a) & 1u; }
  void setConnected(std::size_t v, int a, bool on) {
    if (on)
      links_[v] = static_cast<std::uint8_t>(links_[v] | (1u << a));
    else
      links_[v] = static_cast<std::uint8_t>(links_[v] & ~(1u << a));
  }
  /// connected() and a disconnection for threads that share the link bytes (one byte holds a
  /// voxel's three links, so neighbouring links share it): atomic, relaxed. The disconnection
  /// says whether this call found the link connected.
  [[nodiscard]] bool connectedShared(std::size_t v, int a) const {
    return (std::atomic_ref<std::uint8_t>(const_cast<std::uint8_t&>(links_[v]))
                .load(std::memory_order_relaxed) >>
            a) &
           1u;
  }
  bool disconnectShared(std::size_t v, int a) {
    const auto bit = static_cast<std::uint8_t>(1u << a);
    return (std::atomic_ref<std::uint8_t>(links_[v]).fetch_and(static_cast<std::uint8_t>(~bit),
                                                               std::memory_order_relaxed) &
            bit) != 0;
  }
  /// Whether voxel v has a neighbour along +a inside the grid.
  [[nodiscard]] bool hasLink(std::size_t v, int a) const { return coord(v)[a] + 1 < dims_[a]; }

  /// Hermite data of links (surface, interface, cut).
  [[nodiscard]] const HermiteMap& hermite() const { return hermite_; }
  HermiteMap& hermite() { return hermite_; }

  /// Names of materials 1..N (index 0 is material 1).
  [[nodiscard]] const std::vector<std::string>& materialNames() const { return materialNames_; }
  void setMaterialNames(std::vector<std::string> names) { materialNames_ = std::move(names); }
  /// Display colours of materials 1..N (RGB in [0, 1]) where the model gave some (a label
  /// volume's segment colours); empty, or an entry without a value, where it did not.
  [[nodiscard]] const std::vector<std::optional<std::array<float, 3>>>& materialColours() const {
    return materialColours_;
  }
  void setMaterialColours(std::vector<std::optional<std::array<float, 3>>> colours) {
    materialColours_ = std::move(colours);
  }

  /// Bytes held by the grid (voxels, links, Hermite data).
  [[nodiscard]] std::size_t bytes() const {
    return material_.capacity() + links_.capacity() + hermite_.bytes();
  }

  /// Raw arrays, for bulk parallel fills.
  std::uint8_t* materialData() { return material_.data(); }
  std::uint8_t* linkData() { return links_.data(); }

 private:
  Index3 dims_;
  Vec3d origin_ = Vec3d::Zero();
  double voxelSize_ = 1.0;
  std::vector<std::uint8_t> material_;
  std::vector<std::uint8_t> links_;
  HermiteMap hermite_;
  std::vector<std::string> materialNames_;
  std::vector<std::optional<std::array<float, 3>>> materialColours_;
};

}  // namespace voxcut
