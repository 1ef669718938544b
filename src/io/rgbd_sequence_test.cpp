#include <locard/io/rgbd_sequence.hpp>

#include <locard/core/error.hpp>

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

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

TEST(RgbdSequenceFormat, DetectsCloudAndConfInputs) {
  const fs::path dir = test::scratch_dir();
  write_text(dir / "scan.PLY", "ply\n");
  write_text(dir / "scan.pcd", "# .PCD\n");
  write_text(dir / "notes.txt", "hello\n");
  EXPECT_EQ(detect_format(dir / "scan.PLY"), DatasetFormat::PlyCloud);
  EXPECT_EQ(detect_format(dir / "scan.pcd"), DatasetFormat::PcdCloud);
  EXPECT_EQ(detect_format(dir / "notes.txt"), DatasetFormat::Unknown);
  EXPECT_EQ(detect_format(dir / "missing"), DatasetFormat::Unknown);
  // Two scans (PLY / PCD) and nothing RGB-D: a set of range scans; one alone is not.
  EXPECT_EQ(detect_format(dir), DatasetFormat::RangeScanFolder);
  fs::remove(dir / "scan.pcd");
  EXPECT_EQ(detect_format(dir), DatasetFormat::Unknown);

  const fs::path bunny = test::shared_data() / "stanford-bunny" / "bunny" / "data";
  EXPECT_EQ(detect_format(bunny / "bun.conf"), DatasetFormat::StanfordConf);
  EXPECT_EQ(detect_format(bunny), DatasetFormat::StanfordConf);
}

TEST(RgbdSequenceFormat, OpenRefusesNonSequencesWithReason) {
  const fs::path dir = test::scratch_dir();
  write_text(dir / "scan.ply", "ply\n");
  EXPECT_THAT([&] { open_rgbd_sequence(dir / "scan.ply"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("scan.ply"), HasSubstr("point-cloud input"),
                                              HasSubstr("not an RGB-D sequence"))));
  EXPECT_THAT([&] { open_rgbd_sequence(dir); },
              ThrowsMessage<InputError>(
                  AllOf(HasSubstr("not a recognised RGB-D sequence"), HasSubstr("rgb.txt"))));
  EXPECT_THAT([&] { open_rgbd_sequence(dir / "nowhere"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("nowhere"), HasSubstr("not found"))));
}

TEST(RgbdSequenceFormat, FormatNames) {
  EXPECT_EQ(to_string(DatasetFormat::Tum), "TUM RGB-D");
  EXPECT_EQ(to_string(DatasetFormat::SevenScenes), "7-Scenes");
  EXPECT_EQ(to_string(DatasetFormat::Redwood), "Redwood");
  EXPECT_EQ(to_string(DatasetFormat::Unknown), "unknown");
}

TEST(RgbdSequenceFormat, IntrinsicsFilesRoundTripAndParse) {
  const fs::path dir = test::scratch_dir();
  CameraIntrinsics k = CameraIntrinsics::preset("tum_freiburg1");  // has distortion
  write_intrinsics_json(dir / "intrinsics.json", k, 5000.0);
  const IntrinsicsFile back = read_intrinsics_json_with_scale(dir / "intrinsics.json");
  EXPECT_EQ(back.intrinsics, k);
  ASSERT_TRUE(back.depth_scale);
  EXPECT_DOUBLE_EQ(*back.depth_scale, 5000.0);
  EXPECT_EQ(test::list_folder(dir), "intrinsics.json\n");

  const CameraIntrinsics primesense =
      read_intrinsics_json(test::shared_data() / "open3d-testdata" / "camera_primesense.json");
  EXPECT_EQ(primesense.width, 640);
  EXPECT_DOUBLE_EQ(primesense.fx, 525.0);
  EXPECT_DOUBLE_EQ(primesense.cy, 239.5);

  const CameraIntrinsics seven = read_intrinsics_matrix_txt(
      test::shared_data() / "7scenes-tsdf-fusion" / "data" / "camera-intrinsics.txt", 640, 480);
  EXPECT_DOUBLE_EQ(seven.fx, 585.0);
  EXPECT_DOUBLE_EQ(seven.cx, 320.0);
  EXPECT_EQ(seven.height, 480);
}

TEST(RgbdSequenceFormat, BadIntrinsicsFilesNameTheFile) {
  const fs::path dir = test::scratch_dir();
  write_text(dir / "broken.json", "{\"fx\": 500,");
  EXPECT_THAT([&] { read_intrinsics_json(dir / "broken.json"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("broken.json"), HasSubstr("JSON"))));
  write_text(dir / "partial.json", R"({"width": 640, "height": 480, "fx": 500})");
  EXPECT_THAT([&] { read_intrinsics_json(dir / "partial.json"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("partial.json"), HasSubstr("\"fy\""))));
  write_text(dir / "k.txt", "500 0 320\n0 500 240\n");
  EXPECT_THAT([&] { read_intrinsics_matrix_txt(dir / "k.txt", 640, 480); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("k.txt"), HasSubstr("9 numbers"))));
}

}  // namespace
}  // namespace locard
