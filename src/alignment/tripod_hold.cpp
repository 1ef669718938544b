// Stage 2b of align_sequence in cumulative mode: the tracked turn held to the tripod.
//
// Tracking sees the pan axis only from the views before it, so a first step taken before the
// axis is known can leave the tripod by degrees, and a ring enters through one view whose tilt
// every later view of the ring inherits. Once the whole turn is tracked, the tripod fit
// (tripod_fit.hpp) knows the axis and the rings from every view by vote. Then, per piece:
//   1. each ring after the first is corrected as a whole against the rings before it
//      (ring_alignment.hpp): its common tilt and roll, and its turn and shift as a block;
//   2. on a new fit, a view whose camera-frame axis is still off its ring's is started again
//      from its pose put back on the ring (onto_ring) and registered against the model of the
//      views on their rings, with a hinge prior: free to turn about the pan axis (the geometry
//      decides the pan), held in tilt and roll, its centre held to the tripod's.
// Tracking's result stays wherever the held registration fails or the ring's correction is
// implausibly large.
#include "alignment/alignment_stages.hpp"
#include "alignment/ring_alignment.hpp"
#include "alignment/tripod_fit.hpp"

#include <locard/preprocess/voxel_grid.hpp>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace locard::alignment_detail {
namespace {

constexpr double kHeldOffAxisSigmaDeg = 1.0;
constexpr double kFreePanSigmaDeg = 5.0;

std::vector<Isometry3d> tracked_poses(const AlignmentState& s, const std::vector<std::size_t>& views) {
  std::vector<Isometry3d> T;
  for (std::size_t f : views) T.push_back(s.tracked_pose(f));
  return T;
}

Target model_of(const AlignmentState& s, const std::vector<std::size_t>& views) {
  const double v = s.options.voxel_size;
  PointCloud all;
  for (std::size_t f : views) all.append(transformed(s.prepared[f].cloud, s.tracked_pose(f)));
  Target target = make_target(voxel_down_sample(all, static_cast<float>(v)).cloud, v);
  prepare_for_icp(target, v, tracking_method(s.options));
  return target;
}

// A ring enters through its first view, whose tilt only the band it shares with the ring below
// fixes (walls, which let a single view tilt along them), and every later view of the ring
// follows it: the whole ring can stand a degree off. As one block the ring sees the shared band
// all round, which fixes its tilt both ways and its turn. So each ring after the first is
// registered as one rigid block against the rings before it, turning about the tripod's centre
// (its points expressed about the centre, the centre held by the prior), and the correction is
// applied to all of its views.
constexpr double kMaxRingCorrectionDeg = 5.0;
constexpr double kMaxRingCorrectionM = 0.10;

void align_rings(AlignmentState& s, const std::vector<std::size_t>& views, const TripodFit& fit,
                 const Eigen::Vector3d& centre) {
  // Rings in the order they were scanned (by their first view).
  std::vector<std::vector<std::size_t>> rings(fit.ring_axes.size());
  std::vector<int> order;
  for (std::size_t k = 0; k < views.size(); ++k) {
    if (fit.off_axis_deg[k] >= kOnRingDeg) continue;
    auto& ring = rings[static_cast<std::size_t>(fit.ring[k])];
    if (ring.empty()) order.push_back(fit.ring[k]);
    ring.push_back(views[k]);
  }
  if (order.size() < 2) return;
  std::vector<std::size_t> before = rings[static_cast<std::size_t>(order[0])];
  for (std::size_t r = 1; r < order.size(); ++r) {
    const std::vector<std::size_t>& ring = rings[static_cast<std::size_t>(order[r])];
    const std::optional<RingCorrection> c = align_ring(s, ring, before, centre);
    const bool sane = c && c->E_deg <= kMaxRingCorrectionDeg && c->C_deg <= kMaxRingCorrectionDeg &&
                      c->tau.norm() <= kMaxRingCorrectionM;
    if (sane) {
      // Every view nearest the ring, those off it too: they were tracked from it.
      const int ring_id = order[r];
      for (std::size_t k = 0; k < views.size(); ++k) {
        if (fit.ring[k] != ring_id) continue;
        FrameAlignment& frame = s.result.frames[views[k]];
        frame.T_world_camera_icp = c->apply(*frame.T_world_camera_icp, centre);
      }
    }
    before.insert(before.end(), ring.begin(), ring.end());
  }
}

std::vector<Eigen::Matrix3d> rotations(const AlignmentState& s,
                                       const std::vector<std::size_t>& views) {
  std::vector<Eigen::Matrix3d> R;
  for (std::size_t f : views) R.push_back(s.tracked_pose(f).linear());
  return R;
}

// The views off the tripod - their camera-frame axis off their ring's, or their centre off the
// nodal model (fit_nodal) - registered again against the model of the views on it.
void hold_views(AlignmentState& s, const std::vector<std::size_t>& views, const TripodFit& fit,
                const std::vector<Eigen::Matrix3d>& R) {
  const NodalFit nodal = fit_nodal(tracked_poses(s, views));
  std::vector<std::size_t> good, off;  // frames; positions in `views`
  for (std::size_t k = 0; k < views.size(); ++k)
    if (fit.off_axis_deg[k] < kOnRingDeg && nodal.residual_m[k] < kOnTripodM) good.push_back(views[k]);
    else off.push_back(k);
  if (off.empty() || good.size() < 2) return;
  const Target model = model_of(s, good);
  const AlignmentOptions& o = s.options;
  std::vector<std::optional<IcpResult>> held(off.size());
  tbb::parallel_for(std::size_t{0}, off.size(), [&](std::size_t j) {
    const std::size_t k = off[j], f = views[k];
    Isometry3d start = s.tracked_pose(f);
    start.linear() = onto_its_ring(fit, k, R[k]);
    start.translation() = nodal.pivot + start.linear() * nodal.offset;
    IcpPosePrior prior;
    prior.T_target_source = start;
    prior.centre_sigma_m = kTripodCentreSigmaM;
    prior.rotation_sigma_deg = kFreePanSigmaDeg;
    prior.point_sigma_m = 0.5 * o.voxel_size;
    prior.per_correspondence = true;
    prior.hinge_axis = fit.axis;
    prior.off_axis_sigma_deg = kHeldOffAxisSigmaDeg;
    IcpResult r = refine(s.prepared[f].cloud, s.prepared[f].coarse, model, start, o,
                         tracking_method(o), prior);
    if (acceptable(r, o, o.min_fitness)) held[j] = std::move(r);
  });
  for (std::size_t j = 0; j < off.size(); ++j) {
    if (!held[j]) continue;
    FrameAlignment& frame = s.result.frames[views[off[j]]];
    frame.T_world_camera_icp = held[j]->T_target_source;
    frame.fitness = held[j]->fitness;
    frame.inlier_rmse = held[j]->inlier_rmse;
    frame.initialisation += ", held to the tripod";
  }
}

// The ring of each view (frames used) by capture order, from the known ring sizes; -1 beyond.
int known_ring(const AlignmentOptions& o, std::size_t frame) {
  std::size_t at = 0;
  const std::size_t index = o.first_frame + frame;
  for (std::size_t r = 0; r < o.ring_sizes.size(); ++r) {
    at += o.ring_sizes[r];
    if (index < at) return static_cast<int>(r);
  }
  return -1;
}

// A ring can enter tilted by more than the ring correction takes (a plain room lets its first
// view tilt along the walls), and then no ring holds the majority the tripod fit asks for, so
// nothing is held. Where the rings are known (capture order), each ring's own pan axis is
// fitted from its views alone; one tripod has one axis, so a ring whose axis stands off the
// largest ring's is turned as a block about the tripod's centre by the rotation between the
// two axes. Its turn about the axis is left to the ring correction.
constexpr double kMaxRingLevelDeg = 20.0;

void level_rings(AlignmentState& s, const std::vector<std::size_t>& views,
                 const Eigen::Vector3d& centre) {
  if (s.options.ring_sizes.size() < 2) return;
  std::vector<std::vector<std::size_t>> rings(s.options.ring_sizes.size());
  for (std::size_t f : views)
    if (const int r = known_ring(s.options, f); r >= 0) rings[static_cast<std::size_t>(r)].push_back(f);
  std::vector<std::optional<Eigen::Vector3d>> axis(rings.size());
  std::size_t reference = rings.size();
  for (std::size_t r = 0; r < rings.size(); ++r) {
    const std::optional<TripodFit> fit = fit_tripod(rotations(s, rings[r]));
    if (!fit) continue;
    axis[r] = fit->axis;
    if (reference == rings.size() || rings[r].size() > rings[reference].size()) reference = r;
  }
  if (reference == rings.size()) return;
  for (std::size_t r = 0; r < rings.size(); ++r) {
    if (r == reference || !axis[r]) continue;
    const Eigen::Matrix3d Q = Eigen::Quaterniond::FromTwoVectors(*axis[r], *axis[reference]).toRotationMatrix();
    const double angle = Eigen::AngleAxisd(Q).angle() * 180.0 / M_PI;
    if (angle < kOnRingDeg || angle > kMaxRingLevelDeg) continue;
    for (std::size_t f : rings[r]) {
      Isometry3d& T = *s.result.frames[f].T_world_camera_icp;
      T.linear() = Q * T.linear();
      T.translation() = centre + Q * (T.translation() - centre);
    }
  }
}

// Rings first (a ring's correction moves its views' axes), then the views, on a new fit.
void hold_piece(AlignmentState& s, const std::vector<std::size_t>& views) {
  if (views.size() >= 2) level_rings(s, views, median_centre(tracked_poses(s, views)));
  const std::optional<TripodFit> fit = fit_tripod(rotations(s, views));
  if (!fit) return;
  std::vector<std::size_t> good;
  for (std::size_t k = 0; k < views.size(); ++k)
    if (fit->off_axis_deg[k] < kOnRingDeg) good.push_back(views[k]);
  if (good.size() < 2) return;
  align_rings(s, views, *fit, median_centre(tracked_poses(s, good)));
  const std::vector<Eigen::Matrix3d> R = rotations(s, views);
  if (const std::optional<TripodFit> refit = fit_tripod(R)) hold_views(s, views, *refit, R);
}

}  // namespace

void hold_to_tripod(AlignmentState& s) {
  if (s.options.mode != AlignmentMode::Cumulative) return;
  for (std::size_t piece = 0; piece < s.piece_count; ++piece) {
    std::vector<std::size_t> views;
    for (std::size_t f : s.registered)
      if (s.piece_of[f] == piece) views.push_back(f);
    hold_piece(s, views);
  }
}

}  // namespace locard::alignment_detail
