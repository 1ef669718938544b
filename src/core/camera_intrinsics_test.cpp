#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/error.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace locard {
namespace {

TEST(CameraIntrinsics, NamedPresetsHaveThePublishedValues) {
  const auto v1 = CameraIntrinsics::preset("kinect_v1");
  EXPECT_EQ(v1.width, 640);
  EXPECT_EQ(v1.height, 480);
  EXPECT_DOUBLE_EQ(v1.fx, 525.0);
  EXPECT_DOUBLE_EQ(v1.cx, 319.5);
  EXPECT_DOUBLE_EQ(v1.cy, 239.5);
  const auto seven = CameraIntrinsics::preset("seven_scenes");
  EXPECT_DOUBLE_EQ(seven.fx, 585.0);
  EXPECT_DOUBLE_EQ(seven.cx, 320.0);
  const auto fr1 = CameraIntrinsics::preset("tum_freiburg1");
  EXPECT_DOUBLE_EQ(fr1.fx, 517.3);
  EXPECT_DOUBLE_EQ(fr1.fy, 516.5);
  EXPECT_DOUBLE_EQ(fr1.cy, 255.3);
  EXPECT_DOUBLE_EQ(CameraIntrinsics::preset("tum_freiburg2").fx, 520.9);
  EXPECT_DOUBLE_EQ(CameraIntrinsics::preset("tum_freiburg3").fy, 539.2);
}

TEST(CameraIntrinsics, KinectV2FieldOfViewIs70_6By60Degrees) {
  const auto k = CameraIntrinsics::preset("kinect_v2");
  EXPECT_EQ(k.width, 512);
  EXPECT_EQ(k.height, 424);
  const double hfov = 2.0 * std::atan(0.5 * k.width / k.fx) * 180.0 / std::numbers::pi;
  const double vfov = 2.0 * std::atan(0.5 * k.height / k.fy) * 180.0 / std::numbers::pi;
  EXPECT_NEAR(hfov, 70.6, 1e-9);
  EXPECT_NEAR(vfov, 60.0, 1e-9);
  EXPECT_DOUBLE_EQ(k.cx, 255.5);
  EXPECT_DOUBLE_EQ(k.cy, 211.5);
}

TEST(CameraIntrinsics, RecognisesPresetValuesReadFromAFile) {
  CameraIntrinsics k = CameraIntrinsics::preset("seven_scenes");
  k.name = "camera-intrinsics.txt";
  EXPECT_EQ(k.matching_preset(), "seven_scenes");
  k.cx = 320.5;
  EXPECT_EQ(k.matching_preset(), std::nullopt);
}

TEST(CameraIntrinsics, UnknownPresetNamesTheKnownOnes) {
  try {
    CameraIntrinsics::preset("kinect_v3");
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("kinect_v3"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("seven_scenes"), std::string::npos);
  }
}

TEST(CameraIntrinsics, ScalingKeepsTheFieldOfView) {
  // 512x424 depth intrinsics scaled 3.75x (1920 wide) keep the same view of the scene.
  const auto k = CameraIntrinsics::preset("kinect_v2");
  const auto hd = k.scaled(3.75);
  EXPECT_EQ(hd.width, 1920);
  EXPECT_EQ(hd.height, 1590);
  EXPECT_NEAR(hd.width / hd.fx, k.width / k.fx, 1e-12);
  EXPECT_NEAR(hd.cx, (1920 - 1) * 0.5, 1e-9);
}

}  // namespace
}  // namespace locard
