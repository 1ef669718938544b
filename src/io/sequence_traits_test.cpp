// Sequence traits read from the data (docs/sensors.md): every shared dataset, scan-sim's
// capture.json and simulation.json, renamed folders, TUM association lists and ICL-NUIM's
// negative fy checked against its exact poses.
#include <locard/io/rgbd_sequence.hpp>

#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/preprocess/depth_to_points.hpp>

#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

fs::path data(const std::string& name) { return test::shared_data() / name; }

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

void expect_traits(const SequenceTraits& t, DepthSensorKind sensor, CaptureKind capture,
                   bool registered) {
  EXPECT_EQ(t.sensor, sensor) << t.source;
  EXPECT_EQ(t.capture, capture) << t.source;
  EXPECT_EQ(t.color_registered_to_depth, registered) << t.source;
  EXPECT_FALSE(t.source.empty());
}

TEST(SequenceTraits, SevenScenesIsHandHeldKinectV1WithUnregisteredColour) {
  const RgbdSequence s = open_rgbd_sequence(data("7scenes-tsdf-fusion") / "data");
  expect_traits(s.traits, DepthSensorKind::StructuredLight, CaptureKind::HandHeldVideo, false);
  EXPECT_TRUE(s.traits.ring_sizes.empty());
}

TEST(SequenceTraits, TumSequencesAreStructuredLightVideo) {
  for (const char* name : {"tum-fr2-desk-50", "tum-fr3-office-16"}) {
    const RgbdSequence s = open_rgbd_sequence(data(name));
    SCOPED_TRACE(name);
    expect_traits(s.traits, DepthSensorKind::StructuredLight, CaptureKind::HandHeldVideo, true);
    EXPECT_THAT(s.traits.source, HasSubstr("median frame interval 0.03"));
  }
}

TEST(SequenceTraits, RedwoodFramesAreStructuredLightVideo) {
  const RgbdSequence s = open_rgbd_sequence(data("open3d-testdata") / "RGBD");
  expect_traits(s.traits, DepthSensorKind::StructuredLight, CaptureKind::HandHeldVideo, true);
}

TEST(SequenceTraits, IclNuimIsSyntheticWithWidelySpacedViews) {
  const RgbdSequence s = open_rgbd_sequence(data("iclnuim-livingroom-5"));
  // Five samples tens of degrees apart: not a stream, and nothing says tripod.
  expect_traits(s.traits, DepthSensorKind::Synthetic, CaptureKind::Unknown, true);
  EXPECT_EQ(s.frames.size(), 5u);
  EXPECT_DOUBLE_EQ(s.depth_scale, 5000.0);
  EXPECT_EQ(s.ground_truth_source, "pose.txt");
  ASSERT_EQ(s.ground_truth.size(), 5u);
}

// The traits come from the data, so a misleading folder name changes nothing (only the
// documented intrinsics fallback of TUM folders reads the name).
TEST(SequenceTraits, RenamedFoldersGiveTheSameTraits) {
  const fs::path root = test::scratch_dir();
  for (const char* name : {"tum-fr2-desk-50", "tum-fr3-office-16", "iclnuim-livingroom-5"}) {
    SCOPED_TRACE(name);
    const fs::path link = root / (std::string("kinect_v2_tripod_") + name);
    fs::create_directory_symlink(data(name), link);
    const RgbdSequence original = open_rgbd_sequence(data(name));
    const RgbdSequence renamed = open_rgbd_sequence(link);
    EXPECT_EQ(renamed.traits.sensor, original.traits.sensor);
    EXPECT_EQ(renamed.traits.capture, original.traits.capture);
    EXPECT_EQ(renamed.traits.color_registered_to_depth,
              original.traits.color_registered_to_depth);
    EXPECT_EQ(renamed.frames.size(), original.frames.size());
  }
  const fs::path seven = root / "rgbd_dataset_freiburg1_tripod";
  fs::create_directory_symlink(data("7scenes-tsdf-fusion") / "data", seven);
  expect_traits(open_rgbd_sequence(seven).traits, DepthSensorKind::StructuredLight,
                CaptureKind::HandHeldVideo, false);
}

// ---- scan-sim outputs: a small TUM folder (index only) with the simulator's files.

fs::path make_sim_folder(const fs::path& folder, std::size_t views) {
  fs::create_directories(folder);
  std::string rgb, depth;
  for (std::size_t i = 0; i < views; ++i) {
    const std::string t = std::to_string(i) + ".0";  // one view a second: no video timing
    rgb += t + " rgb/" + std::to_string(i) + ".png\n";
    depth += t + " depth/" + std::to_string(i) + ".png\n";
  }
  write_text(folder / "rgb.txt", rgb);
  write_text(folder / "depth.txt", depth);
  return folder;
}

TEST(SequenceTraits, CaptureJsonOfScanSim) {
  const fs::path folder = make_sim_folder(test::scratch_dir() / "fr1_video", 6);
  write_text(folder / "capture.json",
             R"({"sensor": "kinect_v2", "depth_sensor": "time_of_flight", "capture": )"
             R"("tripod_turn", "color_registered_to_depth": true, "ring_sizes": [4, 2]})");
  const RgbdSequence s = open_rgbd_sequence(folder);
  expect_traits(s.traits, DepthSensorKind::TimeOfFlight, CaptureKind::TripodTurn, true);
  EXPECT_THAT(s.traits.ring_sizes, ElementsAre(4u, 2u));
  EXPECT_THAT(s.traits.source, HasSubstr("capture.json"));
}

TEST(SequenceTraits, BadCaptureJsonNamesFileAndKey) {
  const fs::path root = test::scratch_dir();
  const auto error_of = [&](const std::string& name, const std::string& json) {
    const fs::path folder = make_sim_folder(root / name, 6);
    write_text(folder / "capture.json", json);
    try {
      open_rgbd_sequence(folder);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string good_tail = R"("capture": "tripod_turn", "color_registered_to_depth": true)";
  EXPECT_THAT(error_of("a", R"({"depth_sensor": 3, )" + good_tail + "}"),
              AllOf(HasSubstr("capture.json"), HasSubstr("\"depth_sensor\" must be a string")));
  EXPECT_THAT(error_of("b", R"({"depth_sensor": "lidar", )" + good_tail + "}"),
              AllOf(HasSubstr("capture.json"), HasSubstr("lidar")));
  EXPECT_THAT(error_of("c", R"({"sensor": "kinect_v2", "capture": "tripod_turn", )"
                            R"("color_registered_to_depth": "yes"})"),
              AllOf(HasSubstr("capture.json"), HasSubstr("color_registered_to_depth")));
  EXPECT_THAT(error_of("d", R"({"sensor": "kinect_v2", )" + good_tail +
                                R"(, "ring_sizes": [4, -2]})"),
              AllOf(HasSubstr("capture.json"), HasSubstr("\"ring_sizes\"[1]")));
  EXPECT_THAT(error_of("e", R"({"sensor": "kinect_v2", )" + good_tail +
                                R"(, "ring_sizes": [4, 4]})"),
              AllOf(HasSubstr("capture.json"), HasSubstr("add up to 8"), HasSubstr("6 depth")));
  EXPECT_THAT(error_of("f", R"({"sensor": "kinect_v1", "depth_sensor": "time_of_flight", )" +
                                good_tail + "}"),
              AllOf(HasSubstr("capture.json"), HasSubstr("structured_light")));
  EXPECT_THAT(error_of("g", R"({"sensor": "kinect_v2", "color_registered_to_depth": true})"),
              AllOf(HasSubstr("capture.json"), HasSubstr("\"capture\"")));
  EXPECT_THAT(error_of("h", "[1, 2"), AllOf(HasSubstr("capture.json"), HasSubstr("JSON")));
}

TEST(SequenceTraits, OlderScanSimOutputFromSimulationJson) {
  const fs::path folder = make_sim_folder(test::scratch_dir() / "hand_held", 6);
  write_text(folder / "simulation.json",
             R"({"generator": "locard scan-sim", "views": 6, "views_per_pitch_row": 3, )"
             R"("pitch_deg": [0, 20], "sensor": {"model": "kinect_v2", "depth_scale": 1000}})");
  const RgbdSequence s = open_rgbd_sequence(folder);
  expect_traits(s.traits, DepthSensorKind::TimeOfFlight, CaptureKind::TripodTurn, true);
  EXPECT_THAT(s.traits.ring_sizes, ElementsAre(3u, 3u));
  EXPECT_THAT(s.traits.source, HasSubstr("simulation.json"));
}

TEST(SequenceTraits, TumLayoutWithoutEvidenceOfVideoHasUnknownCapture) {
  const RgbdSequence s = open_rgbd_sequence(make_sim_folder(test::scratch_dir() / "x", 4));
  expect_traits(s.traits, DepthSensorKind::StructuredLight, CaptureKind::Unknown, true);
  EXPECT_THAT(s.traits.source, HasSubstr("median frame interval 1.000 s"));
}

// ---- TUM association lists

TEST(TumAssociation, ReadsFr2DeskWithItsPosePerFrame) {
  const RgbdSequence s = open_rgbd_sequence(data("tum-fr2-desk-50"));
  EXPECT_EQ(s.format, DatasetFormat::Tum);
  ASSERT_EQ(s.frames.size(), 50u);
  ASSERT_EQ(s.ground_truth.size(), 50u);
  EXPECT_THAT(s.ground_truth_source, HasSubstr("associate.txt"));
  // Line 1: 1311868164.363181 rgb/1311868164.363181.png 1311868164.373557
  //         depth/1311868164.373557.png 1311868164.363200 -0.1546 -1.4445 1.4773 0.6529 -0.5483
  //         0.3248 -0.4095
  const FrameEntry& f = s.frames[0];
  EXPECT_DOUBLE_EQ(f.timestamp, 1311868164.373557);
  EXPECT_EQ(f.depth_path, data("tum-fr2-desk-50") / "depth" / "1311868164.373557.png");
  EXPECT_EQ(f.color_path, data("tum-fr2-desk-50") / "rgb" / "1311868164.363181.png");
  ASSERT_TRUE(f.T_world_camera);
  EXPECT_NEAR(f.T_world_camera->translation().x(), -0.1546, 1e-12);
  EXPECT_NEAR(f.T_world_camera->translation().z(), 1.4773, 1e-12);
  const Eigen::Quaterniond q(f.T_world_camera->rotation());
  EXPECT_NEAR(std::abs(q.w()), 0.4095, 1e-4);
  EXPECT_DOUBLE_EQ(s.ground_truth[0].timestamp, 1311868164.3632);
  for (const FrameEntry& e : s.frames) EXPECT_TRUE(e.T_world_camera.has_value());
  const RgbdFrame loaded = s.load_frame(49);
  EXPECT_EQ(loaded.depth.width(), 640);
  EXPECT_DOUBLE_EQ(loaded.depth_scale, 5000.0);
}

TEST(TumAssociation, Fr3OfficeKeepsTheFramesItHasAndTheWholeGroundTruth) {
  const RgbdSequence s = open_rgbd_sequence(data("tum-fr3-office-16"));
  EXPECT_EQ(s.frames.size(), 16u);
  // depth.txt lists 2509 frames, the copy holds the first 16 images.
  EXPECT_EQ(s.frames.size() + s.absent_tail_frames + s.dropped_frames, 2509u);
  EXPECT_GT(s.absent_tail_frames, 2400u);
  EXPECT_EQ(s.ground_truth.size(), 8710u);
  // Ground truth starts 67 ms after the first image: the first two frames have none in 20 ms.
  EXPECT_FALSE(s.frames[0].T_world_camera);
  EXPECT_FALSE(s.frames[1].T_world_camera);
  EXPECT_TRUE(s.frames[2].T_world_camera);
  EXPECT_NO_THROW(s.load_frame(15));
}

TEST(TumAssociation, BothOrdersGiveTheSamePairs) {
  const fs::path root = test::scratch_dir();
  fs::create_directories(root / "c");
  fs::create_directories(root / "d");
  write_text(root / "c" / "associate.txt",
             "# rgb first\n"
             "1.00 rgb/a.png 1.01 depth/a.png\n"
             "1.03 rgb/b.png 1.04 depth/b.png\n");
  write_text(root / "d" / "associations.txt",
             "1.01 depth/a.png 1.00 rgb/a.png\n"
             "1.04 depth/b.png 1.03 rgb/b.png\n");
  const RgbdSequence c = open_rgbd_sequence(root / "c");
  const RgbdSequence d = open_rgbd_sequence(root / "d");
  ASSERT_EQ(c.frames.size(), 2u);
  ASSERT_EQ(d.frames.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(c.frames[i].depth_path.filename(), d.frames[i].depth_path.filename());
    EXPECT_EQ(c.frames[i].depth_path.parent_path().filename(), "depth");
    EXPECT_EQ(d.frames[i].color_path.parent_path().filename(), "rgb");
    EXPECT_DOUBLE_EQ(c.frames[i].timestamp, d.frames[i].timestamp);
  }
  EXPECT_DOUBLE_EQ(c.frames[1].timestamp, 1.04);
  EXPECT_FALSE(c.has_ground_truth());
}

TEST(TumAssociation, MalformedLinesNameFileAndLine) {
  const fs::path root = test::scratch_dir();
  const auto error_of = [&](const std::string& name, const std::string& text) {
    fs::create_directories(root / name);
    write_text(root / name / "associate.txt", text);
    try {
      open_rgbd_sequence(root / name);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string first = "1.00 rgb/a.png 1.01 depth/a.png\n";
  EXPECT_THAT(error_of("a", first + "1.03 rgb/b.png 1.04\n"),
              AllOf(HasSubstr("associate.txt:2"), HasSubstr("found 3 values")));
  EXPECT_THAT(error_of("b", first + "1.0x rgb/b.png 1.04 depth/b.png\n"),
              AllOf(HasSubstr("associate.txt:2"), HasSubstr("1.0x")));
  EXPECT_THAT(error_of("c", first + "1.03 x/b.png 1.04 y/b.png\n"),
              AllOf(HasSubstr("associate.txt:2"), HasSubstr("colour and which the depth")));
  EXPECT_THAT(error_of("d", first + "0.90 rgb/b.png 0.91 depth/b.png\n"),
              HasSubstr("associate.txt:2"));
  EXPECT_THAT(error_of("e", first + "1.03 rgb/b.png 1.04 depth/b.png 1.04 0 0 0 0 0 0 2\n"),
              AllOf(HasSubstr("associate.txt:2"), HasSubstr("quaternion")));
}

// ---- ICL-NUIM: fy = -480 (image y up). The reader turns it into the same camera with y down
// and conjugates the exact poses; back-projected views must then land on each other.

PointCloud world_points(const RgbdSequence& s, std::size_t i, const Isometry3d& T) {
  DepthToPointsOptions o;
  o.stride = 4;
  o.with_color = false;
  return depth_to_points(s.load_frame(i), o, T);
}

// Share of `b`'s points within `radius` of a point of `a`.
double overlap(const PointCloud& a, const PointCloud& b, float radius) {
  const KdTree tree(a.positions);
  std::size_t near = 0;
  for (const Eigen::Vector3f& p : b.positions) {
    Neighbor n;
    near += tree.nearest(p, n) && n.squared_distance < radius * radius;
  }
  return static_cast<double>(near) / static_cast<double>(b.size());
}

TEST(IclNuim, NegativeFyIsFlippedAndTheExactPosesAlignTheViews) {
  const RgbdSequence s = open_rgbd_sequence(data("iclnuim-livingroom-5"));
  EXPECT_DOUBLE_EQ(s.intrinsics.fx, 481.2);
  EXPECT_DOUBLE_EQ(s.intrinsics.fy, 480.0);  // published -480.0, y axis flipped
  EXPECT_DOUBLE_EQ(s.intrinsics.cy, 239.5);
  EXPECT_TRUE(s.intrinsics.valid());
  EXPECT_THAT(s.intrinsics_source, HasSubstr("-480"));
  // pose.txt line 1: t = (0.000466347, 0.00895357, -2.24935); after S T S, t_y is negated.
  const Isometry3d& T0 = *s.frames[0].T_world_camera;
  EXPECT_NEAR(T0.translation().x(), 0.000466347, 1e-12);
  EXPECT_NEAR(T0.translation().y(), -0.00895357, 1e-12);
  EXPECT_NEAR(T0.translation().z(), -2.24935, 1e-12);
  EXPECT_NEAR(T0.linear().determinant(), 1.0, 1e-9);

  // Samples 1, 4 and 5 look at the same wall from 36-39 degrees apart; with the exact poses
  // their surfaces coincide within the sampling (stride 4: points 2.5 cm apart at 3 m) and
  // 1/5000 m quantisation. The poses as written in pose.txt, used with fy = +480 (no
  // conversion, i.e. a mirrored camera), do not align them: the conversion matters.
  Isometry3d S = Isometry3d::Identity();
  S.linear().diagonal() << 1.0, -1.0, 1.0;
  const auto raw = [&](std::size_t i) {
    return Isometry3d(S.matrix() * s.frames[i].T_world_camera->matrix() * S.matrix());
  };
  const PointCloud first = world_points(s, 0, T0);
  const PointCloud first_raw = world_points(s, 0, raw(0));
  for (std::size_t j : {3u, 4u}) {
    SCOPED_TRACE(j);
    const double converted =
        overlap(first, world_points(s, j, *s.frames[j].T_world_camera), 0.05f);
    const double unconverted = overlap(first_raw, world_points(s, j, raw(j)), 0.05f);
    EXPECT_GT(converted, 0.9);     // measured 0.96, 0.98
    EXPECT_LT(unconverted, 0.5);   // measured 0.41, 0.44
  }
}

}  // namespace
}  // namespace locard
