#pragma once
// Whole-sequence alignment: the reference paper's sections III-D and III-E (Algorithm 1).
//
//  1. Every frame becomes a camera-frame cloud: depth back-projected (stride), voxel grid of
//     `voxel_size`, normals towards the sensor. A frame with fewer than min_frame_points points
//     (depth all zero, covered lens) is reported by index and left out.
//  2. Sequential registration, each frame against a world-frame model of frames already
//     registered (voxel grid of voxel_size, normals averaged per voxel):
//       cumulative  the model holds every registered frame (the paper's scheme) of a tripod
//                   turn: one pan axis through a fixed centre. The initial poses are the
//                   previous pose turned about the pan axis (estimated from the steps so far)
//                   by the last step and by every tripod_sweep_step_deg up to
//                   max_tripod_step_deg either way, screened by a short coarse ICP; the best
//                   few are refined by the full ICP. Where a pitch ring starts (ring_sizes),
//                   or the turn alone finds nothing, tilts about the horizontal axis up to
//                   max_tripod_tilt_deg are added, and then feature registration (FPFH +
//                   RANSAC + SVD, "after SVD"). A result whose camera leaves the tripod
//                   (view_check.max_tripod_offset_m from the centre) or turns further than a
//                   step allows is rejected: a symmetric room fits itself turned by 90 or 180
//                   degrees, and only the tripod tells those poses apart. Among the rest the
//                   higher fitness (then lower RMSE) wins. Once the views on their rings span
//                   45 degrees, the pan axis is voted from all of them (tripod_fit.hpp), and a
//                   view whose geometry does not fix its rotation (view_check.min_constraint: a
//                   wall seen square on) is held to its ring by a hinge prior (icp.hpp).
//       odometry    frame-to-local-model tracking for long video: the model holds the last
//                   `local_model_frames` keyframes; the initial guess is the constant-velocity
//                   prediction, refined by coloured ICP (Park et al. 2017: photometric +
//                   geometric terms, so a textured wall still constrains the motion along it).
//                   Feature registration is the fall-back when ICP fails.
//     A frame is accepted when ICP succeeds with fitness >= min_fitness and inlier RMSE <=
//     max_inlier_rmse_ratio * voxel_size. Otherwise it is reported by index with the reason and
//     left out of the trajectory (never given a guessed pose). After max_consecutive_failures
//     failures in a row, the next usable frame starts a new piece; pieces are joined later by
//     loop closure when possible, and reported otherwise.
//  2b. Tripod turn (cumulative): the tracked turn held to the tripod (tripod_hold.cpp): each
//     ring after the first corrected as a whole against the rings before it, then every view
//     off its ring or off the head's nodal model registered again, held to it.
//  3. Loop closure between keyframes (every frame in cumulative mode, every keyframe_interval
//     registered frames in odometry mode): candidates are pairs far apart in the sequence
//     (at least loop_min_separation frames; in odometry mode also beyond the local model's
//     span) whose cameras are within loop_max_distance_m and loop_max_angle_deg (pose
//     proximity; the loop_candidates_per_keyframe nearest earlier keyframes of each keyframe),
//     (verified by ICP from the current relative pose), plus, by feature registration
//     (FPFH + RANSAC, then ICP), the first and last keyframes of every piece (the
//     first/last overlap of a turn, found even after large drift). Each candidate is verified
//     by ICP: fitness >= loop_min_fitness and inlier RMSE <= max_inlier_rmse_ratio *
//     voxel_size; a verified candidate becomes an uncertain pose-graph edge.
//  4. Pose graph (pose_graph.hpp): nodes are the registered frames, odometry edges join
//     consecutive registered frames (information from their overlap), loop edges as above;
//     wrong loop edges are pruned by the line process and the post-check. On a tripod turn a
//     solution that moves more views off the tripod than tracking left there is undone and
//     its loop edges are reported rejected (they slide along walls; the tripod does not).
//  4b. Joint refinement (tripod turn; joint_refinement.cpp): every view moved at once by one
//     least-squares problem over the point-to-plane residuals of all overlapping pairs (up to
//     8 partners a view) and the tripod's nodal model (pivot and offset solved with the views,
//     each centre pulled to it: what no surface fixes - a wall view's slide, the height of
//     rings that share only walls - the tripod does), each view's pan axis as its camera sees
//     it pulled onto its ring's (the tripod fit of the current poses: a head turns about one
//     axis, so a view's tilt and roll are its ring's), a weak prior at the solved pose for the
//     gauge; views that would move more than three voxels or a degree, or that it would take
//     off the tripod, keep their solved pose (and do not count towards undoing it).
// Randomness (RANSAC) is seeded by `seed`; the same input and options give the same result.

#include <locard/alignment/pose_graph.hpp>
#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>
#include <locard/core/progress.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/registration/icp.hpp>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard {

enum class AlignmentMode { Cumulative, Odometry };

// Stage 5, the self-check of every registered view against the model of the OTHER views
// (leave-one-out, so a view cannot vouch for itself):
//  - agreement: ICP of the view against the others' model, from its final pose; the
//    correction it finds estimates the view's own error. On a tripod turn it is held to the
//    accuracy a verified view vouches for, max_error_m / max_error_deg (1 cm / 0.5 degree: a
//    view the others place 16 mm / 0.87 degree away was 19 mm off, generated room 86). On
//    video, whose check is noisier (motion blur, rolling shutter, a model seen once), to
//    max_video_correction_m / max_video_correction_deg (2 cm / 1 degree: between a good view
//    and the error that makes a wrong model, 5 cm / 2 degrees).
//  - overlap: share of the view's points within 2 voxels of the others' model.
//  - free space: others' surface points (seen by >= 2 other views) that lie in front of the
//    view's own depth along its rays, i.e. surfaces the view claims to see through.
//  - constraint: the smallest eigenvalue of the view's point-to-plane normal matrix (per
//    point, so 1/3 for normals spread evenly): rotation only for a tripod turn (its position
//    is held by the tripod), all six degrees of freedom for video. A bare wall constrains
//    neither the slide along it nor the turn about its normal. The eigenvalue is about the
//    share of points that pin the weakest direction (times their lever, up to 1/3): a bare
//    plane, or two planes meeting along a line, give under 0.001. Rotation alone (three
//    directions) is held to min_constraint (3 % of the points); six directions share the
//    same points, so real clutter seen hand-held - a desk, a kitchen - lies at 0.007-0.017
//    (TUM fr2/fr3, 7-Scenes), and video is held to min_constraint_6dof (1 %). On a tripod
//    turn a view that fixes its pan but not its tilt or roll (a bare wall) is held by the
//    tripod instead: its constraint is the pan's, its check's ICP turns it only about the pan
//    axis, and it must stand within 0.5 degree of its ring - allowed only where the tripod's
//    measured play (views fixing all six directions, off the nodal model) keeps its slide
//    within max_error_m at 2.5 sigma. Where the camera stands is judged the same way: a tripod-turn
//    view whose own points (and colour) leave a translation free - a wall and the floor, whose
//    meeting line it may slide along (slide_constraint below min_constraint) - is placed there
//    by the tripod alone, which the check's ICP cannot see; it is verified only where 2.5
//    sigma of the play along its k free axes (play * sqrt(k / 3)), plus its offset from the
//    nodal model along them, stays within max_error_m.
//  - tripod (cumulative mode, the tripod-turn scheme): the camera centre lies within
//    max_tripod_offset_m of the median centre of the views that stand together (the most views
//    within that distance of one view: where tracking left arcs of the turn at several centres,
//    no majority is left for a median, and the largest arc is the turn); a view placed elsewhere
//    is wrong whatever its overlap (a symmetric room fits itself turned by 180 degrees). The
//    nodal model below is fitted to the same views, those of them on their ring (a ring tracked
//    tens of degrees off the axis as a whole would pull it off every view). And the pan axis as
//    the camera sees it is its ring's (tripod_fit.hpp): a view tilted or rolled more than
//    max_off_axis_deg off its ring is wrong however well it fits (a bare wall lets a view turn
//    about its normal, and a wrong roll still fits it); and its camera centre lies within
//    max_tripod_residual_m of the tripod's nodal model c = P + R d (tripod_fit.hpp: the head
//    turns the camera about a pivot), as a wall lets a view slide along it.
// A view that fails any test is flagged with the reason; flagged views leave the model and the
// check runs again (at most `rounds` times), so one wrong view cannot condemn its neighbours;
// a view flagged in an earlier round whose overlapping views are then all flagged keeps the
// reason it was flagged for.
// Each view is checked against the views of its own piece only (pieces share no frame).
//  - linked: a verified view vouches for its neighbours' placement only where they share
//    surface, so views that pass every test but are joined to the rest only through flagged
//    views form a block whose place in the model nothing checked (a ring split by bare walls
//    into arcs that each agree with themselves and sit degrees apart). Verified views are
//    linked where at least min_link_overlap of one view's surface (cells of twice the voxel
//    size) is seen by the other: consecutive tripod views share 60-90 %, views a field of
//    view apart under 10 %. The largest linked block is the model (its piece becomes piece
//    0); the views of every other block are flagged.
struct ViewCheckOptions {
  double max_error_m = 0.01;    // a verified view's bar (tripod turn)
  double max_error_deg = 0.5;
  double max_video_correction_m = 0.02;
  double max_video_correction_deg = 1.0;
  double min_overlap = 0.3;
  double max_free_space = 0.1;
  double min_constraint = 0.01;       // rotation only (tripod turn)
  double min_constraint_6dof = 0.003; // six degrees of freedom (video)
  double max_tripod_offset_m = 0.25;
  double max_off_axis_deg = 1.0;
  double max_tripod_residual_m = 0.04;
  double min_link_overlap = 0.2;
  int rounds = 3;
};
std::string_view to_string(AlignmentMode mode);
std::optional<AlignmentMode> parse_alignment_mode(std::string_view name);

struct AlignmentOptions {
  AlignmentMode mode = AlignmentMode::Cumulative;
  // Frames
  int stride = 2;                  // back-projection stride in pixels
  double min_depth_m = 0.3;
  double max_depth_m = 4.0;
  double voxel_size = 0.02;        // frame clouds, model and fused output (metres)
  std::size_t min_frame_points = 500;
  std::size_t first_frame = 0;     // frames [first_frame, first_frame + max_frames) are used
  std::size_t max_frames = 0;      // 0: all
  // Registration
  double feature_voxel_size = 0.05;  // FPFH + RANSAC resolution
  double min_fitness = 0.3;
  double max_inlier_rmse_ratio = 0.8;  // x voxel_size
  std::size_t local_model_frames = 8;  // odometry: keyframes in the local model
  // Odometry: the method of the last ICP level (the coarser levels are point to plane).
  // Coloured needs colour registered to depth; point to plane suits sensors whose colour
  // camera is offset and unregistered (7-Scenes' Kinect v1).
  IcpMethod odometry_method = IcpMethod::Colored;
  std::size_t max_consecutive_failures = 10;
  // Loop closure
  bool loop_closure = true;
  std::size_t keyframe_interval = 5;   // odometry mode
  std::size_t loop_min_separation = 10;  // frames apart in the sequence
  double loop_max_distance_m = 1.0;
  double loop_max_angle_deg = 20.0;
  double loop_min_fitness = 0.3;
  std::size_t loop_candidates_per_keyframe = 3;  // the nearest earlier keyframes of each
  std::size_t max_loop_candidates = 200;         // nearest first, over all keyframes
  PoseGraphOptions pose_graph;
  // Joint refinement (step 4b, joint_refinement.cpp): all views moved at once by one
  // least-squares problem over the point-to-plane residuals of every overlapping pair.
  // Runs on a tripod turn (cumulative mode).
  bool joint_refinement = true;
  // With a colour term (Park et al. 2017) beside the geometric one: what holds a view on a
  // textured wall whose geometry leaves its slide free. Only where colour is registered to
  // depth (a point's colour is then what its depth pixel saw).
  bool refinement_color = true;
  // Self-check (view_verification.hpp): every registered view is tested against the model of
  // the other views; `align` and `reconstruct` exit with kExitTooFewVerified when fewer than
  // this share of the usable views is verified.
  bool verify_views = true;
  ViewCheckOptions view_check;
  double min_verified_share = 0.9;
  // Tripod turn: views per pitch ring in capture order (SequenceTraits::ring_sizes); empty
  // when unknown. A ring's first view is searched with tilts as well as turns.
  std::vector<std::size_t> ring_sizes;
  // Tripod tracking (cumulative mode, step 2): the widest turn between consecutive views
  // (wider than the field of view leaves no overlap), the spacing of the turns tried, and the
  // widest tilt tried where a ring starts.
  // The method of the last ICP level of tripod tracking (`--tripod-icp`). Point to plane by
  // default: measured on simulated turns, coloured ICP is better on strongly textured walls
  // (a random checker room: ATE 2.7 vs 8.0 mm) but worse on the bedroom (0.79 vs 0.56 mm)
  // and 25 % slower; the tripod prior, not colour, is what holds a bare wall.
  IcpMethod tripod_method = IcpMethod::PointToPlane;
  double max_tripod_step_deg = 60.0;
  double tripod_sweep_step_deg = 5.0;
  double max_tripod_tilt_deg = 60.0;
  std::size_t tripod_refined_guesses = 3;  // screened guesses refined by the full ICP
  std::uint64_t seed = 0;
  ProgressCallback progress;  // (frames done, frames total) over stage 2
};

enum class FrameStatus { Registered, Unusable, Failed };
std::string_view to_string(FrameStatus status);

// The self-check of one registered view against the model fused from the other views.
struct ViewCheck {
  bool checked = false;    // false: not run (verification off, or too few other views)
  bool verified = false;   // passed every test below
  double confidence = 0.0; // 0..1: 1 a view consistent with all others, 0 a rejected one
  double residual_m = 0.0; // inlier RMSE of the leave-one-out ICP (point-to-point distance)
  double overlap = 0.0;    // share of the view's points within the gate of the others' model
  double free_space = 0.0; // share of others' surface points in its view that it sees through
  double constraint = 0.0; // smallest normalised eigenvalue of its point-to-plane matrix
  // Smallest over the translation alone (geometry, and colour where it counts): on a tripod
  // turn, how firmly the view's own points fix where its camera stands.
  double slide_constraint = 0.0;
  double tripod_play_m = std::numeric_limits<double>::quiet_NaN();  // the turn's measured play
  // Its geometry leaves a direction free and its colour's texture fixes it: the constraint
  // counts the colour term and the check's ICP is coloured (view_verification.cpp).
  bool fixed_by_color = false;
  double correction_m = 0.0;    // leave-one-out ICP correction of its pose
  double correction_deg = 0.0;
  // Tripod turn: angle between the pan axis as the view sees it and its ring's; NaN when the
  // views make no tripod fit (video, or too few).
  double off_axis_deg = std::numeric_limits<double>::quiet_NaN();
  double tripod_residual_m = std::numeric_limits<double>::quiet_NaN();  // from the nodal model
  std::string reason;      // why flagged; empty when verified
};

struct FrameAlignment {
  std::size_t sequence_index = 0;  // index into RgbdSequence::frames
  std::int64_t frame_index = -1;
  double timestamp = 0.0;
  FrameStatus status = FrameStatus::Unusable;
  std::string reason;              // why not registered; empty when registered
  std::size_t piece = 0;           // which connected piece (after loop closure)
  std::size_t points = 0;          // after the voxel grid
  // Before ICP: the feature alignment (SVD) pose, or in tripod tracking the turn or tilt
  // guess the accepted ICP began at ("initial pose" in the stage report).
  std::optional<Isometry3d> T_world_camera_svd;
  std::optional<Isometry3d> T_world_camera_icp;    // after ICP (registered frames)
  std::optional<Isometry3d> T_world_camera_final;  // after loop closure
  double fitness = 0.0;
  double inlier_rmse = 0.0;
  // "first frame", "tripod turn", "tripod tilt", "features" (cumulative);
  // "prediction", "previous pose", "features" (odometry)
  std::string initialisation;
  ViewCheck check;                 // registered frames only
  // Registered and (when verification ran) verified: the frames fused and measured.
  bool trusted() const {
    return status == FrameStatus::Registered && T_world_camera_final &&
           (!check.checked || check.verified);
  }
};

// How a loop candidate was proposed: the cameras' poses are near each other, or feature
// registration (FPFH + RANSAC) found the overlap (first and last keyframes of a piece).
enum class LoopSource { Proximity, Features };
std::string_view to_string(LoopSource source);  // "proximity", "features"

struct LoopCandidate {
  std::size_t source = 0;  // sequence indices
  std::size_t target = 0;
  LoopSource found_by = LoopSource::Proximity;
  bool accepted = false;   // verified and kept through the pose graph
  std::string reason;      // why rejected
  double fitness = 0.0;
  double inlier_rmse = 0.0;
  double chi2_before = 0.0;   // loop residual at the ICP poses
  double chi2_after = 0.0;    // after the pose graph
  double confidence = 0.0;    // line-process weight
  Isometry3d T_target_source = Isometry3d::Identity();
};

struct AlignmentTimings {
  double prepare_s = 0.0;
  double register_s = 0.0;
  double loop_closure_s = 0.0;
  double pose_graph_s = 0.0;
  double refinement_s = 0.0;
  double verification_s = 0.0;
  double total_s = 0.0;
};

// What the joint refinement (step 4b) did.
struct JointRefinement {
  bool ran = false;                 // a tripod turn with the stage on
  std::size_t pairs = 0;            // overlapping view pairs in the problem
  int iterations = 0;               // Gauss-Newton steps
  std::size_t correspondences = 0;  // in the last step
  std::size_t views_held = 0;       // would have moved too far: kept at the solved pose
  double max_change_m = 0.0;        // largest move of a view kept
  double max_change_deg = 0.0;
  bool undone = false;              // moved views off the tripod: the solved poses kept
  // The pose graph's own optimum (its nodes before this step): where the graph's edges are
  // judged - the refined poses answer to the joint problem, not to the tracking edges they
  // correct (reconstruct's a-posteriori variance factor). Empty when the step did not run.
  std::vector<Isometry3d> graph_optimum;
};

struct AlignmentResult {
  AlignmentOptions options;
  std::vector<FrameAlignment> frames;  // one per frame used, in sequence order
  std::vector<LoopCandidate> loops;
  PoseGraph graph;                     // nodes in the order of `node_frames`
  std::vector<std::size_t> node_frames;  // node -> index into `frames`
  PoseGraphResult pose_graph;
  std::size_t pieces = 0;              // connected pieces after loop closure
  JointRefinement refinement;
  AlignmentTimings timings;

  // Trusted frames (registered, not flagged) with their final poses (TUM-ready); piece < 0
  // means all pieces.
  Trajectory trajectory(long piece = -1) const;
  std::vector<std::int64_t> unregistered_frame_indices() const;
  // Registered frames the self-check flagged, by frame index.
  std::vector<std::int64_t> flagged_frame_indices() const;
  std::size_t usable_frames() const;    // frames not Unusable
  std::size_t trusted_frames() const;   // FrameAlignment::trusted()
  // trusted / usable; 0 with no usable frame.
  double trusted_share() const;
  bool enough_trusted() const { return trusted_share() >= options.min_verified_share; }
};

// Exit status of `locard align` and `locard reconstruct` when fewer than
// AlignmentOptions::min_verified_share of the usable views are verified (after writing what
// they could, with the flagged views left out).
inline constexpr int kExitTooFewVerified = 4;

// Throws InputError for unusable options or a sequence without frames.
AlignmentResult align_sequence(const RgbdSequence& sequence, const AlignmentOptions& options);

// The trusted frames (FrameAlignment::trusted) fused into one coloured cloud in the world frame (voxel grid of
// voxel_size): frames are re-read from the sequence. piece < 0: all pieces.
PointCloud fuse_aligned_frames(const RgbdSequence& sequence, const AlignmentResult& result,
                               double voxel_size, long piece = -1);

}  // namespace locard
