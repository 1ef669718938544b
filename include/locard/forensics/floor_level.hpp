#pragma once
// Levelling a case from its floor, for data that records no gravity (TUM, Redwood, ICL-NUIM,
// any hand-held video reconstructed in its first camera's frame).
//
// A person holds a camera roughly upright and a tripod stands level, so the cameras' "up" (the
// image's -y axis, averaged over the views) points within a few tens of degrees of true up.
// The floor is then the plane, among the lowest points along that guess, with the most points
// within `inlier_distance_m` whose normal lies within `max_tilt_deg` of the guess and with
// hardly any point below it (RANSAC with a fixed seed, then a least-squares fit to its inliers). Its normal is the case's +z: the
// rotation returned turns it there (about the origin), so top views, plans, walk mode and
// clipping, which assume z up, hold. No floor (too few points on any such plane) is nullopt:
// the case is then not levelled, and says so.
#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace locard::forensics {

struct FloorLevelOptions {
  double max_tilt_deg = 30.0;       // floor normal vs the cameras' up
  double inlier_distance_m = 0.02;  // a point this close to the plane is on it
  double lowest_share = 0.3;        // planes are drawn from the lowest 30 % of points
  double min_inlier_share = 0.03;   // of all points, for the plane to count as the floor
  double max_below_share = 0.02;    // of all points, below the plane (outliers): more is no floor
  std::size_t min_inliers = 500;
  int iterations = 400;
  std::uint64_t seed = 1;
};

struct FloorLevel {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // the floor's up normal, before levelling
  double height_m = 0.0;         // the floor's height along `normal` (before levelling)
  double rms_m = 0.0;            // of the inliers about the fitted plane
  std::size_t inliers = 0;
  std::size_t points = 0;
  double tilt_deg = 0.0;         // between `normal` and +z: how far the frame was from level
  Eigen::Matrix3d R_level = Eigen::Matrix3d::Identity();  // turns `normal` onto +z
};

// `points` in some world frame; `up_guess` the cameras' mean up in that frame (any length).
std::optional<FloorLevel> find_floor_level(const std::vector<Eigen::Vector3d>& points,
                                           const Eigen::Vector3d& up_guess,
                                           const FloorLevelOptions& options = {});

}  // namespace locard::forensics
