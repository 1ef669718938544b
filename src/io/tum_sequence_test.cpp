#include <locard/io/rgbd_sequence.hpp>

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>

#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

fs::path tum_metadata() { return test::shared_data() / "tum-fr1-xyz-metadata"; }

std::vector<std::string> read_lines(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

void write_lines(const fs::path& path, const std::vector<std::string>& lines) {
  std::ofstream out(path);
  for (const auto& line : lines) out << line << '\n';
}

// The three TUM lists of freiburg1_xyz: 3 header lines, then data. `edit` may change the
// data lines (index 0 = first data line, file line 4) of each file before it is written.
using Edit = std::function<void(const std::string& file, std::vector<std::string>& data)>;

fs::path make_tum_folder(const fs::path& folder, const Edit& edit = {}) {
  fs::create_directories(folder / "rgb");
  fs::create_directories(folder / "depth");
  for (const std::string name : {"rgb.txt", "depth.txt", "groundtruth.txt"}) {
    std::vector<std::string> lines = read_lines(tum_metadata() / name);
    std::vector<std::string> header(lines.begin(), lines.begin() + 3);
    std::vector<std::string> data(lines.begin() + 3, lines.end());
    if (edit) edit(name, data);
    header.insert(header.end(), data.begin(), data.end());
    write_lines(folder / name, header);
  }
  return folder;
}

// rgb.txt without its data lines 10..19: depth frames 11..19 then have no colour within 20 ms.
void drop_ten_colour_frames(const std::string& file, std::vector<std::string>& data) {
  if (file == "rgb.txt") data.erase(data.begin() + 10, data.begin() + 20);
}

const FrameEntry* find_frame(const RgbdSequence& s, std::int64_t index) {
  for (const auto& f : s.frames)
    if (f.frame_index == index) return &f;
  return nullptr;
}

TEST(TumSequence, IndexesSharedMetadataWithFreiburg1FromFolderName) {
  EXPECT_EQ(detect_format(tum_metadata()), DatasetFormat::Tum);
  const RgbdSequence s = open_rgbd_sequence(tum_metadata());
  EXPECT_EQ(s.format, DatasetFormat::Tum);
  EXPECT_EQ(s.frames.size(), 798u);
  EXPECT_EQ(s.dropped_frames, 0u);
  EXPECT_EQ(s.ground_truth.size(), 3000u);
  EXPECT_EQ(s.ground_truth_source, "groundtruth.txt");
  EXPECT_DOUBLE_EQ(s.depth_scale, 5000.0);
  EXPECT_EQ(s.intrinsics, CameraIntrinsics::preset("tum_freiburg1"));  // "fr1" in the name
  EXPECT_THAT(s.intrinsics_source, HasSubstr("tum_freiburg1"));
  // Depth frames 1 and 2 share the nearest colour image.
  EXPECT_EQ(s.frames[1].color_path.filename(), "1305031102.211214.png");
  EXPECT_EQ(s.frames[2].color_path.filename(), "1305031102.211214.png");
  EXPECT_EQ(s.frames[0].depth_path, tum_metadata() / "depth" / "1305031102.160407.png");
  EXPECT_DOUBLE_EQ(s.frames[0].timestamp, 1305031102.160407);
  // Ground truth has a gap of 110 ms around depth frames 201 and 202.
  const auto with_pose = std::count_if(s.frames.begin(), s.frames.end(), [](const FrameEntry& f) {
    return f.T_world_camera.has_value();
  });
  EXPECT_EQ(with_pose, 796);
  EXPECT_FALSE(s.frames[201].T_world_camera);
  EXPECT_FALSE(s.frames[202].T_world_camera);
}

TEST(TumSequence, AssociatesDepthToNearestColourAndCountsDrops) {
  const fs::path folder = make_tum_folder(test::scratch_dir() / "plain", drop_ten_colour_frames);
  const RgbdSequence s = read_tum_sequence(folder);
  EXPECT_EQ(s.frames.size(), 789u);
  EXPECT_EQ(s.dropped_frames, 9u);
  for (std::int64_t k = 11; k <= 19; ++k) EXPECT_EQ(find_frame(s, k), nullptr) << k;
  EXPECT_EQ(s.frames[10].frame_index, 10);
  EXPECT_EQ(s.frames[11].frame_index, 20);
  const auto with_pose = std::count_if(s.frames.begin(), s.frames.end(), [](const FrameEntry& f) {
    return f.T_world_camera.has_value();
  });
  EXPECT_EQ(with_pose, 787);

  SequenceOptions tight;
  tight.max_time_difference = 0.01;
  // At 10 ms, 605 depth frames keep a colour image (the 9 above were more than 10 ms away
  // from their nearest colour image anyway).
  EXPECT_EQ(read_tum_sequence(folder, tight).frames.size(), 605u);
}

TEST(TumSequence, GroundTruthOfKnownFrame) {
  const RgbdSequence s = read_tum_sequence(make_tum_folder(test::scratch_dir() / "plain"));
  // Depth frame 100 (t = 1305031105.497931) -> groundtruth line
  // "1305031105.4958 1.2573 0.6160 1.6071 0.6537 0.6321 -0.2926 -0.2959" (2.1 ms away).
  const FrameEntry& f = s.frames[100];
  EXPECT_EQ(f.frame_index, 100);
  EXPECT_DOUBLE_EQ(f.timestamp, 1305031105.497931);
  ASSERT_TRUE(f.T_world_camera);
  EXPECT_NEAR((f.T_world_camera->translation() - Eigen::Vector3d(1.2573, 0.6160, 1.6071)).norm(),
              0.0, 1e-12);
  const Eigen::Quaterniond q(-0.2959, 0.6537, 0.6321, -0.2926);
  EXPECT_LT((f.T_world_camera->linear() - q.normalized().toRotationMatrix()).norm(), 1e-12);
  EXPECT_EQ(s.ground_truth[683].frame_index, 683);  // file line 687, 0-based among data lines
  EXPECT_DOUBLE_EQ(s.ground_truth[683].timestamp, 1305031105.4958);
}

TEST(TumSequence, IntrinsicsFromJsonFolderNameOrDefault) {
  const fs::path root = test::scratch_dir();
  const RgbdSequence plain = read_tum_sequence(make_tum_folder(root / "plain"));
  EXPECT_EQ(plain.intrinsics, CameraIntrinsics::preset("kinect_v1"));
  EXPECT_THAT(plain.intrinsics_source, AllOf(HasSubstr("kinect_v1"), HasSubstr("assumed")));

  const RgbdSequence fr2 = read_tum_sequence(make_tum_folder(root / "rgbd_dataset_freiburg2_desk"));
  EXPECT_DOUBLE_EQ(fr2.intrinsics.fx, 520.9);
  EXPECT_THAT(fr2.intrinsics_source, HasSubstr("tum_freiburg2"));

  // Our simulator writes intrinsics.json, which wins over the folder name and may set the scale.
  const fs::path sim = make_tum_folder(root / "fr3_sim");
  CameraIntrinsics k = CameraIntrinsics::preset("kinect_v2");
  k.distortion = {0.1, -0.2, 0.0, 0.001, 0.05};
  write_intrinsics_json(sim / "intrinsics.json", k, 1000.0);
  const RgbdSequence s = read_tum_sequence(sim);
  EXPECT_EQ(s.intrinsics, k);
  EXPECT_EQ(s.intrinsics_source, "intrinsics.json");
  EXPECT_DOUBLE_EQ(s.depth_scale, 1000.0);

  SequenceOptions options;
  options.intrinsics = CameraIntrinsics::preset("tum_freiburg3");
  options.depth_scale = 4000.0;
  const RgbdSequence overridden = read_tum_sequence(sim, options);
  EXPECT_EQ(overridden.intrinsics, CameraIntrinsics::preset("tum_freiburg3"));
  EXPECT_THAT(overridden.intrinsics_source, HasSubstr("override"));
  EXPECT_DOUBLE_EQ(overridden.depth_scale, 4000.0);
}

TEST(TumSequence, LoadsFrameWithScale5000) {
  const fs::path folder = make_tum_folder(test::scratch_dir() / "plain");
  DepthImage depth(640, 480);
  depth.at(10, 20) = 5000;   // 1 m
  depth.at(11, 20) = 10920;  // 2.184 m
  write_png(folder / "depth" / "1305031102.160407.png", depth);
  write_png(folder / "rgb" / "1305031102.175304.png", ColorImage(640, 480, 7));
  const RgbdSequence s = read_tum_sequence(folder);
  const RgbdFrame frame = s.load_frame(0);
  EXPECT_DOUBLE_EQ(frame.depth_scale, 5000.0);
  EXPECT_DOUBLE_EQ(frame.depth_m(10, 20), 1.0);
  EXPECT_DOUBLE_EQ(frame.depth_m(11, 20), 2.184);
  EXPECT_EQ(frame.color.at(5, 5, 1), 7);
  EXPECT_EQ(frame.frame_index, 0);
  EXPECT_DOUBLE_EQ(frame.timestamp, 1305031102.160407);
  EXPECT_EQ(frame.intrinsics, s.intrinsics);
  EXPECT_EQ(frame.depth_path, folder / "depth" / "1305031102.160407.png");
  EXPECT_EQ(frame.color_path, folder / "rgb" / "1305031102.175304.png");
}

TEST(TumSequence, BadFramesNameFileAndFrame) {
  const fs::path folder = make_tum_folder(test::scratch_dir() / "plain");
  // Frame 1: colour present, depth missing.
  write_png(folder / "rgb" / "1305031102.211214.png", ColorImage(640, 480));
  // Frame 2: 8-bit depth.
  write_png(folder / "depth" / "1305031102.226738.png", GrayImage(640, 480));
  // Frame 3: colour 320x240, depth 640x480.
  write_png(folder / "depth" / "1305031102.262886.png", DepthImage(640, 480));
  write_png(folder / "rgb" / "1305031102.275326.png", ColorImage(320, 240));
  // Frame 4: both 320x240, intrinsics say 640x480.
  write_png(folder / "depth" / "1305031102.295279.png", DepthImage(320, 240));
  write_png(folder / "rgb" / "1305031102.311267.png", ColorImage(320, 240));
  // Frame 5: depth present, colour missing.
  write_png(folder / "depth" / "1305031102.329195.png", DepthImage(640, 480));
  const RgbdSequence s = read_tum_sequence(folder);

  EXPECT_THAT([&] { s.load_frame(1); },
              ThrowsMessage<InputError>(
                  AllOf(HasSubstr("depth/1305031102.194330.png"), HasSubstr("frame 1"))));
  EXPECT_THAT([&] { s.load_frame(2); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("depth/1305031102.226738.png"),
                                              HasSubstr("depth image is 8-bit, expected 16-bit"),
                                              HasSubstr("frame 2"))));
  EXPECT_THAT([&] { s.load_frame(3); },
              ThrowsMessage<InputError>(AllOf(
                  HasSubstr("rgb/1305031102.275326.png"), HasSubstr("depth/1305031102.262886.png"),
                  HasSubstr("320x240"), HasSubstr("640x480"), HasSubstr("frame 3"))));
  EXPECT_THAT([&] { s.load_frame(4); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("depth/1305031102.295279.png"),
                                              HasSubstr("intrinsics"), HasSubstr("frame 4"))));
  EXPECT_THAT([&] { s.load_frame(5); },
              ThrowsMessage<InputError>(
                  AllOf(HasSubstr("rgb/1305031102.343233.png"), HasSubstr("frame 5"))));
  EXPECT_THROW(s.load_frame(798), InputError);
}

TEST(TumSequence, NonMonotonicTimestampsNameFileAndLine) {
  const fs::path root = test::scratch_dir();
  const auto swap_data = [](const std::string& which, std::size_t a) {
    return [which, a](const std::string& file, std::vector<std::string>& data) {
      if (file == which) std::swap(data[a], data[a + 1]);
    };
  };
  EXPECT_THAT([&] { read_tum_sequence(make_tum_folder(root / "d", swap_data("depth.txt", 5))); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("depth.txt:10"), HasSubstr("line 9"))));
  EXPECT_THAT([&] { read_tum_sequence(make_tum_folder(root / "c", swap_data("rgb.txt", 0))); },
              ThrowsMessage<InputError>(HasSubstr("rgb.txt:5")));
  EXPECT_THAT(
      [&] { read_tum_sequence(make_tum_folder(root / "g", swap_data("groundtruth.txt", 100))); },
      ThrowsMessage<InputError>(HasSubstr("groundtruth.txt:105")));
}

TEST(TumSequence, UnparsableLinesNameFileAndLine) {
  const fs::path root = test::scratch_dir();
  const auto replace = [](const std::string& which, std::size_t i, std::string line) {
    return [which, i, line](const std::string& file, std::vector<std::string>& data) {
      if (file == which) data[i] = line;
    };
  };
  EXPECT_THAT(
      [&] {
        read_tum_sequence(
            make_tum_folder(root / "a", replace("rgb.txt", 3, "1305031102.27x rgb/x.png")));
      },
      ThrowsMessage<InputError>(AllOf(HasSubstr("rgb.txt:7"), HasSubstr("1305031102.27x"))));
  EXPECT_THAT(
      [&] {
        read_tum_sequence(make_tum_folder(root / "b", replace("depth.txt", 2, "1305031102.2300")));
      },
      ThrowsMessage<InputError>(AllOf(HasSubstr("depth.txt:6"), HasSubstr("timestamp filename"))));
  EXPECT_THAT(
      [&] {
        read_tum_sequence(
            make_tum_folder(root / "c", replace("groundtruth.txt", 0, "1305031098.6659 1.3 0.6")));
      },
      ThrowsMessage<InputError>(HasSubstr("groundtruth.txt:4")));
}

}  // namespace
}  // namespace locard
