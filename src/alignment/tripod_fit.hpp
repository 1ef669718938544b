#pragma once
// The tripod turn as a set of camera rotations shows it.
//
// A tripod head turns the camera about one pan axis a (world frame) and tilts it only between
// pitch rings, so within a ring the pan axis as the camera sees it, u_i = R_i^T a, is one
// vector u_r. A view tracked with a wrong tilt or roll (a bare wall leaves the turn about its
// normal free) has u_i away from its ring's u_r by the angle of that error - whatever its pan
// angle. The fit finds a without trusting any single view:
//   1. candidates: the axis of R_j R_i^T for pairs of views turned 8-172 degrees apart (a pair
//      in one ring turns about a; a pair across rings gives a wrong axis that loses the vote);
//   2. vote: a candidate scores sum_i #{j : angle(u_i, u_j) < vote_deg}, the views whose
//      camera-frame axes coincide - a whole ring collapses to a point only under the true a;
//   3. rings: the camera-frame axes clustered within ring_deg of the densest (a ring needs
//      min_ring_views and a quarter of the largest ring's count);
//   4. refine: alternate u_r = mean of the ring's R_i^T a and a = mean of R_i u_r over views
//      within inlier_deg.
// Not a tripod turn (no candidate pair, or fewer than min_inlier_share of the views within
// inlier_deg of a ring): no fit. Where the capture is known to be a tripod turn, the self-check
// asks for the fit whatever the share (0): a model half of whose views no tripod explains (a
// ring tilted as a whole) is wrong, and must show it, not drop the test.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <optional>
#include <vector>

namespace locard::alignment_detail {

// A view is on the tripod when it lies within kOnRingDeg of its ring (tracking noise of a good
// view is a few hundredths of a degree) and within kOnTripodM of the nodal model (tripod play
// is millimetres): the hold stage and the pose graph's tripod post-check use the same bounds.
// kTripodCentreSigmaM is how firmly a prior holds a camera centre to the tripod's.
constexpr double kOnRingDeg = 0.5;
constexpr double kOnTripodM = 0.02;
constexpr double kTripodCentreSigmaM = 0.03;

// Component-wise median of the poses' camera centres (robust to a minority of wrong views).
Eigen::Vector3d median_centre(const std::vector<Eigen::Isometry3d>& T_world_camera);
// The views (indices, ascending) whose camera centres stand within `radius` of the view with
// the most such neighbours: the turn's own, where tracking left arcs of it elsewhere (no
// majority is left for a median or a least-squares fit to find).
std::vector<std::size_t> densest_centres(const std::vector<Eigen::Isometry3d>& T_world_camera,
                                         double radius);

struct TripodFit {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // world frame, unit
  std::vector<Eigen::Vector3d> ring_axes;            // camera frame, unit, one per ring
  std::vector<int> ring;             // per view: its ring, or the nearest ring when none held it
  std::vector<double> off_axis_deg;  // per view: angle between R_i^T axis and its ring's axis
};

struct TripodFitOptions {
  double vote_deg = 0.3;
  double ring_deg = 3.0;
  double inlier_deg = 0.5;
  std::size_t min_ring_views = 4;
  double min_inlier_share = 0.5;
};

std::optional<TripodFit> fit_tripod(const std::vector<Eigen::Matrix3d>& R_world_camera,
                                    const TripodFitOptions& options = {});

// Where the camera centres of a tripod turn lie: the head turns the camera about a pivot P and
// the optical centre sits at a fixed offset d from it in the camera frame (the nodal offset),
// so c_i = P + R_i d. Least squares in (P, d), linear; then twice again over the views within
// max(inlier_m, 3 x the median residual), so a minority of wandering centres does not move it.
// (Along the pan axis only P_a + u . d is fixed within a ring; a small ridge on d picks one.)
struct NodalFit {
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();   // world
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // camera frame
  std::vector<double> residual_m;                    // per view: |c_i - P - R_i d|
  // |c - P - R d| of any pose, fitted or not.
  double residual(const Eigen::Isometry3d& T_world_camera) const {
    return (T_world_camera.translation() - pivot - T_world_camera.linear() * offset).norm();
  }
};
NodalFit fit_nodal(const std::vector<Eigen::Isometry3d>& T_world_camera, double inlier_m = 0.01);

// Which of the poses stand off the tripod: off their ring by off_axis_deg or more, or off the
// nodal model by residual_m or more. None when the poses make no tripod fit.
std::optional<std::vector<char>> which_views_off_tripod(
    const std::vector<Eigen::Isometry3d>& T_world_camera, double off_axis_deg, double residual_m);
// How many (which_views_off_tripod's count).
std::optional<std::size_t> views_off_tripod(const std::vector<Eigen::Isometry3d>& T_world_camera,
                                            double off_axis_deg, double residual_m);

// The rotation nearest R (by turning the camera about one axis) whose camera-frame pan axis is
// ring_axis: R Q with Q the shortest rotation taking ring_axis to R^T axis.
Eigen::Matrix3d onto_ring(const Eigen::Matrix3d& R, const Eigen::Vector3d& axis,
                          const Eigen::Vector3d& ring_axis);
// View k of a fit (rotation R) put back on its ring: onto_ring with the fit's axis and the
// view's ring axis.
Eigen::Matrix3d onto_its_ring(const TripodFit& fit, std::size_t k, const Eigen::Matrix3d& R);

}  // namespace locard::alignment_detail
