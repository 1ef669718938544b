#pragma once
// Bullet-trajectory analysis on the model.
//
// The line: through two points (entry and exit holes), or fitted to three or more points along
// a trajectory rod (total least squares: the centroid and the principal axis of the points).
// Its direction d points from the first point towards the last.
//   horizontal angle (azimuth): atan2(d_y, d_x) in degrees, counter-clockwise from +x seen
//                               from above (world frame, z up), in (-180, 180];
//   vertical angle (elevation): asin(d_z) in degrees, positive upwards, in [-90, 90].
// Extension: the line is cast forwards from the last point and backwards from the first
// (Embree, CaseModel::raycaster), skipping min_gap_m so the holes themselves are not hit; the
// first surface met either way is reported with its distance and normal.
// Error cone: the direction's angular standard uncertainty from the points' uncertainties,
//   two points:  sigma_theta = sqrt(sigma_a^2 + sigma_b^2) / |b - a|   (perpendicular sigmas)
//   fitted rod:  sigma_theta = sigma_perp * sqrt(1 / sum_i (s_i - s_mean)^2)   (slope of a
//                line fit, s_i the positions along the line, sigma_perp the fit's rms or the
//                points' sigma, whichever is larger)
// and the cone's half-angle is coverage_factor x sigma_theta; at each surface hit, the cone's
// radius is distance * tan(half-angle) plus the expanded point uncertainty.

#include <locard/forensics/case_model.hpp>
#include <locard/forensics/revisions.hpp>

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace locard::forensics {

class CaseFolder;

struct TrajectoryInput {
  std::string name;
  std::vector<Eigen::Vector3d> points;  // 2: entry and exit; 3+: along a rod
  double point_sigma_m = 0.0;  // standard uncertainty of each point (0: from the model)
  double coverage_factor = 2.0;
  double min_gap_m = 0.02;
  double max_range_m = 50.0;
};

struct SurfaceHit {
  bool hit = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit, facing the incoming line
  double distance_m = 0.0;        // from the last (forward) or first (backward) point
  double incidence_deg = 0.0;     // between the line and the surface normal
  double cone_radius_m = 0.0;     // expanded radius of the error cone at the hit
};

struct TrajectoryAnalysis {
  std::string name;
  std::vector<Eigen::Vector3d> points;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();     // centroid of the points
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // unit, first -> last
  double horizontal_angle_deg = 0.0;
  double vertical_angle_deg = 0.0;
  double fit_rms_m = 0.0;  // rod fit: rms distance of the points from the line (0 for two)
  double point_sigma_m = 0.0;
  double angular_sigma_deg = 0.0;
  double cone_half_angle_deg = 0.0;  // expanded
  SurfaceHit forward;   // beyond the last point
  SurfaceHit backward;  // before the first point
  Revisions revisions;  // earlier names, withdrawal
};

// Throws InputError for fewer than two points, coincident points or non-finite input.
// `model` may be null: no surface hits, and point_sigma_m must then be given.
TrajectoryAnalysis analyse_trajectory(const CaseModel* model, const TrajectoryInput& input);
TrajectoryAnalysis analyse_trajectory(const TriangleMesh& mesh, const TrajectoryInput& input);

// trajectories/analyses.json: {"analyses": [...]} as text, and back (for the report/viewer).
std::string trajectory_analyses_json(const std::vector<TrajectoryAnalysis>& analyses);
std::vector<TrajectoryAnalysis> read_trajectory_analyses(const std::filesystem::path& path);
// One row per analysis (spreadsheet-safe): name, angles, cone, hits, status, previous names.
std::string trajectory_analyses_csv(const std::vector<TrajectoryAnalysis>& analyses);
// Writes analyses.json and analyses.csv beside it (atomic each); the caller logs both.
void write_trajectory_analyses(const std::filesystem::path& json_path,
                               const std::vector<TrajectoryAnalysis>& analyses);

// The name an unnamed analysis gets in a case that stores `stored` of them: "T<stored + 1>".
std::string default_trajectory_name(std::size_t stored);

// How a trajectory analysis enters a case, from the CLI and the viewer alike: appended to
// trajectories/analyses.json (+ .csv) as one logged step "trajectory" with `parameters_json`,
// under the case's lock (read again there: another writer may have added one). An empty name
// becomes "T<n>"; a name the case already has is an InputError. Returns the analysis as stored
// and the step's log sequence number.
struct RecordedTrajectory {
  TrajectoryAnalysis analysis;
  std::size_t log_seq = 0;
};
RecordedTrajectory record_trajectory_analysis(CaseFolder& folder, TrajectoryAnalysis analysis,
                                              const std::string& parameters_json,
                                              double duration_s);

}  // namespace locard::forensics
