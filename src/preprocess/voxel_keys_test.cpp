// The batch key kernel against the scalar key, bit for bit: random clouds at several voxel
// sizes, points on voxel boundaries on both sides of zero, far from the origin (coordinates
// up to the kernel's 2^50 limit), keys near 2^32, non-finite coordinates in each axis, and
// every tail length.

#include "preprocess/voxel_keys.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace locard::detail {
namespace {

// The grid of `points` at `voxel` as the voxel grid builds it (finite points only).
VoxelKeyGrid grid_of(const std::vector<Eigen::Vector3f>& points, double voxel,
                     Eigen::Vector3d* min_out = nullptr, Eigen::Vector3d* max_out = nullptr) {
  const double inverse = 1.0 / voxel;
  Eigen::Vector3d low = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d high = -low;
  for (const Eigen::Vector3f& p : points) {
    if (!p.allFinite()) continue;
    const Eigen::Vector3d v(std::floor(p.x() * inverse), std::floor(p.y() * inverse),
                            std::floor(p.z() * inverse));
    low = low.cwiseMin(v);
    high = high.cwiseMax(v);
  }
  const VoxelKeyGrid grid = VoxelKeyGrid::over(inverse, low, high - low + Eigen::Vector3d::Ones());
  if (min_out) *min_out = low;
  if (max_out) *max_out = high;
  return grid;
}

void expect_batch_equals_scalar(const std::vector<Eigen::Vector3f>& points, double voxel) {
  Eigen::Vector3d low, high;
  const VoxelKeyGrid grid = grid_of(points, voxel, &low, &high);
  ASSERT_TRUE(batch_keys_apply(grid, low, high)) << voxel;
  std::vector<std::uint32_t> batch(points.size() + 1, 0xDEADBEEF);
  voxel_keys_u32(grid, points.data(), points.size(), batch.data());
  EXPECT_EQ(batch.back(), 0xDEADBEEF) << "wrote past the end";
  for (std::size_t i = 0; i < points.size(); ++i) {
    ASSERT_EQ(batch[i], grid.key(points[i])) << "point " << i << " of " << points.size()
                                             << " at voxel " << voxel;
  }
}

TEST(VoxelKeys, BatchEqualsScalarOnRandomClouds) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(-4.f, 4.f);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 100001; ++i) points.emplace_back(u(rng), u(rng), u(rng));  // odd count
  for (const double voxel : {0.006, 0.01, 0.05, 0.37, 10.0}) {
    expect_batch_equals_scalar(points, voxel);
  }
}

TEST(VoxelKeys, BoundariesBothSidesOfZeroAndEveryTail) {
  std::vector<Eigen::Vector3f> points;
  for (int k = -40; k <= 40; ++k) {
    const float c = 0.25f * static_cast<float>(k);  // exact multiples of the voxel
    points.emplace_back(c, -c, std::nextafter(c, 0.f));
    points.emplace_back(std::nextafter(c, -1e9f), std::nextafter(c, 1e9f), -0.f);
  }
  for (std::size_t n = 0; n <= 9; ++n) {  // tails of every length, n = 0 included
    const std::vector<Eigen::Vector3f> prefix(points.begin(),
                                              points.begin() + static_cast<long>(n));
    if (n == 0) {
      std::uint32_t untouched = 7;
      voxel_keys_u32(grid_of(points, 0.25), prefix.data(), 0, &untouched);
      EXPECT_EQ(untouched, 7u);
      continue;
    }
    expect_batch_equals_scalar(prefix, 0.25);
  }
  expect_batch_equals_scalar(points, 0.25);
}

TEST(VoxelKeys, FarFromTheOriginAndKeysNear2To32) {
  // 1e6 m from the origin at 1 mm: voxel coordinates near 1e9, ~2^30 each way from zero.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.f, 60.f);
  std::vector<Eigen::Vector3f> far;
  for (int i = 0; i < 20001; ++i) {
    far.emplace_back(1e6f + u(rng), -1e6f + u(rng), 5e5f + 0.03f * u(rng));
  }
  expect_batch_equals_scalar(far, 0.06);
  // A grid whose keys reach almost 2^32 - 1 (the last voxel's key is the sentinel - 1).
  std::vector<Eigen::Vector3f> wide = {Eigen::Vector3f(0.f, 0.f, 0.f),
                                       Eigen::Vector3f(1023.5f, 2047.5f, 2046.5f)};
  for (int i = 0; i < 999; ++i) {
    wide.emplace_back(1023.f + 0.001f * i, 2047.f, 2046.f + 0.0005f * i);
  }
  const VoxelKeyGrid grid = grid_of(wide, 1.0);
  EXPECT_GT(grid.sentinel, 0xFF000000u);
  expect_batch_equals_scalar(wide, 1.0);
  // Voxel coordinates near the limit: 2^49 voxels from the origin.
  const std::vector<Eigen::Vector3f> edge = {Eigen::Vector3f(0x1p49f, 1.f, -0x1p49f),
                                             Eigen::Vector3f(0x1p49f + 0x1p26f, 3.f, -0x1p49f)};
  expect_batch_equals_scalar(edge, 1.0);
}

TEST(VoxelKeys, NonFiniteCoordinatesGiveTheSentinel) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<Eigen::Vector3f> points = {{0.1f, 0.2f, 0.3f}, {1.f, 2.f, 3.f}};
  for (const float bad : {nan, inf, -inf}) {
    points.emplace_back(bad, 0.5f, 0.5f);
    points.emplace_back(0.5f, bad, 0.5f);
    points.emplace_back(0.5f, 0.5f, bad);
    points.emplace_back(0.7f, 0.7f, 0.7f);
  }
  points.emplace_back(inf, -inf, 0.f);  // inf - inf in the finiteness sum
  const VoxelKeyGrid grid = grid_of(points, 0.1);
  std::vector<std::uint32_t> batch(points.size());
  voxel_keys_u32(grid, points.data(), points.size(), batch.data());
  std::size_t sentinels = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(batch[i], grid.key(points[i])) << i;
    sentinels += batch[i] == grid.sentinel;
  }
  EXPECT_EQ(sentinels, 10u);
}

TEST(VoxelKeys, BatchDoesNotApplyBeyondItsLimits) {
  VoxelKeyGrid grid;
  grid.sentinel = 1000;
  EXPECT_TRUE(batch_keys_apply(grid, Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(9.0)));
  EXPECT_FALSE(batch_keys_apply(grid, Eigen::Vector3d::Zero(), Eigen::Vector3d(0x1p50, 0.0, 0.0)));
  EXPECT_FALSE(batch_keys_apply(grid, Eigen::Vector3d(0.0, -0x1p51, 0.0), Eigen::Vector3d::Zero()));
  grid.sentinel = std::uint64_t{1} << 32;
  EXPECT_FALSE(batch_keys_apply(grid, Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(9.0)));
}

}  // namespace
}  // namespace locard::detail
