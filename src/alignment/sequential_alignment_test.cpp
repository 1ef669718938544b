// Whole-sequence alignment on reduced inputs: a simulated bedroom turn with exact ground truth
// (fewer views than the 50-view demo, whose numbers are in docs/benchmarks.md), a blank frame
// that must be reported and left out, and the first 7-Scenes frames.
#include <locard/alignment/alignment_defaults.hpp>
#include <locard/alignment/sequential_alignment.hpp>
#include <locard/alignment/stage_report.hpp>
#include <locard/alignment/trajectory_eval.hpp>

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/sim/scan_writer.hpp>
#include <locard/sim/scene.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace locard {
namespace {

namespace fs = std::filesystem;

constexpr int kTestViews = 30;  // 12 degrees of yaw between views

// The bedroom turn with kTestViews views, written once per test process (ctest runs every test
// of this binary in a process of its own, two at a time: a folder shared between processes was
// deleted and rewritten by one test while another read it).
const fs::path& bedroom() {
  static const fs::path folder = [] {
    const fs::path f = test::process_scratch_dir("alignment-bedroom-" + std::to_string(kTestViews)) / "scan";
    sim::Scene scene = sim::builtin_scene("bedroom");
    scene.scanner.set_rings(kTestViews, {-10.0});  // one ring, as the bedroom had before its downward ring
    sim::write_simulated_scan(scene, f);
    return f;
  }();
  return folder;
}

double ate(const RgbdSequence& seq, const AlignmentResult& r) {
  AssociationOptions a;
  a.match_by_frame_index = true;
  return absolute_trajectory_error(seq.ground_truth, r.trajectory(0), a).translation.rmse;
}

TEST(SequentialAlignment, BedroomTurnCumulativeStagesAndLoopClosure) {
  const RgbdSequence seq = open_rgbd_sequence(bedroom());
  ASSERT_EQ(seq.frames.size(), static_cast<std::size_t>(kTestViews));
  AlignmentOptions o;
  o.mode = AlignmentMode::Cumulative;
  const AlignmentResult r = align_sequence(seq, o);
  // The self-check passes every view of a correct turn (each within 0.5 mm of the truth).
  EXPECT_TRUE(r.flagged_frame_indices().empty());
  EXPECT_TRUE(r.enough_trusted());
  for (const FrameAlignment& f : r.frames) {
    EXPECT_TRUE(f.check.checked) << f.frame_index;
    EXPECT_GT(f.check.confidence, 0.0) << f.frame_index << ": " << f.check.reason;
    EXPECT_LT(f.check.correction_m, 0.01) << f.frame_index;
  }
  EXPECT_EQ(r.pieces, 1u);
  EXPECT_TRUE(r.unregistered_frame_indices().empty());
  ASSERT_EQ(r.trajectory().size(), seq.frames.size());
  // The first/last overlap of the turn is closed by a verified, kept loop edge.
  bool closed = false;
  for (const LoopCandidate& c : r.loops)
    closed |= c.accepted && c.target == 0 && c.source == seq.frames.size() - 1;
  EXPECT_TRUE(closed);
  EXPECT_TRUE(r.pose_graph.success) << r.pose_graph.reason;

  const StageReport report = make_stage_report(r, seq);
  ASSERT_TRUE(report.has_ground_truth);
  const StageSummary& svd = report.summary[0];
  const StageSummary& icp = report.summary[1];
  const StageSummary& lc = report.summary[2];
  ASSERT_TRUE(svd.ate_rmse_m && icp.ate_rmse_m && lc.ate_rmse_m);
  EXPECT_GT(svd.mean_translation_m, icp.mean_translation_m);
  EXPECT_GT(icp.mean_translation_m, lc.mean_translation_m);
  EXPECT_LE(*lc.ate_rmse_m, 0.005);
  EXPECT_NEAR(ate(seq, r), *lc.ate_rmse_m, 1e-12);
  for (const StageViewError& v : report.views) {
    ASSERT_TRUE(v.rotation_deg[2]);
    EXPECT_LT(*v.rotation_deg[2], 0.5) << "frame " << v.frame_index;
  }

  // Same input, same options: the same poses bit for bit.
  const AlignmentResult again = align_sequence(seq, o);
  const Trajectory a = r.trajectory(), b = again.trajectory();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_EQ(a[i].T_world_camera.matrix(), b[i].T_world_camera.matrix()) << i;

  // Report files: JSON and an SVG with one line per stage.
  const fs::path out = test::scratch_dir();
  write_stage_report_json(out / "stage.json", r, report);
  write_stage_report_svg(out / "stage.svg", r, report);
  std::ifstream svg(out / "stage.svg");
  const std::string text((std::istreambuf_iterator<char>(svg)), {});
  EXPECT_NE(text.find("<svg"), std::string::npos);
  EXPECT_NE(text.find("after loop closure"), std::string::npos);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n') > 10, true);
}

// Twelve views, 30 degrees apart with 1 degree of yaw jitter: a rectangular room fits such a
// view turned back onto what the model already holds, or 90 and 180 degrees round, about as
// well as the true pose at the model's edge. Feature inits did exactly that here (views 9-11
// off by 0.1-1.6 m and up to 45 degrees, caught only by the self-check); tripod tracking
// turns forward about the pan axis and keeps every view within 0.2 degree and 5 mm.
TEST(SequentialAlignment, WideStepTurnTracksEveryViewOnTheTripod) {
  const fs::path folder = test::scratch_dir() / "bedroom-12";
  sim::Scene scene = sim::builtin_scene("bedroom");
  scene.scanner.set_rings(12, {-10.0});  // one ring, as the bedroom had before its downward ring
  sim::write_simulated_scan(scene, folder);
  const RgbdSequence seq = open_rgbd_sequence(folder);
  AlignmentOptions o;
  o.mode = AlignmentMode::Cumulative;
  const AlignmentResult r = align_sequence(seq, o);
  EXPECT_TRUE(r.unregistered_frame_indices().empty());
  EXPECT_TRUE(r.flagged_frame_indices().empty());
  for (const FrameAlignment& f : r.frames)
    if (f.frame_index > 0) {
      EXPECT_NE(f.initialisation.find("tripod"), std::string::npos) << f.frame_index;
    }
  const StageReport report = make_stage_report(r, seq);
  for (const StageViewError& v : report.views) {
    ASSERT_TRUE(v.rotation_deg[2] && v.translation_m[2]) << v.frame_index;
    EXPECT_LT(*v.rotation_deg[2], 0.2) << "frame " << v.frame_index;
    EXPECT_LT(*v.translation_m[2], 0.005) << "frame " << v.frame_index;
  }
  EXPECT_LE(ate(seq, r), 0.003);
}

// A copy of the bedroom scan (in a scratch folder named `name`) whose view `view` has every
// depth pixel at `depth_m` (0: no measurement at all).
RgbdSequence bedroom_with_flat_depth(const std::string& name, std::size_t view, double depth_m) {
  const fs::path copy = test::scratch_dir() / name;
  fs::copy(bedroom(), copy, fs::copy_options::recursive);
  const RgbdSequence original = open_rgbd_sequence(copy);
  DepthImage flat = original.load_depth(view);
  std::fill(flat.data().begin(), flat.data().end(),
            static_cast<std::uint16_t>(std::lround(depth_m * original.depth_scale)));
  write_png(original.frames[view].depth_path, flat);
  return open_rgbd_sequence(copy);
}

// A frame whose depth is all zero (covered lens) is reported by index and left out; the frames
// around it are still aligned.
TEST(SequentialAlignment, BlankFrameIsReportedNotGuessed) {
  const std::size_t blank = 7;
  const RgbdSequence seq = bedroom_with_flat_depth("blank", blank, 0.0);
  AlignmentOptions o;
  o.max_frames = 12;
  o.loop_closure = false;
  const AlignmentResult r = align_sequence(seq, o);
  ASSERT_EQ(r.frames.size(), 12u);
  EXPECT_EQ(r.frames[blank].status, FrameStatus::Unusable);
  EXPECT_NE(r.frames[blank].reason.find("depth"), std::string::npos) << r.frames[blank].reason;
  EXPECT_FALSE(r.frames[blank].T_world_camera_final.has_value());
  // Frames just after the gap may fail too (24 degrees to the last registered view); each is
  // reported with its reason, none is given a guessed pose.
  const auto missing = r.unregistered_frame_indices();
  EXPECT_NE(std::find(missing.begin(), missing.end(), seq.frames[blank].frame_index),
            missing.end());
  for (const FrameAlignment& f : r.frames)
    if (f.status != FrameStatus::Registered) {
      EXPECT_FALSE(f.reason.empty()) << f.frame_index;
      EXPECT_FALSE(f.T_world_camera_final.has_value()) << f.frame_index;
    }
  // The trajectory holds the trusted views only: a view the self-check flags (here possibly
  // the one after the gap, with the least overlap) is reported with its reason instead.
  const auto flagged = r.flagged_frame_indices();
  for (const FrameAlignment& f : r.frames)
    if (f.status == FrameStatus::Registered && !f.trusted()) {
      EXPECT_FALSE(f.check.reason.empty()) << f.frame_index;
    }
  const Trajectory t = r.trajectory();
  EXPECT_EQ(t.size() + missing.size() + flagged.size(), 12u);
  EXPECT_LE(flagged.size(), 2u);
  for (const StampedPose& p : t) EXPECT_NE(p.frame_index, seq.frames[blank].frame_index);
}

// A view of a bare wall (constant depth: a plane facing the camera) fixes neither the slide
// along the wall nor the turn about its normal; it must never be trusted as registered.
TEST(SequentialAlignment, BareWallViewIsNeverTrusted) {
  const std::size_t wall = 6;
  const RgbdSequence seq = bedroom_with_flat_depth("bare-wall", wall, 1.2);
  AlignmentOptions o;
  o.max_frames = 12;
  o.loop_closure = false;
  const AlignmentResult r = align_sequence(seq, o);
  ASSERT_EQ(r.frames.size(), 12u);
  const FrameAlignment& f = r.frames[wall];
  EXPECT_FALSE(f.trusted()) << "constraint " << f.check.constraint;
  if (f.status == FrameStatus::Registered) {
    EXPECT_TRUE(f.check.checked);
    EXPECT_FALSE(f.check.reason.empty());
  }
  std::printf("bare wall view: %s, %s\n", std::string(to_string(f.status)).c_str(),
              (f.status == FrameStatus::Registered ? f.check.reason : f.reason).c_str());
  const Trajectory t = r.trajectory();
  for (const StampedPose& p : t) EXPECT_NE(p.frame_index, seq.frames[wall].frame_index);
}

TEST(SequentialAlignment, OptionsAndEmptyInputAreChecked) {
  RgbdSequence empty;
  empty.root = "/nowhere";
  EXPECT_THROW(align_sequence(empty, {}), InputError);
  const RgbdSequence seq = open_rgbd_sequence(bedroom());
  AlignmentOptions o;
  o.voxel_size = 0.0;
  EXPECT_THROW(align_sequence(seq, o), InputError);
  o = {};
  o.first_frame = 1000;
  EXPECT_THROW(align_sequence(seq, o), InputError);
  EXPECT_EQ(parse_alignment_mode("odometry"), AlignmentMode::Odometry);
  EXPECT_FALSE(parse_alignment_mode("slam").has_value());
}

// Real handheld data: the first 7-Scenes frames (30 Hz) in odometry mode.
TEST(SequentialAlignment, SevenScenesFirstFramesOdometry) {
  const fs::path data = test::shared_data() / "7scenes-tsdf-fusion" / "data";
  if (!fs::exists(data)) GTEST_SKIP() << data << " is missing";
  const RgbdSequence seq = open_rgbd_sequence(data);
  AlignmentOptions o;
  o.mode = AlignmentMode::Odometry;
  o.max_frames = 60;
  const AlignmentResult r = align_sequence(seq, o);
  EXPECT_TRUE(r.unregistered_frame_indices().empty());
  EXPECT_EQ(r.pieces, 1u);
  EXPECT_LT(ate(seq, r), 0.02);
}

// Real hand-held video with motion-capture ground truth, aligned with the data's own defaults
// (no flags): every frame registered and verified (a desk's clutter fixes every view), and the
// trajectory within the 12 mm of the motion capture. The self-check once held video to
// the tripod's rotation-only bound and flagged all 50 frames of this desk.
TEST(SequentialAlignment, TumDeskVideoWithDataDefaultsIsVerified) {
  const fs::path data = test::shared_data() / "tum-fr2-desk-50";
  if (!fs::exists(data)) GTEST_SKIP() << data << " is missing";
  const RgbdSequence seq = open_rgbd_sequence(data);
  const AlignmentOptions o = default_alignment_options(seq.traits);
  ASSERT_EQ(o.mode, AlignmentMode::Odometry);
  const AlignmentResult r = align_sequence(seq, o);
  EXPECT_EQ(r.pieces, 1u);
  EXPECT_TRUE(r.unregistered_frame_indices().empty());
  EXPECT_TRUE(r.flagged_frame_indices().empty());
  EXPECT_TRUE(r.enough_trusted());
  EXPECT_LT(absolute_trajectory_error(seq.ground_truth, r.trajectory(0), {}).translation.rmse, 0.012);
}

// A bare wall in the middle of hand-held video (constant depth: a plane facing the camera): six
// degrees of freedom, of which the plane fixes three. Never trusted.
TEST(SequentialAlignment, BareWallViewIsNeverTrustedInVideo) {
  const std::size_t wall = 6;
  const RgbdSequence seq = bedroom_with_flat_depth("bare-wall-video", wall, 1.2);
  AlignmentOptions o;
  o.mode = AlignmentMode::Odometry;
  o.max_frames = 12;
  o.loop_closure = false;
  const AlignmentResult r = align_sequence(seq, o);
  ASSERT_EQ(r.frames.size(), 12u);
  const FrameAlignment& f = r.frames[wall];
  EXPECT_FALSE(f.trusted()) << "constraint " << f.check.constraint;
  if (f.status == FrameStatus::Registered) {
    EXPECT_LT(f.check.constraint, o.view_check.min_constraint_6dof);
    EXPECT_FALSE(f.check.reason.empty());
  }
}

}  // namespace
}  // namespace locard
