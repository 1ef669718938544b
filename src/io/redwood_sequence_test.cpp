#include <locard/io/rgbd_sequence.hpp>

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/trajectory_io.hpp>

#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

fs::path open3d_rgbd() { return test::shared_data() / "open3d-testdata" / "RGBD"; }

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

// A Redwood folder of `n` frames of 64x48 with an Open3D camera JSON (column-major K).
fs::path make_redwood_folder(const fs::path& folder, int n) {
  fs::create_directories(folder / "color");
  fs::create_directories(folder / "depth");
  for (int i = 0; i < n; ++i) {
    const std::string name = "0000" + std::to_string(i);
    write_png(folder / "depth" / (name + ".png"),
              DepthImage(64, 48, static_cast<std::uint16_t>(1000 + i)));
    write_png(folder / "color" / (name + ".png"), ColorImage(64, 48, static_cast<std::uint8_t>(i)));
  }
  write_text(
      folder / "camera.json",
      R"({"width": 64, "height": 48, "intrinsic_matrix": [50, 0, 0, 0, 51, 0, 31.5, 23.5, 1]})");
  return folder;
}

TEST(RedwoodSequence, IndexesOpen3dTestData) {
  EXPECT_EQ(detect_format(open3d_rgbd()), DatasetFormat::Redwood);
  const RgbdSequence s = open_rgbd_sequence(open3d_rgbd());
  EXPECT_EQ(s.format, DatasetFormat::Redwood);
  ASSERT_EQ(s.frames.size(), 5u);
  // camera_primesense.json one folder up.
  EXPECT_EQ(s.intrinsics.width, 640);
  EXPECT_EQ(s.intrinsics.height, 480);
  EXPECT_DOUBLE_EQ(s.intrinsics.fx, 525.0);
  EXPECT_DOUBLE_EQ(s.intrinsics.fy, 525.0);
  EXPECT_DOUBLE_EQ(s.intrinsics.cx, 319.5);
  EXPECT_DOUBLE_EQ(s.intrinsics.cy, 239.5);
  EXPECT_EQ(s.intrinsics_source, "../camera_primesense.json");
  EXPECT_DOUBLE_EQ(s.depth_scale, 1000.0);
  // rgbd.match pairs depth/0000i.png with color/0000i.jpg.
  EXPECT_EQ(s.frames[3].depth_path, open3d_rgbd() / "depth" / "00003.png");
  EXPECT_EQ(s.frames[3].color_path, open3d_rgbd() / "color" / "00003.jpg");
  EXPECT_DOUBLE_EQ(s.frames[3].timestamp, 3.0 / 30.0);

  // Both odometry.log and trajectory.log have 5 entries; odometry.log is preferred.
  EXPECT_EQ(s.ground_truth_source, "odometry.log");
  ASSERT_EQ(s.ground_truth.size(), 5u);
  Eigen::Matrix4d frame2;                                // entry "2 2 3" of odometry.log
  frame2 << 0.999954, -7.8978e-005, 0.0096394, 1.99935,  //
      -0.000149351, 0.99972, 0.0236841, 1.95353,         //
      -0.00963857, -0.0236844, 0.999673, -0.301586,      //
      0, 0, 0, 1;
  ASSERT_TRUE(s.frames[2].T_world_camera);
  EXPECT_EQ(s.frames[2].T_world_camera->matrix(), frame2);
  EXPECT_EQ(s.ground_truth[2].T_world_camera.matrix(), frame2);
}

TEST(RedwoodSequence, LoadsFramesWithKnownDepth) {
  const RgbdSequence s = read_redwood_sequence(open3d_rgbd());
  const RgbdFrame f0 = s.load_frame(0);
  ASSERT_EQ(f0.depth.width(), 640);
  ASSERT_EQ(f0.color.width(), 640);
  ASSERT_EQ(f0.color.height(), 480);
  EXPECT_EQ(f0.depth.at(320, 240), 2195);
  EXPECT_DOUBLE_EQ(f0.depth_m(320, 240), 2.195);
  EXPECT_EQ(f0.depth.at(100, 100), 1370);
  EXPECT_EQ(s.load_frame(2).depth.at(100, 100), 1364);
  for (std::size_t i = 0; i < s.frames.size(); ++i) EXPECT_NO_THROW(s.load_frame(i));
}

TEST(RedwoodSequence, PairsBySortedNameWithoutMatchFile) {
  const fs::path folder = make_redwood_folder(test::scratch_dir() / "scene", 3);
  const RgbdSequence s = read_redwood_sequence(folder);
  ASSERT_EQ(s.frames.size(), 3u);
  EXPECT_EQ(s.frames[2].depth_path.filename(), "00002.png");
  EXPECT_EQ(s.frames[2].color_path, folder / "color" / "00002.png");
  EXPECT_EQ(s.intrinsics_source, "camera.json");
  EXPECT_DOUBLE_EQ(s.intrinsics.fy, 51.0);
  EXPECT_DOUBLE_EQ(s.intrinsics.cx, 31.5);
  EXPECT_FALSE(s.has_ground_truth());
  const RgbdFrame f = s.load_frame(2);
  EXPECT_EQ(f.depth.at(0, 0), 1002);
  EXPECT_EQ(f.color.at(0, 0, 0), 2);
}

TEST(RedwoodSequence, GroundTruthOnlyFromLogWithOneEntryPerFrame) {
  const fs::path folder = make_redwood_folder(test::scratch_dir() / "scene", 3);
  Trajectory two(2), three(3);
  for (std::size_t i = 0; i < 3; ++i) {
    three[i].frame_index = static_cast<std::int64_t>(i);
    three[i].T_world_camera.translation() = Eigen::Vector3d(0.1 * static_cast<double>(i), 0, 0);
  }
  two[0].frame_index = 0;
  two[1].frame_index = 1;
  write_redwood_log(folder / "a_short.log", two);
  write_redwood_log(folder / "z_full.log", three);
  const RgbdSequence s = read_redwood_sequence(folder);
  EXPECT_EQ(s.ground_truth_source, "z_full.log");
  ASSERT_EQ(s.ground_truth.size(), 3u);
  ASSERT_TRUE(s.frames[2].T_world_camera);
  EXPECT_DOUBLE_EQ(s.frames[2].T_world_camera->translation().x(), 0.2);
}

TEST(RedwoodSequence, IntrinsicsFallBackToKinectV1) {
  const fs::path folder = make_redwood_folder(test::scratch_dir() / "scene", 1);
  fs::remove(folder / "camera.json");
  write_text(folder / "notes.json", R"({"operator": "unit test"})");  // not intrinsics
  const RgbdSequence s = read_redwood_sequence(folder);
  EXPECT_EQ(s.intrinsics, CameraIntrinsics::preset("kinect_v1"));
  EXPECT_THAT(s.intrinsics_source, HasSubstr("kinect_v1"));
  // 64x48 images, 640x480 intrinsics: refused when loading.
  EXPECT_THAT([&] { s.load_frame(0); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("00000.png"), HasSubstr("64x48"),
                                              HasSubstr("640x480"), HasSubstr("frame 0"))));
}

TEST(RedwoodSequence, MismatchedColourAndDepthSizeNamesBothFiles) {
  const fs::path folder = make_redwood_folder(test::scratch_dir() / "scene", 2);
  write_png(folder / "color" / "00001.png", ColorImage(32, 24));
  const RgbdSequence s = read_redwood_sequence(folder);
  EXPECT_NO_THROW(s.load_frame(0));
  EXPECT_THAT([&] { s.load_frame(1); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("color/00001.png"),
                                              HasSubstr("depth/00001.png"), HasSubstr("32x24"),
                                              HasSubstr("64x48"), HasSubstr("frame 1"))));
}

TEST(RedwoodSequence, UnequalImageCountsWithoutMatchFileIsInputError) {
  const fs::path folder = make_redwood_folder(test::scratch_dir() / "scene", 3);
  fs::remove(folder / "color" / "00001.png");
  EXPECT_THAT(
      [&] { read_redwood_sequence(folder); },
      ThrowsMessage<InputError>(AllOf(HasSubstr("color/ holds 2"), HasSubstr("depth/ holds 3"))));
  // An rgbd.match makes the pairing explicit; the missing colour is reported on load.
  write_text(folder / "rgbd.match",
             "depth/00000.png color/00000.png\ndepth/00001.png color/00001.png\n");
  const RgbdSequence s = read_redwood_sequence(folder);
  ASSERT_EQ(s.frames.size(), 2u);
  EXPECT_THAT([&] { s.load_frame(1); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("color/00001.png"), HasSubstr("frame 1"))));
}

TEST(RedwoodSequence, RowMajorCameraJsonIsInputError) {
  const fs::path folder = make_redwood_folder(test::scratch_dir() / "scene", 1);
  write_text(
      folder / "camera.json",
      R"({"width": 64, "height": 48, "intrinsic_matrix": [50, 0, 31.5, 0, 51, 23.5, 0, 0, 1]})");
  EXPECT_THAT([&] { read_redwood_sequence(folder); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("camera.json"), HasSubstr("row-major"))));
}

}  // namespace
}  // namespace locard
