// Rooms the pipeline has never seen (issue 13): one generated room of each kind - Kinect v1
// and v2, plain and textured surfaces - reduced to 24 views a ring and at most two rings, aligned
// with the data's own defaults as `locard align` would, and judged against the simulator's exact
// poses the way bench/room_robustness.py judges a room: the verified views fitted to the truth
// (rotation by chordal mean, then translation). The property held for every room, whatever else
// it gets right: no verified view more than 2 degrees or 5 cm off (a wrong model never claims to
// be right). Flagged views are allowed; each must carry its reason.
#include <locard/alignment/alignment_defaults.hpp>
#include <locard/alignment/sequential_alignment.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/sim/random_scene.hpp>
#include <locard/sim/scan_writer.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>

namespace locard {
namespace {

namespace fs = std::filesystem;

struct Judgement {
  std::size_t verified = 0, flagged = 0, silent = 0;
  double worst_deg = 0.0, worst_m = 0.0;
  double ate_m = 0.0;  // RMS position error of the verified views
};

Judgement judge(const RgbdSequence& seq, const AlignmentResult& r) {
  Judgement j;
  std::vector<std::size_t> verified;
  for (std::size_t i = 0; i < r.frames.size(); ++i) {
    if (r.frames[i].trusted()) verified.push_back(i);
    else {
      ++j.flagged;
      const FrameAlignment& f = r.frames[i];
      EXPECT_FALSE((f.status == FrameStatus::Registered ? f.check.reason : f.reason).empty())
          << "frame " << f.frame_index << " left out without a reason";
    }
  }
  j.verified = verified.size();
  if (verified.size() < 2) return j;
  std::vector<Isometry3d> estimate, truth;
  for (std::size_t i : verified) {
    estimate.push_back(*r.frames[i].T_world_camera_final);
    truth.push_back(seq.ground_truth[r.frames[i].sequence_index].T_world_camera);
  }
  for (const auto& [deg, m] : test::errors_after_fit(estimate, truth)) {
    j.worst_deg = std::max(j.worst_deg, deg);
    j.worst_m = std::max(j.worst_m, m);
    j.silent += deg > 2.0 || m > 0.05;
    j.ate_m += m * m;
  }
  j.ate_m = std::sqrt(j.ate_m / static_cast<double>(verified.size()));
  return j;
}

using RoomKind = std::tuple<std::uint64_t, sim::ScannerModel, sim::SurfaceKind>;

class GeneratedRoom : public ::testing::TestWithParam<RoomKind> {};

TEST_P(GeneratedRoom, NoWrongViewIsVerified) {
  const auto [seed, sensor, surfaces] = GetParam();
  sim::Scene scene = sim::random_scene(seed, {sensor, surfaces});
  scene.scanner.views = 24;
  if (scene.scanner.pitch_deg.size() > 2) scene.scanner.pitch_deg.resize(2);
  const fs::path folder = test::scratch_dir() / ("generated-room-" + std::to_string(seed));
  sim::write_simulated_scan(scene, folder);
  const RgbdSequence seq = open_rgbd_sequence(folder);
  const AlignmentOptions o = default_alignment_options(seq.traits);
  ASSERT_EQ(o.mode, AlignmentMode::Cumulative) << "a tripod scan is aligned as a tripod turn";
  const AlignmentResult r = align_sequence(seq, o);
  const Judgement j = judge(seq, r);
  std::printf("room %llu (%s): %zu verified, %zu flagged, worst verified %.1f mm / %.2f deg\n",
              static_cast<unsigned long long>(seed), sim::random_scene_summary(scene).c_str(),
              j.verified, j.flagged, 1000.0 * j.worst_m, j.worst_deg);
  EXPECT_EQ(j.silent, 0u) << "verified views more than 2 degrees / 5 cm off the truth";
  EXPECT_EQ(j.verified + j.flagged, r.frames.size());
  // The exit status follows the share: what the CLI would report.
  EXPECT_EQ(r.enough_trusted(), static_cast<double>(j.verified) >=
                                    o.min_verified_share * static_cast<double>(r.usable_frames()));
}

// Generated room 75 as `locard scan-sim --random 75` draws it: Kinect v2, noise-textured walls,
// one ring of 43 views, the tripod 0.8 m from two walls. Past view 5 tracking meets a near bare
// wall whose data do not fix the slide along it (the noise texture's gradients only seem to);
// a slide the light prior let the data decide was kept while it stayed within 2 cm of the
// firm prior's, and every later view's prior started from it: tracked views walked 94 mm off,
// 35 of 43 were flagged and the 8 verified ones stood 4.7 mm ATE from the truth. A slide the
// view's own points do not fix is now held by the tripod whatever its size.
TEST(GeneratedRoomTracking, ASlideAlongABareWallIsNotCarriedAlongTheTurn) {
  const sim::Scene scene = sim::random_scene(75);
  ASSERT_EQ(scene.scanner.views, 43) << "the draw of seed 75 changed: " << sim::random_scene_summary(scene);
  const fs::path folder = test::scratch_dir() / "generated-room-75";
  sim::write_simulated_scan(scene, folder);
  const RgbdSequence seq = open_rgbd_sequence(folder);
  const AlignmentResult r = align_sequence(seq, default_alignment_options(seq.traits));
  std::vector<Isometry3d> tracked, truth;
  for (const FrameAlignment& f : r.frames)
    if (f.T_world_camera_icp) {
      tracked.push_back(*f.T_world_camera_icp);
      truth.push_back(seq.ground_truth[f.sequence_index].T_world_camera);
    }
  double worst_tracked_m = 0.0;
  for (const auto& [deg, m] : test::errors_after_fit(tracked, truth)) worst_tracked_m = std::max(worst_tracked_m, m);
  EXPECT_LT(worst_tracked_m, 0.05) << "tracking carried a slide along the turn";  // was 94 mm
  const Judgement j = judge(seq, r);
  EXPECT_EQ(j.silent, 0u);
  EXPECT_GE(j.verified, 16u);  // was 8 of 43
  EXPECT_LT(j.worst_m, 0.01);
  EXPECT_LT(j.ate_m, 0.003);  // was 4.7 mm
}

// Generated room 33 (Kinect v1, plain walls, three rings of 44 views, the tripod 0.7 m from one
// wall), its first ring and the start of the second. Two ways one bare wall broke the turn:
// - view 27 sees little but that wall, aslant. Its ICP with the light prior turned 37 degrees
//   about the wall's normal, which one plane leaves free, and was dropped as off its guess's
//   basin, the firm prior never tried: views 27-36 failed, the turn broke in two pieces;
// - view 0 sees the wall alone too, and the first step (the pan axis not yet known) left it
//   rolled 7.7 degrees against every later view. The second ring was entered from view 0 as
//   tracked, and carried its roll (whole room: registered views 922 mm ATE, then 18 mm).
TEST(GeneratedRoomTracking, AWallSeenAloneDoesNotBreakTheTurn) {
  sim::Scene scene = sim::random_scene(33);
  ASSERT_EQ(scene.scanner.views, 44) << "the draw of seed 33 changed: " << sim::random_scene_summary(scene);
  scene.scanner.pitch_deg.resize(2);
  const fs::path folder = test::scratch_dir() / "generated-room-33";
  sim::write_simulated_scan(scene, folder);
  const RgbdSequence seq = open_rgbd_sequence(folder);
  AlignmentOptions o = default_alignment_options(seq.traits);
  o.max_frames = 52;  // the first ring and 8 views of the second
  const AlignmentResult r = align_sequence(seq, o);
  std::vector<Isometry3d> tracked, truth;
  for (const FrameAlignment& f : r.frames) {
    EXPECT_TRUE(f.T_world_camera_icp.has_value()) << "view " << f.frame_index << " not tracked: " << f.reason;
    if (f.T_world_camera_icp) {
      tracked.push_back(*f.T_world_camera_icp);
      truth.push_back(seq.ground_truth[f.sequence_index].T_world_camera);
    }
  }
  double worst_deg = 0.0;
  for (const auto& [deg, m] : test::errors_after_fit(tracked, truth)) worst_deg = std::max(worst_deg, deg);
  std::vector<Isometry3d> solved;
  for (const FrameAlignment& f : r.frames)
    if (f.T_world_camera_final) solved.push_back(*f.T_world_camera_final);
  ASSERT_EQ(solved.size(), truth.size());
  double worst_solved_deg = 0.0;
  for (const auto& [deg, m] : test::errors_after_fit(solved, truth)) worst_solved_deg = std::max(worst_solved_deg, deg);
  std::printf("worst tracked %.2f deg, worst solved %.2f deg\n", worst_deg, worst_solved_deg);
  EXPECT_LT(worst_deg, 2.0) << "tracking turned part of the turn off the rest";
  EXPECT_LT(worst_solved_deg, 0.5);
}

std::string room_name(const ::testing::TestParamInfo<RoomKind>& room) {
  return "seed" + std::to_string(std::get<0>(room.param)) + "_" +
         std::string(sim::to_string(std::get<1>(room.param))) + "_" +
         std::string(sim::to_string(std::get<2>(room.param)));
}

INSTANTIATE_TEST_SUITE_P(
    EachKind, GeneratedRoom,
    ::testing::Values(RoomKind{1001, sim::ScannerModel::KinectV1, sim::SurfaceKind::Plain},
                      RoomKind{1002, sim::ScannerModel::KinectV1, sim::SurfaceKind::Textured},
                      RoomKind{1003, sim::ScannerModel::KinectV2, sim::SurfaceKind::Plain},
                      RoomKind{1004, sim::ScannerModel::KinectV2, sim::SurfaceKind::Textured}),
    room_name);

}  // namespace
}  // namespace locard
