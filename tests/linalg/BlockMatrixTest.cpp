// One row's block product (linalg/BlockMatrix.h) with double and with single-precision blocks:
// both against a plain sum of Eigen products, the single-precision one on the blocks rounded
// to float and summed in double.

#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include "voxcut/linalg/BlockMatrix.h"

namespace voxcut {
namespace {

TEST(BlockRowProduct, DoubleAndFloatBlocksMatchEigenProducts) {
  std::srand(7);
  const std::size_t slots = 11;
  std::vector<Eigen::Matrix3d> blocks(slots);
  std::vector<Eigen::Matrix3f> floats(slots);
  std::vector<std::uint32_t> column(slots);
  std::vector<Vec3d> x(5);
  for (Vec3d& v : x) v = Vec3d::Random() * 3.0;
  for (std::size_t k = 0; k < slots; ++k) {
    blocks[k] = Eigen::Matrix3d::Random();
    floats[k] = blocks[k].cast<float>();
    column[k] = static_cast<std::uint32_t>((3 * k + 1) % x.size());
  }
  for (std::uint32_t begin : {0u, 3u})
    for (std::uint32_t end : {begin, begin + 1, static_cast<std::uint32_t>(slots)}) {
      Vec3d expectDouble = Vec3d::Zero(), expectFloat = Vec3d::Zero();
      for (std::uint32_t k = begin; k < end; ++k) {
        expectDouble += blocks[k] * x[column[k]];
        expectFloat += floats[k].cast<double>() * x[column[k]];
      }
      const Vec3d d = blockRowProduct(blocks.data(), column.data(), x.data(), begin, end);
      const Vec3d f = blockRowProduct(floats.data(), column.data(), x.data(), begin, end);
      EXPECT_LE((d - expectDouble).norm(), 1e-13) << begin << " " << end;
      // Summed in double: only the order of the sums differs, not the precision.
      EXPECT_LE((f - expectFloat).norm(), 1e-13) << begin << " " << end;
    }
}

}  // namespace
}  // namespace voxcut
