// Voxel-grid down-sampling against a brute-force std::map reference, bit for bit.

#include <locard/core/error.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <tuple>

namespace locard {
namespace {

// The reference: a std::map keyed by the voxel coordinates floor(p * (1 / voxel_size)) (in
// double, as documented), sums in double in input order; std::map's (x, y, z) lexicographic order is
// the documented output order.
VoxelGridResult brute_force_voxel_grid(const PointCloud& cloud, float voxel_size) {
  struct Sum {
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    Eigen::Vector3f first_normal = Eigen::Vector3f::Zero();
    std::uint64_t r = 0, g = 0, b = 0;
    std::vector<double> scalars;
    std::uint32_t count = 0;
  };
  std::map<std::tuple<double, double, double>, Sum> voxels;
  VoxelGridResult result;
  result.report.input_points = cloud.size();
  const double inverse = 1.0 / static_cast<double>(voxel_size);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.positions[i];
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) {
      ++result.report.non_finite;
      continue;
    }
    Sum& sum = voxels[{std::floor(p.x() * inverse), std::floor(p.y() * inverse),
                       std::floor(p.z() * inverse)}];
    if (sum.count == 0 && cloud.has_normals()) sum.first_normal = cloud.normals[i];
    ++sum.count;
    sum.position += p.cast<double>();
    if (cloud.has_normals()) sum.normal += cloud.normals[i].cast<double>();
    if (cloud.has_colors()) {
      sum.r += cloud.colors[i].r;
      sum.g += cloud.colors[i].g;
      sum.b += cloud.colors[i].b;
    }
    sum.scalars.resize(cloud.scalars.size(), 0.0);
    for (std::size_t f = 0; f < cloud.scalars.size(); ++f) sum.scalars[f] += cloud.scalars[f].values[i];
  }
  PointCloud& out = result.cloud;
  for (const ScalarField& f : cloud.scalars) out.scalars.push_back(ScalarField{f.name, {}});
  for (const auto& [key, sum] : voxels) {
    const double n = sum.count;
    out.positions.push_back((sum.position / n).cast<float>());
    if (cloud.has_normals()) {
      out.normals.push_back(sum.normal.norm() > 0.0 ? (sum.normal / sum.normal.norm()).cast<float>()
                                                    : sum.first_normal);
    }
    if (cloud.has_colors()) {
      const auto mean = [n](std::uint64_t s) {
        return static_cast<std::uint8_t>(std::lround(static_cast<double>(s) / n));
      };
      out.colors.push_back(Rgb8{mean(sum.r), mean(sum.g), mean(sum.b)});
    }
    for (std::size_t f = 0; f < cloud.scalars.size(); ++f) {
      out.scalars[f].values.push_back(static_cast<float>(sum.scalars[f] / n));
    }
    result.points_per_voxel.push_back(sum.count);
  }
  result.report.output_points = voxels.size();
  return result;
}

PointCloud random_cloud(std::size_t n, std::uint32_t seed, float extent) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-extent, extent);
  std::uniform_int_distribution<int> byte(0, 255);
  PointCloud cloud;
  ScalarField intensity{"intensity", {}};
  for (std::size_t i = 0; i < n; ++i) {
    cloud.positions.emplace_back(u(rng), u(rng), u(rng) + 3.f);
    cloud.normals.push_back(Eigen::Vector3f(u(rng), u(rng), u(rng)).normalized());
    cloud.colors.push_back(Rgb8{static_cast<std::uint8_t>(byte(rng)),
                                static_cast<std::uint8_t>(byte(rng)),
                                static_cast<std::uint8_t>(byte(rng))});
    intensity.values.push_back(u(rng));
  }
  cloud.scalars.push_back(intensity);
  return cloud;
}

void expect_identical(const VoxelGridResult& a, const VoxelGridResult& b) {
  EXPECT_EQ(a.cloud.positions, b.cloud.positions);
  EXPECT_EQ(a.cloud.normals, b.cloud.normals);
  EXPECT_EQ(a.cloud.colors, b.cloud.colors);
  EXPECT_EQ(a.cloud.scalars, b.cloud.scalars);
  EXPECT_EQ(a.points_per_voxel, b.points_per_voxel);
  EXPECT_EQ(a.report.input_points, b.report.input_points);
  EXPECT_EQ(a.report.non_finite, b.report.non_finite);
  EXPECT_EQ(a.report.output_points, b.report.output_points);
}

TEST(VoxelGrid, EqualsBruteForceReferenceOnRandomCloud) {
  const PointCloud cloud = random_cloud(200000, 1, 2.f);
  for (float voxel : {0.02f, 0.1f, 0.37f, 5.f}) {
    const VoxelGridResult expected = brute_force_voxel_grid(cloud, voxel);
    const VoxelGridResult actual = voxel_down_sample(cloud, voxel);
    SCOPED_TRACE(voxel);
    expect_identical(actual, expected);
    EXPECT_EQ(actual.report.output_points, actual.cloud.size());
  }
}

TEST(VoxelGrid, PointsOnVoxelBoundariesAndNegativeCoordinates) {
  // Coordinates that are exact multiples of the voxel size, on both sides of zero.
  PointCloud cloud;
  for (int x = -4; x <= 4; ++x) {
    for (int y = -4; y <= 4; ++y) {
      cloud.positions.emplace_back(0.25f * x, 0.25f * y, -0.5f);
      cloud.positions.emplace_back(0.25f * x + 0.1f, 0.25f * y, -0.5f);
    }
  }
  const VoxelGridResult actual = voxel_down_sample(cloud, 0.25f);
  expect_identical(actual, brute_force_voxel_grid(cloud, 0.25f));
  EXPECT_EQ(actual.cloud.size(), 81u);
}

TEST(VoxelGrid, NonFinitePointsAreDroppedAndCounted) {
  PointCloud cloud = random_cloud(1000, 2, 1.f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  cloud.positions[0] = Eigen::Vector3f(nan, 0.f, 0.f);
  cloud.positions[10] = Eigen::Vector3f(0.f, inf, 0.f);
  cloud.positions[999] = Eigen::Vector3f(0.f, 0.f, -inf);
  const VoxelGridResult actual = voxel_down_sample(cloud, 0.1f);
  EXPECT_EQ(actual.report.non_finite, 3u);
  EXPECT_EQ(actual.report.input_points, 1000u);
  expect_identical(actual, brute_force_voxel_grid(cloud, 0.1f));
  std::uint64_t total = 0;
  for (auto c : actual.points_per_voxel) total += c;
  EXPECT_EQ(total, 997u);
}

TEST(VoxelGrid, EmptyAndAllNonFiniteClouds) {
  EXPECT_TRUE(voxel_down_sample(PointCloud{}, 0.1f).cloud.empty());
  PointCloud bad;
  bad.positions.assign(5, Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  const VoxelGridResult r = voxel_down_sample(bad, 0.1f);
  EXPECT_TRUE(r.cloud.empty());
  EXPECT_EQ(r.report.non_finite, 5u);
}

TEST(VoxelGrid, OppositeNormalsInOneVoxelKeepTheFirst) {
  PointCloud cloud;
  cloud.positions = {Eigen::Vector3f(0.01f, 0.01f, 0.01f), Eigen::Vector3f(0.02f, 0.02f, 0.02f)};
  cloud.normals = {Eigen::Vector3f::UnitX(), -Eigen::Vector3f::UnitX()};
  const VoxelGridResult r = voxel_down_sample(cloud, 1.f);
  ASSERT_EQ(r.cloud.size(), 1u);
  EXPECT_EQ(r.cloud.normals[0], Eigen::Vector3f::UnitX());
}

TEST(VoxelGrid, SparseHugeGridUses64BitKeys) {
  // 1e6 voxels per axis: 10^18 voxels do not fit 32-bit keys.
  PointCloud cloud = random_cloud(5000, 3, 500.f);
  cloud.positions.push_back(cloud.positions[17]);  // a duplicate
  cloud.normals.push_back(cloud.normals[17]);
  cloud.colors.push_back(cloud.colors[17]);
  cloud.scalars[0].values.push_back(1.f);
  const VoxelGridResult actual = voxel_down_sample(cloud, 0.001f);
  expect_identical(actual, brute_force_voxel_grid(cloud, 0.001f));
  EXPECT_EQ(actual.cloud.size(), 5000u);
}

TEST(VoxelGrid, FarCoordinatesUseTheScalarKeys) {
  // Voxel coordinates beyond 2^50 (where the batch kernel's floor stops being exact), in a
  // grid small enough for 32-bit keys: the scalar path, still equal to the reference. (Floats
  // that far out are 2^28 m apart, so the cloud is one slab at one x.)
  PointCloud cloud = random_cloud(3000, 9, 1.f);
  for (Eigen::Vector3f& p : cloud.positions) p.x() = 3e15f;
  const VoxelGridResult actual = voxel_down_sample(cloud, 0.05f);
  expect_identical(actual, brute_force_voxel_grid(cloud, 0.05f));
  EXPECT_GT(actual.cloud.size(), 1000u);
}

TEST(VoxelGrid, SameBitsWithOneThread) {
  const PointCloud cloud = random_cloud(300000, 4, 3.f);
  const VoxelGridResult parallel = voxel_down_sample(cloud, 0.05f);
  tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
  expect_identical(voxel_down_sample(cloud, 0.05f), parallel);
}

// A large cloud (more voxels than the cache holds, several key ranges): the same bits as the
// reference with any thread count, with and without normals and scalars, and with non-finite
// points in the middle.
TEST(VoxelGrid, LargeCloudSameBitsAsReferenceWithAnyThreadCount) {
  PointCloud cloud = random_cloud(700000, 6, 2.f);
  for (std::size_t i = 0; i < cloud.size(); i += 9973)
    cloud.positions[i].y() = std::numeric_limits<float>::quiet_NaN();
  for (const float voxel : {0.01f, 0.2f}) {
    const VoxelGridResult parallel = voxel_down_sample(cloud, voxel);
    expect_identical(parallel, brute_force_voxel_grid(cloud, voxel));
    EXPECT_EQ(parallel.report.non_finite, 71u);
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    expect_identical(voxel_down_sample(cloud, voxel), parallel);
  }
  PointCloud plain;  // positions and colours only
  plain.positions = cloud.positions;
  plain.colors = cloud.colors;
  expect_identical(voxel_down_sample(plain, 0.05f), brute_force_voxel_grid(plain, 0.05f));
}

// Mean colours at and around every half-integer: the kernel rounds without libm, and must give
// lround's integer (half away from zero) for any count.
TEST(VoxelGrid, ColourMeansRoundLikeLround) {
  PointCloud cloud;
  float x = 0.5f;  // one voxel per (count, sum), voxels of 1 m along x
  const auto add_voxel = [&](int count, int sum) {
    for (int k = 0; k < count; ++k) {
      const int value = std::min(sum, 255);  // the sum spread over the points
      sum -= value;
      cloud.positions.emplace_back(x, 0.5f, 0.5f);
      cloud.colors.push_back(Rgb8{static_cast<std::uint8_t>(value), 0, 255});
    }
    x += 1.f;
  };
  for (int count = 1; count <= 8; ++count) {
    for (int sum = 0; sum <= 255 * count; ++sum) add_voxel(count, sum);
  }
  for (const int count : {100, 1001, 20001, 65536}) {
    for (const int k : {0, 1, 127, 253, 254}) {
      if (count == 65536 && k != 127) continue;
      const int half = (2 * k + 1) * count / 2;  // the sums nearest k + 1/2
      for (int sum = half - 1; sum <= half + 1; ++sum) add_voxel(count, sum);
    }
  }
  expect_identical(voxel_down_sample(cloud, 1.f), brute_force_voxel_grid(cloud, 1.f));
}

// Tables are sized from an estimate of the voxel count split by the ranges' point counts; here
// one range holds nearly all the voxels, so its table must grow while it fills.
TEST(VoxelGrid, TablesGrowWhenARangeHasMoreVoxelsThanExpected) {
  PointCloud cloud = random_cloud(200000, 8, 1.f);  // ~200k voxels at 5 mm, x in [-1, 1]
  for (std::size_t i = 0; i < 200000; ++i) {       // as many points in 8 voxels at x ~ 5
    cloud.positions.emplace_back(5.f + 0.001f * (i % 2), 0.001f * (i % 4), 3.f + 0.001f * (i % 8));
    cloud.normals.push_back(cloud.normals[i]);
    cloud.colors.push_back(cloud.colors[i]);
    cloud.scalars[0].values.push_back(cloud.scalars[0].values[i]);
  }
  const VoxelGridResult expected = brute_force_voxel_grid(cloud, 0.005f);
  for (const int threads : {1, 2, 4}) {
    tbb::task_arena arena(threads);  // one key range per thread
    SCOPED_TRACE(threads);
    arena.execute([&] { expect_identical(voxel_down_sample(cloud, 0.005f), expected); });
  }
}

TEST(VoxelGrid, RejectsBadVoxelSizes) {
  const PointCloud cloud = random_cloud(10, 5, 1.f);
  EXPECT_THROW(voxel_down_sample(cloud, 0.f), InputError);
  EXPECT_THROW(voxel_down_sample(cloud, -1.f), InputError);
  EXPECT_THROW(voxel_down_sample(cloud, std::numeric_limits<float>::quiet_NaN()), InputError);
  EXPECT_THROW(voxel_down_sample(cloud, 1e-7f), InputError);  // 2e7 voxels along an axis
  PointCloud far;  // one voxel wide, but 1e33 voxels from the origin
  far.positions.assign(2, Eigen::Vector3f(1e30f, 0.f, 0.f));
  EXPECT_THROW(voxel_down_sample(far, 1e-3f), InputError);
}

}  // namespace
}  // namespace locard
