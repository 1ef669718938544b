#include <locard/io/rgbd_sequence.hpp>

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>

#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

fs::path seven_scenes() { return test::shared_data() / "7scenes-tsdf-fusion" / "data"; }

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

// frame-000000.pose.txt, as printed in the file.
Eigen::Matrix4d frame0_pose() {
  Eigen::Matrix4d m;
  m << 9.093128999999999795e-01, 2.726222899999999894e-01, -3.142243299999999961e-01,
      -3.404563400000000239e-01,  //
      -2.724861800000000223e-01, 9.610497999999999541e-01, 4.527962600000000337e-02,
      1.646981800000000065e-02,  //
      3.143392500000000145e-01, 4.444964600000000238e-02, 9.482093499999999509e-01,
      2.965691699999999931e-01,  //
      0, 0, 0, 1;
  return m;
}

const std::string kIdentityPose = "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";

TEST(SevenScenesSequence, IndexesSharedDataset) {
  EXPECT_EQ(detect_format(seven_scenes()), DatasetFormat::SevenScenes);
  const RgbdSequence s = open_rgbd_sequence(seven_scenes());
  EXPECT_EQ(s.format, DatasetFormat::SevenScenes);
  ASSERT_EQ(s.frames.size(), 374u);  // 0..59, then every third frame up to 999
  ASSERT_EQ(s.ground_truth.size(), 1000u);
  EXPECT_EQ(s.ground_truth_source, "frame-*.pose.txt");
  EXPECT_EQ(s.intrinsics.width, 640);
  EXPECT_EQ(s.intrinsics.height, 480);
  EXPECT_DOUBLE_EQ(s.intrinsics.fx, 585.0);
  EXPECT_DOUBLE_EQ(s.intrinsics.fy, 585.0);
  EXPECT_DOUBLE_EQ(s.intrinsics.cx, 320.0);
  EXPECT_DOUBLE_EQ(s.intrinsics.cy, 240.0);
  EXPECT_EQ(s.intrinsics_source, "camera-intrinsics.txt");
  EXPECT_DOUBLE_EQ(s.depth_scale, 1000.0);

  EXPECT_EQ(s.frames[59].frame_index, 59);
  EXPECT_EQ(s.frames[60].frame_index, 60);
  EXPECT_EQ(s.frames[61].frame_index, 63);
  EXPECT_EQ(s.frames.back().frame_index, 999);
  EXPECT_DOUBLE_EQ(s.frames.back().timestamp, 999.0 / 30.0);
  EXPECT_EQ(s.ground_truth[500].frame_index, 500);
  EXPECT_DOUBLE_EQ(s.ground_truth[500].timestamp, 500.0 / 30.0);
  for (const auto& f : s.frames) ASSERT_TRUE(f.T_world_camera) << f.frame_index;

  EXPECT_EQ(s.ground_truth[0].T_world_camera.matrix(), frame0_pose());
  EXPECT_EQ(s.frames[0].T_world_camera->matrix(), frame0_pose());
  EXPECT_EQ(s.frames[0].color_path, seven_scenes() / "frame-000000.color.jpg");
}

TEST(SevenScenesSequence, LoadsFrameZeroWithKnownDepth) {
  const RgbdSequence s = read_seven_scenes_sequence(seven_scenes());
  const RgbdFrame frame = s.load_frame(0);
  ASSERT_EQ(frame.depth.width(), 640);
  ASSERT_EQ(frame.depth.height(), 480);
  ASSERT_EQ(frame.color.width(), 640);
  ASSERT_EQ(frame.color.height(), 480);
  EXPECT_EQ(frame.depth.at(320, 240), 1382);
  EXPECT_DOUBLE_EQ(frame.depth_m(320, 240), 1.382);
  EXPECT_EQ(frame.depth.at(100, 100), 2215);
  EXPECT_EQ(frame.frame_index, 0);
  EXPECT_DOUBLE_EQ(frame.timestamp, 0.0);
  EXPECT_DOUBLE_EQ(frame.intrinsics.fx, 585.0);
}

TEST(SevenScenesSequence, InvalidMarker65535BecomesZero) {
  // frame-000033.depth.png stores 46 pixels as 65535 ("no measurement" in 7-Scenes).
  const RgbdSequence s = read_seven_scenes_sequence(seven_scenes());
  const DepthImage raw = read_depth_image(s.frames[33].depth_path);
  EXPECT_EQ(std::count(raw.data().begin(), raw.data().end(), 65535), 46);
  const DepthImage loaded = s.load_depth(33);
  EXPECT_EQ(std::count(loaded.data().begin(), loaded.data().end(), 65535), 0);
  EXPECT_EQ(std::count(loaded.data().begin(), loaded.data().end(), 0),
            std::count(raw.data().begin(), raw.data().end(), 0) + 46);
  EXPECT_EQ(s.load_frame(33).depth, loaded);
}

TEST(SevenScenesSequence, EveryFrameDecodesCleanly) {
  // Strict JPEG checking (corrupt-data warnings are errors) must accept the real files.
  const RgbdSequence s = read_seven_scenes_sequence(seven_scenes());
  std::size_t valid_pixels = 0;
  for (std::size_t i = 0; i < s.frames.size(); ++i) {
    const RgbdFrame frame = s.load_frame(i);
    ASSERT_EQ(frame.color.width(), 640);
    for (const auto d : frame.depth.data()) valid_pixels += d != 0;
  }
  EXPECT_GT(valid_pixels, 0u);
}

TEST(SevenScenesSequence, SyntheticFolderRules) {
  const fs::path dir = test::scratch_dir();
  // Frame 0: everything. Frame 1: pose only. Frame 2: depth + png colour, no pose.
  // Frame 3: depth + pose, no colour (not a frame).
  write_png(dir / "frame-000000.depth.png", DepthImage(64, 48, 1500));
  write_png(dir / "frame-000000.color.png", ColorImage(64, 48, 10));
  write_text(dir / "frame-000000.pose.txt", kIdentityPose);
  write_text(dir / "frame-000001.pose.txt", kIdentityPose);
  write_png(dir / "frame-000002.depth.png", DepthImage(64, 48, 2000));
  write_png(dir / "frame-000002.color.png", ColorImage(64, 48, 20));
  write_png(dir / "frame-000003.depth.png", DepthImage(64, 48));
  write_text(dir / "frame-000003.pose.txt", kIdentityPose);
  write_text(dir / "camera-intrinsics.txt", "100 0 31.5\n0 100 23.5\n0 0 1\n");

  const RgbdSequence s = read_seven_scenes_sequence(dir);
  ASSERT_EQ(s.frames.size(), 2u);
  EXPECT_EQ(s.frames[0].frame_index, 0);
  EXPECT_EQ(s.frames[1].frame_index, 2);
  EXPECT_TRUE(s.frames[0].T_world_camera);
  EXPECT_FALSE(s.frames[1].T_world_camera);
  ASSERT_EQ(s.ground_truth.size(), 3u);
  EXPECT_EQ(s.ground_truth[1].frame_index, 1);
  EXPECT_EQ(s.ground_truth[2].frame_index, 3);
  // Size from the first depth image, K from the file.
  EXPECT_EQ(s.intrinsics.width, 64);
  EXPECT_EQ(s.intrinsics.height, 48);
  EXPECT_DOUBLE_EQ(s.intrinsics.cx, 31.5);
  EXPECT_DOUBLE_EQ(s.load_frame(1).depth_m(3, 3), 2.0);

  fs::remove(dir / "camera-intrinsics.txt");
  const RgbdSequence preset = read_seven_scenes_sequence(dir);
  EXPECT_EQ(preset.intrinsics, CameraIntrinsics::preset("seven_scenes"));
  EXPECT_THAT(preset.intrinsics_source, HasSubstr("preset seven_scenes"));
  // 64x48 images against 640x480 intrinsics.
  EXPECT_THAT([&] { preset.load_frame(0); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("frame-000000.depth.png"),
                                              HasSubstr("64x48"), HasSubstr("640x480"))));
}

TEST(SevenScenesSequence, MalformedPoseFilesNameTheFile) {
  const fs::path root = test::scratch_dir();
  const auto attempt = [&](const std::string& name, const std::string& pose) {
    const fs::path dir = root / name;
    fs::create_directories(dir);
    write_text(dir / "frame-000007.pose.txt", pose);
    read_seven_scenes_sequence(dir);
  };
  EXPECT_THAT(
      [&] { attempt("rows", "1 0 0 0\n0 1 0 0\n0 0 1 0\n"); },
      ThrowsMessage<InputError>(AllOf(HasSubstr("frame-000007.pose.txt"), HasSubstr("found 12"))));
  EXPECT_THAT(
      [&] { attempt("last", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n"); },
      ThrowsMessage<InputError>(AllOf(HasSubstr("frame-000007.pose.txt"), HasSubstr("0 0 0 1"))));
  EXPECT_THAT(
      [&] { attempt("word", "1 0 0 0\n0 1 0 0\n0 0 1 nan?\n0 0 0 1\n"); },
      ThrowsMessage<InputError>(AllOf(HasSubstr("frame-000007.pose.txt"), HasSubstr("nan?"))));
  EXPECT_THAT(
      [&] { attempt("scale", "2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n"); },
      ThrowsMessage<InputError>(AllOf(HasSubstr("frame-000007.pose.txt"), HasSubstr("rigid"))));
  // Issue 14: orthonormal with determinant -1 (a mirror) was accepted.
  EXPECT_THAT(
      [&] { attempt("mirror", "-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"); },
      ThrowsMessage<InputError>(AllOf(HasSubstr("frame-000007.pose.txt"), HasSubstr("reflection"))));
}

TEST(SevenScenesSequence, TruncatedJpegNamesFileAndFrame) {
  const fs::path dir = test::scratch_dir();
  std::ifstream in(seven_scenes() / "frame-000000.color.jpg", std::ios::binary);
  std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  bytes.resize(bytes.size() / 2);
  std::ofstream(dir / "frame-000004.color.jpg", std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  fs::copy_file(seven_scenes() / "frame-000000.depth.png", dir / "frame-000004.depth.png");
  const RgbdSequence s = read_seven_scenes_sequence(dir);
  ASSERT_EQ(s.frames.size(), 1u);
  EXPECT_THAT(
      [&] { s.load_frame(0); },
      ThrowsMessage<InputError>(AllOf(HasSubstr("frame-000004.color.jpg"), HasSubstr("frame 0"))));
}

}  // namespace
}  // namespace locard
