#pragma once
// The stages of align_sequence (sequential_alignment.hpp) over one explicit state:
//   prepare_frames   depth -> camera-frame clouds (step 1)
//   track_frames     sequential registration into pieces (step 2)
//   hold_to_tripod   tripod turn: views tracked off the fitted tripod registered again (2b)
//   propose_loops    loop candidates from pose proximity, ring structure and piece ends (3)
//   verify_loops     each candidate checked by registration (3)
//   solve_graph      pose graph over odometry and loop edges, pieces joined (4)
//   refine_jointly   tripod turn: all views moved at once over every overlapping pair (4b)
//   check_views      every registered view tested against the others' model (5)
// Each stage reads what the earlier ones wrote and adds its own part; none reaches back.
#include "alignment/tripod_fit.hpp"

#include <locard/alignment/sequential_alignment.hpp>
#include <locard/core/disjoint_sets.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/registration/global_registration.hpp>
#include <locard/registration/icp.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace locard::alignment_detail {

struct PreparedFrame {
  PointCloud cloud;   // camera frame, voxel grid, normals towards the sensor, colours
  PointCloud coarse;  // the same at twice the voxel size (first ICP level)
  std::string unusable;  // non-empty: why this frame cannot be used
  // The colour term's information over the cloud (view_verification.cpp), made the first time
  // tracking or the view check asks for it: a gradient fit over the view, not worth repeating.
  // Filled by one thread per frame (tracking runs frame by frame, the check a task per view).
  mutable std::optional<Eigen::Matrix<double, 6, 6>> color_information;
};

// A registration target at two resolutions (the coarse one is made once per model update).
// A tracking model is also prepared for point-to-plane ICP once (kd-trees), as every guess of
// a frame runs against it.
struct Target {
  PointCloud fine;
  PointCloud coarse;
  std::shared_ptr<const IcpTarget> fine_icp;    // point to plane; null: prepared per call
  std::shared_ptr<const IcpTarget> coarse_icp;
  std::shared_ptr<const IcpTarget> fine_colored_icp;  // the last level, when coloured
};
Target make_target(PointCloud fine, double voxel_size);
// Prepares the target for refine() with `method` on the last level.
void prepare_for_icp(Target& target, double voxel_size, IcpMethod method);

struct AlignmentState {
  const RgbdSequence& sequence;
  const AlignmentOptions& options;
  std::size_t n = 0;                    // frames used
  std::vector<PreparedFrame> prepared;  // one per frame used
  AlignmentResult result;
  std::vector<std::size_t> piece_of;    // tracking piece of each frame
  std::vector<std::size_t> registered;  // indices into result.frames, in order
  std::size_t piece_count = 0;
  std::vector<LoopCandidate> candidates;

  AlignmentState(const RgbdSequence& s, const AlignmentOptions& o) : sequence(s), options(o) {}
  const Isometry3d& tracked_pose(std::size_t frame) const {
    return *result.frames[frame].T_world_camera_icp;
  }
};

void prepare_frames(AlignmentState& state);
void track_frames(AlignmentState& state);
void hold_to_tripod(AlignmentState& state);
void propose_loops(AlignmentState& state);
void verify_loops(AlignmentState& state);
void solve_graph(AlignmentState& state);
void refine_jointly(AlignmentState& state);
void check_views(AlignmentState& state);
// The tripod fit (tripod_fit.hpp) of a turn's camera rotations as the self-check and the
// joint refinement take it: none unless the run is a tripod turn (cumulative mode), and a turn
// known from its capture (ring sizes) is fitted whatever share of views its rings hold - a
// model half of whose views no tripod explains is wrong and must show it (view_verification.cpp).
std::optional<TripodFit> turn_fit(const AlignmentOptions& o,
                                  const std::vector<Eigen::Matrix3d>& R_world_camera);
// The cells of side `cell_size` that a camera-frame cloud's points fall in at pose T (world
// frame), sorted, each once (view_verification.cpp).
std::vector<std::uint64_t> world_cells(const PointCloud& cloud, const Isometry3d& T,
                                       double cell_size);
// How firmly frame i's own points fix a move of its camera along `direction` (camera frame):
// the mean of (n . d)^2 over its points, and where that is below the check's min_constraint
// and colour is registered to depth, the significant colour gradients' share as the view check
// counts it (view_verification.cpp).
double translation_constraint(const AlignmentState& s, std::size_t i,
                              const Eigen::Vector3d& direction);
// Smallest eigenvalue of a camera-frame cloud's per-point normal matrix (ViewCheckOptions'
// "constraint"): rotation about the camera centre only, or all six degrees of freedom.
double pose_constraint(const PointCloud& cloud, bool rotation_only);
// The colour gradient of a camera-frame cloud (with normals) as the colour terms of the joint
// refinement and of the view check use it (color_gradient.hpp): over the at most 30 points
// within two voxels (Open3D: twice the correspondence distance, 30 points), `intensity` per
// point; `standard_error` as color_gradients gives it (joint_refinement.cpp).
std::vector<Eigen::Vector3f> surface_color_gradients(const PointCloud& cloud, const KdTree& tree,
                                                     std::span<const float> intensity,
                                                     double voxel_size,
                                                     std::vector<float>* standard_error = nullptr);

// Shared registration steps (frame_registration.cpp).
// ICP of a camera-frame cloud against a target, coarse to fine: point to plane at 2v with a 4v
// gate, then at v with gates 2v and v; the last level uses `method`.
// `prior` (tripod tracking) holds what the geometry leaves free.
IcpResult refine(const PointCloud& source_fine, const PointCloud& source_coarse,
                 const Target& target, const Isometry3d& init, const AlignmentOptions& o,
                 IcpMethod method, const std::optional<IcpPosePrior>& prior = std::nullopt);
bool acceptable(const IcpResult& r, const AlignmentOptions& o, double min_fitness);
std::string rejection(const IcpResult& r, const AlignmentOptions& o, double min_fitness);
bool better(const IcpResult& a, const IcpResult& b);
GlobalRegistrationResult features(const PointCloud& source, const PointCloud& target,
                                  const Eigen::Vector3f& target_viewpoint,
                                  const AlignmentOptions& o, std::uint64_t salt);
// The ICP method of the last level for this run's mode.
IcpMethod tracking_method(const AlignmentOptions& o);
// The first ICP level alone, short: a cheap score for one of many initial guesses.
IcpResult screen(const PointCloud& source_coarse, const Target& target, const Isometry3d& init,
                 const AlignmentOptions& o,
                 const std::optional<IcpPosePrior>& prior = std::nullopt);

// Tripod tracking (tripod_tracking.cpp): the registration of frame `frame` against the model
// of the piece so far, from turns (and tilts) of the previous pose about the tripod.
struct TrackedView {
  std::optional<IcpResult> best;  // the accepted result, or the best rejected one
  std::string initialisation;
  // The pose the accepted ICP began at: the feature (SVD) pose when features won, else the
  // tripod guess.
  std::optional<Isometry3d> T_world_camera_initial;
  std::string failure;            // why nothing was accepted; empty when best is accepted
};
TrackedView register_tripod_view(const AlignmentState& s, const Target& model, std::size_t frame,
                                 std::size_t piece);

Eigen::Vector3d forward(const Isometry3d& T);
double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

// Union-find over node indices (core/disjoint_sets.hpp).
using Components = DisjointSets;

}  // namespace locard::alignment_detail
