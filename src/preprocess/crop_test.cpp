// Crops and point selection: every kept set equals a brute-force predicate; NaN/Inf counted.

#include <locard/core/error.hpp>
#include <locard/preprocess/crop.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace locard {
namespace {

PointCloud random_cloud(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-2.f, 2.f);
  PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    cloud.positions.emplace_back(u(rng), u(rng), u(rng) + 2.5f);
    cloud.colors.push_back(Rgb8{static_cast<std::uint8_t>(i % 256), 0, 0});
  }
  cloud.scalars.push_back(ScalarField{"id", {}});
  for (std::size_t i = 0; i < n; ++i) cloud.scalars[0].values.push_back(static_cast<float>(i));
  return cloud;
}

template <typename Keep>
std::vector<std::uint32_t> brute_force(const PointCloud& cloud, const Keep& keep) {
  std::vector<std::uint32_t> kept;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.positions[i].allFinite() && keep(cloud.positions[i])) {
      kept.push_back(static_cast<std::uint32_t>(i));
    }
  }
  return kept;
}

void expect_consistent(const PointCloud& input, const FilterResult& result) {
  ASSERT_EQ(result.cloud.size(), result.indices.size());
  EXPECT_EQ(result.report.input_points, input.size());
  EXPECT_EQ(result.report.output_points, result.indices.size());
  EXPECT_EQ(result.report.output_points + result.report.rejected + result.report.non_finite,
            input.size());
  for (std::size_t k = 0; k < result.indices.size(); ++k) {
    const std::uint32_t i = result.indices[k];
    ASSERT_EQ(result.cloud.positions[k], input.positions[i]);
    if (input.has_colors()) {
      ASSERT_EQ(result.cloud.colors[k], input.colors[i]);
    }
    for (std::size_t f = 0; f < input.scalars.size(); ++f) {
      ASSERT_EQ(result.cloud.scalars[f].values[k], input.scalars[f].values[i]);
    }
  }
}

TEST(PointSelection, SelectKeepsEveryAttributeInTheGivenOrder) {
  PointCloud cloud = random_cloud(10, 1);
  cloud.normals.assign(10, Eigen::Vector3f::UnitZ());
  cloud.normals[7] = Eigen::Vector3f::UnitX();
  const std::vector<std::uint32_t> indices{7, 2, 7};
  const PointCloud out = select_points(cloud, indices);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out.positions[0], cloud.positions[7]);
  EXPECT_EQ(out.positions[1], cloud.positions[2]);
  EXPECT_EQ(out.normals[0], Eigen::Vector3f::UnitX());
  EXPECT_EQ(out.colors[2], cloud.colors[7]);
  EXPECT_EQ(out.scalars[0].values, (std::vector<float>{7.f, 2.f, 7.f}));
  EXPECT_NO_THROW(out.check_consistent());
}

TEST(PointSelection, RemoveNonFiniteCountsWhatItDrops) {
  PointCloud cloud = random_cloud(100, 2);
  cloud.positions[3].x() = std::numeric_limits<float>::quiet_NaN();
  cloud.positions[50].z() = -std::numeric_limits<float>::infinity();
  const FilterResult r = remove_non_finite(cloud);
  EXPECT_EQ(r.report.non_finite, 2u);
  EXPECT_EQ(r.report.rejected, 0u);
  EXPECT_EQ(r.cloud.size(), 98u);
  expect_consistent(cloud, r);
  PointCloud broken = cloud;
  broken.colors.pop_back();
  EXPECT_THROW(remove_non_finite(broken), Error);
}

TEST(Crop, AxisAlignedBoxEqualsPredicateInsideAndOutside) {
  PointCloud cloud = random_cloud(20000, 3);
  cloud.positions[5] = Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f);
  cloud.positions[6] = Eigen::Vector3f(-1.f, 0.5f, 2.f);  // exactly on the min corner's faces
  const AxisAlignedBox box{Eigen::Vector3f(-1.f, -0.5f, 2.f), Eigen::Vector3f(1.f, 0.5f, 3.f)};
  const FilterResult inside = crop_box(cloud, box);
  EXPECT_EQ(inside.indices, brute_force(cloud, [&](const Eigen::Vector3f& p) {
              return p.x() >= -1.f && p.x() <= 1.f && p.y() >= -0.5f && p.y() <= 0.5f &&
                     p.z() >= 2.f && p.z() <= 3.f;
            }));
  EXPECT_EQ(inside.report.non_finite, 1u);
  EXPECT_NE(std::find(inside.indices.begin(), inside.indices.end(), 6u), inside.indices.end());
  expect_consistent(cloud, inside);
  const FilterResult outside = crop_box(cloud, box, false);
  EXPECT_EQ(outside.indices.size() + inside.indices.size() + 1, cloud.size());
  expect_consistent(cloud, outside);
}

TEST(Crop, OrientedBoxRotatedAboutZ) {
  PointCloud cloud = random_cloud(20000, 4);
  OrientedBox box;
  box.T_world_box = Isometry3d::Identity();
  box.T_world_box.translate(Eigen::Vector3d(0.2, -0.1, 2.5));
  box.T_world_box.rotate(Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()));
  box.half_extents = Eigen::Vector3d(1.0, 0.3, 0.5);
  const FilterResult r = crop_box(cloud, box);
  const Isometry3d T_box_world = box.T_world_box.inverse();
  EXPECT_EQ(r.indices, brute_force(cloud, [&](const Eigen::Vector3f& p) {
              const Eigen::Vector3d q = T_box_world * p.cast<double>();
              return std::abs(q.x()) <= 1.0 && std::abs(q.y()) <= 0.3 && std::abs(q.z()) <= 0.5;
            }));
  EXPECT_GT(r.indices.size(), 100u);
  // A point along the box's rotated x axis, 0.9 m from its centre, is inside; the same
  // distance along the world x axis is not.
  EXPECT_TRUE(box.contains((box.T_world_box * Eigen::Vector3d(0.9, 0, 0)).cast<float>()));
  EXPECT_FALSE(box.contains(Eigen::Vector3f(0.2f + 0.9f, -0.1f, 2.5f)));
  // The identity-oriented box is the axis-aligned box.
  OrientedBox aligned{Isometry3d(Eigen::Translation3d(0.0, 0.0, 2.5)), Eigen::Vector3d(1, 1, 1)};
  const AxisAlignedBox same{Eigen::Vector3f(-1.f, -1.f, 1.5f), Eigen::Vector3f(1.f, 1.f, 3.5f)};
  EXPECT_EQ(crop_box(cloud, aligned).indices, crop_box(cloud, same).indices);
}

TEST(Crop, DepthRangeInCameraAndWorldFrames) {
  PointCloud camera_cloud = random_cloud(20000, 5);
  camera_cloud.positions[9].y() = std::numeric_limits<float>::infinity();
  const FilterResult in_camera = crop_depth_range(camera_cloud, 1.0, 3.0);
  EXPECT_EQ(in_camera.indices, brute_force(camera_cloud, [](const Eigen::Vector3f& p) {
              return p.z() >= 1.f && p.z() <= 3.f;
            }));
  EXPECT_EQ(in_camera.report.non_finite, 1u);
  expect_consistent(camera_cloud, in_camera);

  // The same points expressed in a world frame: cropping with the camera pose selects the
  // same points (up to rounding at the limits; the random depths avoid them).
  Isometry3d T_world_camera = Isometry3d::Identity();
  T_world_camera.translate(Eigen::Vector3d(4.0, -2.0, 1.0));
  T_world_camera.rotate(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  PointCloud world_cloud = camera_cloud;
  for (auto& p : world_cloud.positions) p = (T_world_camera * p.cast<double>()).cast<float>();
  const FilterResult in_world = crop_depth_range(world_cloud, 1.0, 3.0, T_world_camera);
  EXPECT_EQ(in_world.indices, in_camera.indices);
}

}  // namespace
}  // namespace locard
