// Joint refinement (refine_jointly) on a generated room it has not seen: every view of a
// simulated tripod turn placed at its exact pose, then each moved by a few millimetres and
// tenths of a degree in a random direction - the error tracking leaves (issue 13: 5-15 mm ATE
// before this stage). Refinement must take out the rotation drift and most of the centre
// error (the bar is ATE <= 3 mm, every view within 0.5 degree / 1 cm of the truth after
// the best rigid fit), and must not spoil a turn that is already right. Judged over the views
// the self-check then verifies: in a plain room a bare-wall view's slide is fixed by no
// surface, refinement leaves it to the tripod's nodal model, and the check flags it unless the
// tripod's play is small; in a textured room the colour term fixes it.
#include "alignment/alignment_stages.hpp"

#include <locard/io/rgbd_sequence.hpp>
#include <locard/sim/random_scene.hpp>
#include <locard/sim/scan_writer.hpp>

#include "test_support.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace locard::alignment_detail {
namespace {

namespace fs = std::filesystem;

RgbdSequence generated_turn(std::uint64_t seed, sim::SurfaceKind surfaces = sim::SurfaceKind::Plain) {
  sim::Scene scene = sim::random_scene(seed, {sim::ScannerModel::KinectV2, surfaces});
  scene.scanner.views = 24;
  if (scene.scanner.pitch_deg.size() > 2) scene.scanner.pitch_deg.resize(2);
  const fs::path folder = test::scratch_dir() / ("joint-refinement-" + std::to_string(seed) + "-" +
                                                 std::string(sim::to_string(surfaces)));
  sim::write_simulated_scan(scene, folder);
  return open_rgbd_sequence(folder);
}

// The state after the pose graph with every view registered, in one piece, at `poses`.
struct SolvedState {
  AlignmentOptions options;
  AlignmentState state;
  SolvedState(const RgbdSequence& seq, const std::vector<Isometry3d>& poses)
      : state(seq, options) {
    options.mode = AlignmentMode::Cumulative;
    options.ring_sizes = seq.traits.ring_sizes;
    state.n = seq.frames.size();
    prepare_frames(state);
    for (std::size_t i = 0; i < state.n; ++i) {
      if (!state.prepared[i].unusable.empty()) continue;
      FrameAlignment& f = state.result.frames[i];
      f.status = FrameStatus::Registered;
      f.piece = 0;
      f.T_world_camera_final = poses[i];
      state.registered.push_back(i);
      state.result.node_frames.push_back(i);
      state.result.graph.nodes.push_back(poses[i]);
    }
    state.piece_of.assign(state.n, 0);
    state.piece_count = 1;
  }
};

struct Errors {
  double ate_m = 0.0, worst_m = 0.0, worst_deg = 0.0;
};

// Over the views the self-check verifies (all registered ones before it runs): what the run
// vouches for, as bench/room_robustness.py judges a room.
Errors errors(const AlignmentState& s) {
  std::vector<Isometry3d> estimate, truth;
  for (std::size_t i : s.registered) {
    if (!s.result.frames[i].trusted()) continue;
    estimate.push_back(*s.result.frames[i].T_world_camera_final);
    truth.push_back(s.sequence.ground_truth[i].T_world_camera);
  }
  Errors e;
  for (const auto& [deg, m] : test::errors_after_fit(estimate, truth)) {
    e.ate_m += m * m;
    e.worst_m = std::max(e.worst_m, m);
    e.worst_deg = std::max(e.worst_deg, deg);
  }
  e.ate_m = std::sqrt(e.ate_m / static_cast<double>(estimate.size()));
  return e;
}

void print_refinement(const Errors& before, const Errors& after, const JointRefinement& r) {
  std::printf("before: ATE %.2f mm, worst %.1f mm / %.3f deg; after: ATE %.2f mm, worst %.1f mm / "
              "%.3f deg (%zu pairs, %d steps, %zu held)\n",
              1000 * before.ate_m, 1000 * before.worst_m, before.worst_deg, 1000 * after.ate_m,
              1000 * after.worst_m, after.worst_deg, r.pairs, r.iterations, r.views_held);
}

// Each view moved by `mm` millimetres and `deg` degrees in a random direction (fixed seed).
std::vector<Isometry3d> disturbed(const RgbdSequence& seq, double mm, double deg) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  std::vector<Isometry3d> poses;
  for (const auto& gt : seq.ground_truth) {
    const Eigen::Vector3d axis = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    const Eigen::Vector3d dir = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    Isometry3d T = gt.T_world_camera;
    T.linear() = Eigen::AngleAxisd(deg * M_PI / 180.0, axis).toRotationMatrix() * T.linear();
    T.translation() += 0.001 * mm * dir;
    poses.push_back(T);
  }
  return poses;
}

TEST(JointRefinement, BringsADisturbedTurnToTheBar) {
  const RgbdSequence seq = generated_turn(1003);
  SolvedState solved(seq, disturbed(seq, 6.0, 0.3));
  const Errors before = errors(solved.state);
  refine_jointly(solved.state);
  check_views(solved.state);
  const Errors after = errors(solved.state);
  const JointRefinement& r = solved.state.result.refinement;
  print_refinement(before, after, r);
  EXPECT_GT(before.ate_m, 0.004);  // the disturbance is what tracking leaves
  // The bar (3 mm ATE, every view within 0.5 degree / 1 cm). Before the ring term a
  // view that sees little more than a wall kept a slide along it (2.6 mm ATE, one view 10.2 mm
  // off on 2026-12-04); held to its ring, its tilt no longer trades for that slide (0.36 mm,
  // worst 0.5 mm / 0.010 degree on 2026-12-06).
  EXPECT_LE(after.worst_deg, 0.1);
  EXPECT_LE(after.ate_m, 0.003);
  EXPECT_LE(after.worst_m, 0.010);
  EXPECT_FALSE(r.undone);
  EXPECT_GT(r.pairs, solved.state.registered.size());  // neighbours and ring to ring
}

// A textured room: the walls' colour fixes what their geometry leaves free. The same disturbed
// turn refined with the colour term and without it (as for colour not registered to depth).
TEST(JointRefinement, ColourHoldsWhatATexturedWallLeavesFree) {
#if defined(__SANITIZE_ADDRESS__)
  // Two full refinements: release builds only (the sanitizers run the colour term's code in the
  // other tests here, where the plain room's colours are registered too).
  GTEST_SKIP() << "two full refinements: release builds only";
#endif
  const RgbdSequence seq = generated_turn(1003, sim::SurfaceKind::Textured);
  const std::vector<Isometry3d> start = disturbed(seq, 6.0, 0.3);
  SolvedState with_colour(seq, start), without(seq, start);
  without.options.refinement_color = false;
  const Errors before = errors(with_colour.state);
  refine_jointly(with_colour.state);
  refine_jointly(without.state);
  const Errors colour = errors(with_colour.state), geometry = errors(without.state);
  std::printf("before: ATE %.2f mm; with colour: ATE %.2f mm, worst %.1f mm / %.3f deg; geometry "
              "only: ATE %.2f mm, worst %.1f mm / %.3f deg\n",
              1000 * before.ate_m, 1000 * colour.ate_m, 1000 * colour.worst_m, colour.worst_deg,
              1000 * geometry.ate_m, 1000 * geometry.worst_m, geometry.worst_deg);
  EXPECT_FALSE(with_colour.state.result.refinement.undone);
  // The bar over every view, before any is flagged (0.56 mm ATE, worst 1.3 mm on
  // 2026-12-04; geometry alone 3.0 mm, worst 11.4 mm).
  EXPECT_LE(colour.ate_m, 0.003);
  EXPECT_LE(colour.worst_m, 0.010);
  EXPECT_LE(colour.worst_deg, 0.5);
  EXPECT_LT(colour.ate_m, 0.75 * geometry.ate_m);
}

// Each view tilted `deg` degrees about a random axis across the pan axis (as its camera sees
// it): off its ring, the error a tripod head cannot make and tracking can (generated room 99:
// views up to 1.05 degrees off, ATE 9.9 mm, after the pose graph).
std::vector<Isometry3d> tilted_off_rings(const RgbdSequence& seq, double deg) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * M_PI);
  std::vector<Isometry3d> poses;
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // the generator's pan axis
  for (const auto& gt : seq.ground_truth) {
    Eigen::Vector3d across = up.unitOrthogonal();
    across = Eigen::AngleAxisd(angle(rng), up) * across;
    Isometry3d T = gt.T_world_camera;
    T.linear() = Eigen::AngleAxisd(deg * M_PI / 180.0, across).toRotationMatrix() * T.linear();
    poses.push_back(T);
  }
  return poses;
}

// The ring term (joint_refinement.cpp): every view's pan axis is pulled onto its ring's, which
// the surfaces alone fix only through pairs far apart. Without it the same start ends with
// views 0.3-0.4 degrees off (room 99: a turn pitched 0.39 degrees in every camera's frame).
TEST(JointRefinement, BringsViewsTiltedOffTheirRingsBack) {
  const RgbdSequence seq = generated_turn(1004);
  SolvedState solved(seq, tilted_off_rings(seq, 0.6));
  const Errors before = errors(solved.state);
  refine_jointly(solved.state);
  const Errors after = errors(solved.state);
  const JointRefinement& r = solved.state.result.refinement;
  print_refinement(before, after, r);
  EXPECT_GT(before.worst_deg, 0.5);
  EXPECT_FALSE(r.undone);
  EXPECT_LE(after.worst_deg, 0.1);
}

TEST(JointRefinement, LeavesAnExactTurnWhereItIs) {
  const RgbdSequence seq = generated_turn(1003);
  std::vector<Isometry3d> exact;
  for (const auto& gt : seq.ground_truth) exact.push_back(gt.T_world_camera);
  SolvedState solved(seq, exact);
  refine_jointly(solved.state);
  check_views(solved.state);
  const Errors after = errors(solved.state);
  std::printf("exact turn after refinement: ATE %.2f mm, worst %.1f mm / %.3f deg\n",
              1000 * after.ate_m, 1000 * after.worst_m, after.worst_deg);
  // Before the ring term the steps' re-found correspondences walked a view whose surfaces
  // leave a direction free along it, tilting as it went (2.79 mm ATE, one view 12.4 mm off on
  // 2026-12-04); held to its ring it stays (0.33 mm, worst 0.5 mm on 2026-12-06).
  EXPECT_LE(after.ate_m, 0.0015);
  EXPECT_LE(after.worst_m, 0.005);
  EXPECT_LE(after.worst_deg, 0.1);
}

}  // namespace
}  // namespace locard::alignment_detail
