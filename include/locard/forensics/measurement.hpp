#pragma once
// Measurements on the reconstructed model, each with an uncertainty.
//
// Snapping a point (snap_point). The raw depth points within search_radius_m of the given
// point (CaseModel::local_points) are split into planes by sequential RANSAC + least squares
// refit. With a measuring direction o (pointing away from the other end of a distance):
//   - a plane whose normal is within 35 degrees of o ("facing plane": a wall, a box's end face)
//     fixes the coordinate along o: the point moves along o onto it;
//   - planes along o ("side planes": the top of a box measured along its length) pull the
//     point onto themselves perpendicular to o; when their points stop within edge_margin_m
//     beyond the given point along o, the point is at an edge of the model and moves along o
//     to where the surface ends, found by counting points per view (measurement.cpp: the
//     density just inside the edge against the count beyond it; robust to lateral noise and
//     mixed pixels), pooled over the views; when too few points lie at the measuring line
//     (something in front hides the edge there), points up to edge_follow_m along the
//     straight edge are used;
//   - otherwise the point is in the middle of a face and keeps its position along o.
// Without a direction the point is projected onto the plane nearest to it ("face"), or onto
// the mesh when no plane fits ("surface"). With a direction and no facing plane or edge across
// it, the end is "not snapped": it keeps the picked place along the line (moved only onto side
// planes, across it). A point farther than max_snap_distance_m from the
// model is an InputError ("off the model").
//
// Uncertainty of a snapped point (standard, k = 1, a 3x3 covariance in the world frame):
//   sensor: sigma_axial^2 / n of the points that fixed it (plane offset), or the lateral
//           sigma plus the local spacing / sqrt(12) for an edge found from where points end;
//   plane fit: rms^2 / n; quantisation: depth_step^2 / 12;
//   poses: J Sigma_k J^T averaged over the observing views k (J = [-[p]x  I], the pose
//          covariance of pose_covariance.hpp), taken as fully correlated (not divided by n).
// A distance's standard uncertainty projects both covariances on the direction; the expanded
// uncertainty is coverage_factor (k = 2, about 95 %) times that, as the GUM recommends.

#include <locard/forensics/case_model.hpp>

#include <Eigen/Core>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard::forensics {

struct SnapOptions {
  double search_radius_m = 0.03;
  double max_snap_distance_m = 0.05;
  double edge_margin_m = 0.012;
  double edge_window_m = 0.006;  // density window just inside an edge (see snap_point)
  double edge_follow_m = 0.08;   // how far along a hidden edge its points may be taken from
  double coverage_factor = 2.0;
  std::size_t min_plane_points = 25;
  double plane_inlier_m = 0.004;
};

// What fixed a snapped point's place. With a measuring direction, only a feature across the
// line (a facing plane, an edge, a corner) fixes the end along it; otherwise the end is
// NotSnapped and the distance is only as good as the pick - said so everywhere it is shown,
// and never counted as measured within U in Table I.
enum class SnapFeature {
  Face,             // a plane facing the measuring direction (without one: the nearest plane)
  Edge,             // where one side plane's points end along the measuring direction
  Corner,           // where two or more side planes end
  EdgeOutermost,    // an edge from its outermost point (too few points near it to count)
  CornerOutermost,  // likewise for a corner
  MeshSurface,      // no plane around, no measuring direction: projected onto the mesh
  NotSnapped,       // nothing across the measuring line: the picked point is used as given
};
// "face", "edge", "corner", "edge (outermost point)", "corner (outermost point)", "surface",
// "not snapped" (what the case files, the CSV and the viewer carry).
std::string_view to_string(SnapFeature feature);
// A sentence for people: "not snapped: the picked point is used as given", "edge", ...
std::string describe(SnapFeature feature);
// True when the model fixed the end (every feature but NotSnapped).
constexpr bool is_snapped(SnapFeature feature) { return feature != SnapFeature::NotSnapped; }

struct SnappedPoint {
  Eigen::Vector3d given = Eigen::Vector3d::Zero();
  Eigen::Vector3d snapped = Eigen::Vector3d::Zero();
  SnapFeature feature = SnapFeature::NotSnapped;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // standard, m^2
  std::size_t views = 0;   // views that observed the spot
  std::size_t points = 0;  // raw points used
  std::size_t planes = 0;  // planes found around it
};

struct PointToPointMeasurement {
  SnappedPoint a, b;
  double distance_m = 0.0;
  double standard_uncertainty_m = 0.0;
  double expanded_uncertainty_m = 0.0;  // coverage_factor x standard
  double coverage_factor = 2.0;
};

struct PlaneEstimate {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   // on the plane, nearest the given point
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(); // unit
  double rms_m = 0.0;
  std::size_t points = 0;
  double offset_sigma_m = 0.0;  // standard uncertainty of the plane along its normal
  double normal_sigma_rad = 0.0;
};

struct PointToPlaneMeasurement {
  SnappedPoint point;
  PlaneEstimate plane;
  double distance_m = 0.0;  // signed: positive on the side the normal points to
  double standard_uncertainty_m = 0.0;
  double expanded_uncertainty_m = 0.0;
};

struct PlaneAngleMeasurement {
  PlaneEstimate first, second;
  double angle_deg = 0.0;  // between the normals' lines, 0..90
  double standard_uncertainty_deg = 0.0;
  double expanded_uncertainty_deg = 0.0;
};

// `outward` (unit or empty): see the header comment. Throws InputError for a point off the model.
SnappedPoint snap_point(const CaseModel& model, const Eigen::Vector3d& point,
                        const std::optional<Eigen::Vector3d>& outward = std::nullopt,
                        const SnapOptions& options = {});
PointToPointMeasurement measure_point_to_point(const CaseModel& model, const Eigen::Vector3d& a,
                                               const Eigen::Vector3d& b,
                                               const SnapOptions& options = {});
// The plane through the surface around `on_plane` (raw points within radius_m).
PlaneEstimate fit_plane_at(const CaseModel& model, const Eigen::Vector3d& on_plane,
                           double radius_m = 0.05, const SnapOptions& options = {});
PointToPlaneMeasurement measure_point_to_plane(const CaseModel& model,
                                               const Eigen::Vector3d& point,
                                               const Eigen::Vector3d& on_plane,
                                               double plane_radius_m = 0.05,
                                               const SnapOptions& options = {});
PlaneAngleMeasurement measure_plane_angle(const CaseModel& model, const Eigen::Vector3d& on_first,
                                          const Eigen::Vector3d& on_second,
                                          double plane_radius_m = 0.05,
                                          const SnapOptions& options = {});

// A tape measurement to compare the model with: points given as coordinates (world frame)
// or by evidence marker ("marker:3" or a marker's label; resolved by the caller's markers).
struct ReferenceMeasurement {
  std::string name;
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double true_distance_m = 0.0;
};

// Reads a reference file: the simulator's measurements.json ({"measurements": [{"name", "a",
// "b", "distance_m"}]}) or Locard's reference.json (same keys, "distance_m" the tape value;
// "a"/"b" may name evidence markers: `marker_lookup` returns their world point or nothing).
// Throws InputError naming the file and entry for missing keys, unknown keys, bad values,
// duplicate names and unknown marker names.
std::vector<ReferenceMeasurement> read_reference_measurements(
    const std::filesystem::path& path,
    const std::function<std::optional<Eigen::Vector3d>(const std::string&)>& marker_lookup = {});

struct TableRow {
  std::string name;
  double real_m = 0.0;
  double model_m = 0.0;
  double error_m = 0.0;                 // model - real
  double expanded_uncertainty_m = 0.0;  // k = 2
  // |error| <= expanded uncertainty, and both ends snapped: a row with an end not snapped
  // reads the tape point back and measures nothing, so it is never "within U".
  bool within_uncertainty = false;
  bool ends_snapped = false;  // both ends fixed by the model (is_snapped)
  PointToPointMeasurement detail;
  std::string not_measured;  // why the model could not give it (then model_m etc. are 0)
};

// The paper's Table I: each reference distance measured on the model.
std::vector<TableRow> compare_with_reference(const CaseModel& model,
                                             const std::vector<ReferenceMeasurement>& reference,
                                             const SnapOptions& options = {});

// measurements/table.json ({"coverage_factor", "rows": [{"name", "real_m", "model_m",
// "error_m", "expanded_uncertainty_m", "within_uncertainty", "a", "b"}]}) and table.csv.
void write_measurement_table(const CaseFolder& folder, const std::vector<TableRow>& rows);

// Ad-hoc measurements (CLI `locard measure`, the viewer) are appended to
// measurements/measurements.json and the CSV beside it (case_measurements.hpp: the format, its
// typed reader and writer; append_case_measurement(case_measurement(name, m))); returns the
// case-relative paths written. The caller appends the log step.
std::vector<std::filesystem::path> append_measurement(const CaseFolder& folder,
                                                      const std::string& name,
                                                      const PointToPointMeasurement& m);
std::vector<std::filesystem::path> append_measurement(const CaseFolder& folder,
                                                      const std::string& name,
                                                      const PointToPlaneMeasurement& m);
std::vector<std::filesystem::path> append_measurement(const CaseFolder& folder,
                                                      const std::string& name,
                                                      const PlaneAngleMeasurement& m);
// One measurement as JSON text (what append_measurement stores, without name and time).
std::string measurement_json(const PointToPointMeasurement& m);

}  // namespace locard::forensics
