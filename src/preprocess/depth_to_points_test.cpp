// Back-projection against hand-computed points, range limits, stride, colour and poses.
#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/error.hpp>
#include <locard/core/rgbd_frame.hpp>
#include <locard/preprocess/depth_to_points.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace locard {
namespace {

RgbdFrame make_frame(const char* preset, double depth_scale) {
  RgbdFrame frame;
  frame.intrinsics = CameraIntrinsics::preset(preset);
  frame.depth = DepthImage(frame.intrinsics.width, frame.intrinsics.height);
  frame.depth_scale = depth_scale;
  return frame;
}

TEST(DepthToPoints, MatchesHandComputedPoint) {
  // 7-Scenes intrinsics fx = fy = 585, cx = 320, cy = 240; pixel (100, 400), 1500 mm:
  // x = (100 - 320) * 1.5 / 585 = -0.564102564..., y = (400 - 240) * 1.5 / 585 = 0.41025641...
  RgbdFrame frame = make_frame("seven_scenes", 1000.0);
  frame.depth.at(100, 400) = 1500;
  const PointCloud cloud = depth_to_points(frame, {});
  ASSERT_EQ(cloud.size(), 1u);
  EXPECT_NEAR(cloud.positions[0].x(), -0.5641025641, 1e-6);
  EXPECT_NEAR(cloud.positions[0].y(), 0.4102564103, 1e-6);
  EXPECT_NEAR(cloud.positions[0].z(), 1.5, 1e-7);
  EXPECT_FALSE(cloud.has_colors());
}

TEST(DepthToPoints, TumScaleAndPrincipalPoint) {
  // TUM stores 5000 units per metre: 10000 -> 2 m. Principal point (318.6, 255.3) is not on
  // a pixel centre, so even the nearest pixel has a small lateral offset.
  RgbdFrame frame = make_frame("tum_freiburg1", 5000.0);
  frame.depth.at(319, 255) = 10000;
  const PointCloud cloud = depth_to_points(frame, {});
  ASSERT_EQ(cloud.size(), 1u);
  EXPECT_NEAR(cloud.positions[0].x(), (319 - 318.6) * 2.0 / 517.3, 1e-6);
  EXPECT_NEAR(cloud.positions[0].y(), (255 - 255.3) * 2.0 / 516.5, 1e-6);
  EXPECT_NEAR(cloud.positions[0].z(), 2.0, 1e-7);
}

TEST(DepthToPoints, RangeLimitsAreInclusiveAndZeroIsInvalid) {
  RgbdFrame frame = make_frame("kinect_v1", 1000.0);
  frame.depth.at(0, 0) = 499;   // below 0.5 m
  frame.depth.at(1, 0) = 500;   // exactly the minimum: kept
  frame.depth.at(2, 0) = 4500;  // exactly the maximum: kept
  frame.depth.at(3, 0) = 4501;  // above: dropped
  DepthToPointsOptions options;
  options.min_depth_m = 0.5;
  options.max_depth_m = 4.5;
  const PointCloud cloud = depth_to_points(frame, options);
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_FLOAT_EQ(cloud.positions[0].z(), 0.5f);
  EXPECT_FLOAT_EQ(cloud.positions[1].z(), 4.5f);
}

TEST(DepthToPoints, ColourFollowsItsPixelAndOrderIsRowMajor) {
  RgbdFrame frame = make_frame("kinect_v1", 1000.0);
  frame.color = ColorImage(640, 480);
  frame.depth.at(10, 300) = 1000;
  frame.depth.at(600, 20) = 2000;
  frame.color.at(10, 300, 0) = 200;
  frame.color.at(600, 20, 2) = 77;
  const PointCloud cloud = depth_to_points(frame, {});
  ASSERT_EQ(cloud.size(), 2u);
  ASSERT_TRUE(cloud.has_colors());
  // Row 20 comes before row 300.
  EXPECT_FLOAT_EQ(cloud.positions[0].z(), 2.0f);
  EXPECT_EQ(cloud.colors[0], (Rgb8{0, 0, 77}));
  EXPECT_EQ(cloud.colors[1], (Rgb8{200, 0, 0}));
}

TEST(DepthToPoints, StrideSamplesEveryNthPixel) {
  RgbdFrame frame = make_frame("kinect_v1", 1000.0);
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) frame.depth.at(u, v) = 1000;
  DepthToPointsOptions options;
  options.stride = 4;
  EXPECT_EQ(depth_to_points(frame, options).size(), 160u * 120u);
  options.stride = 1;
  EXPECT_EQ(depth_to_points(frame, options).size(), 640u * 480u);
}

TEST(DepthToPoints, AppliesCameraToWorldPose) {
  RgbdFrame frame = make_frame("seven_scenes", 1000.0);
  frame.depth.at(320, 240) = 2000;  // on the optical axis: camera point (0, 0, 2)
  Isometry3d T_world_camera = Isometry3d::Identity();
  T_world_camera.linear() =
      Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T_world_camera.translation() = Eigen::Vector3d(1.0, 2.0, 3.0);
  const PointCloud cloud = depth_to_points(frame, {}, T_world_camera);
  ASSERT_EQ(cloud.size(), 1u);
  // R_x(90 deg) * (0, 0, 2) = (0, -2, 0); plus t.
  EXPECT_NEAR(cloud.positions[0].x(), 1.0, 1e-6);
  EXPECT_NEAR(cloud.positions[0].y(), 0.0, 1e-6);
  EXPECT_NEAR(cloud.positions[0].z(), 3.0, 1e-6);
}

TEST(DepthToPoints, MismatchedColourIsAnError) {
  RgbdFrame frame = make_frame("kinect_v1", 1000.0);
  frame.color = ColorImage(320, 240);
  frame.depth.at(1, 1) = 1000;
  EXPECT_THROW(depth_to_points(frame, {}), Error);
}

}  // namespace
}  // namespace locard
