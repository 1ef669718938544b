#pragma once
// The case's ad-hoc measurements (`locard measure` without --reference, the viewer's measure
// tool), typed: one reader and one writer that the CLI, the viewer, the case edits, the report
// and the CSV all go through.
//
// Files (docs/case-format.md): measurements/measurements.json
//   {"measurements": [{"name", "kind", "created", <what was measured>, <the value>,
//                      "previous_names": [...], "withdrawn": {"reason", "at"}}]}
// with, by kind,
//   point_to_point  "a", "b" (ends), "distance_m", "standard_uncertainty_m",
//                   "expanded_uncertainty_m", "coverage_factor"
//   point_to_plane  "point" (an end), "plane", "distance_m" (signed), "standard_uncertainty_m",
//                   "expanded_uncertainty_m"
//   plane_angle     "first", "second" (planes), "angle_deg", "standard_uncertainty_deg",
//                   "expanded_uncertainty_deg"
// an end  {"given", "snapped": [x,y,z], "feature", "snapped_to_feature", "views", "points",
//          "planes", "standard_uncertainty_m"}
// a plane {"point", "normal": [x,y,z], "rms_m", "points", "offset_sigma_m", "normal_sigma_deg"}
// and measurements/measurements.csv beside it, one row each (name,kind,value,unit,
// expanded_uncertainty,a_feature,b_feature,created,status,previous_names), always written
// together. A withdrawn measurement stays in both files (see revisions.hpp).

#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/measurement.hpp>
#include <locard/forensics/revisions.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard::forensics {

// Case-relative paths of the two files.
inline const std::filesystem::path kCaseMeasurementsJson = "measurements/measurements.json";
inline const std::filesystem::path kCaseMeasurementsCsv = "measurements/measurements.csv";

enum class MeasurementKind { PointToPoint, PointToPlane, PlaneAngle };
// "point_to_point", "point_to_plane", "plane_angle" (the files' "kind").
std::string_view to_string(MeasurementKind kind);

// One end of a measurement as recorded: where it was picked, where the model put it and why.
struct MeasuredEnd {
  Eigen::Vector3d given = Eigen::Vector3d::Zero();
  Eigen::Vector3d snapped = Eigen::Vector3d::Zero();
  SnapFeature feature = SnapFeature::NotSnapped;
  // The file's "snapped_to_feature": is_snapped(feature) in files written since snapping said
  // when it did not snap; absent (nullopt) in older ones, where an end left as picked was also
  // called "face" - so such an end is not taken as fixed by the model.
  std::optional<bool> snapped_to_feature;
  std::size_t views = 0;
  std::size_t points = 0;
  std::size_t planes = 0;
  double standard_uncertainty_m = 0.0;  // sqrt of the trace of the end's covariance

  bool fixed_by_model() const { return snapped_to_feature.value_or(false); }
};
MeasuredEnd measured_end(const SnappedPoint& point);

// A plane a measurement used, as recorded.
struct MeasuredPlane {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double rms_m = 0.0;
  std::size_t points = 0;
  double offset_sigma_m = 0.0;
  double normal_sigma_deg = 0.0;
};
MeasuredPlane measured_plane(const PlaneEstimate& plane);

struct CaseMeasurement {
  std::string name;
  MeasurementKind kind = MeasurementKind::PointToPoint;
  // What was measured, by kind (the others stay empty):
  //   PointToPoint: a, b;  PointToPlane: a (the point, "point") and plane;
  //   PlaneAngle: plane ("first") and second_plane ("second").
  std::optional<MeasuredEnd> a, b;
  std::optional<MeasuredPlane> plane, second_plane;
  // In metres (PointToPlane: signed, positive on the side the normal points to), or degrees
  // for PlaneAngle (unit()); standard (k = 1) and expanded uncertainty in the same unit.
  double value = 0.0;
  double standard_uncertainty = 0.0;
  double expanded_uncertainty = 0.0;
  std::optional<double> coverage_factor;  // recorded by PointToPoint only
  std::string created;                    // ISO 8601 UTC
  Revisions revisions;                    // earlier names, withdrawal

  bool is_angle() const { return kind == MeasurementKind::PlaneAngle; }
  std::string_view unit() const { return is_angle() ? "deg" : "m"; }
};

// A measurement as the case records it (created left empty: append_case_measurement sets it).
CaseMeasurement case_measurement(std::string name, const PointToPointMeasurement& m);
CaseMeasurement case_measurement(std::string name, const PointToPlaneMeasurement& m);
CaseMeasurement case_measurement(std::string name, const PlaneAngleMeasurement& m);

// Nothing when the file does not exist. Strict: anything else than the format above - not
// JSON, a key missing or unknown, a value of the wrong type, an unknown kind or feature, a
// "snapped_to_feature" that contradicts the feature - is an InputError naming the file and the
// place (`measurement 2 "door".a.feature: ...`, counted from 1 as `locard evidence` does).
std::vector<CaseMeasurement> read_case_measurements(const std::filesystem::path& json_path);
// Writes measurements.json and measurements.csv beside it (atomic each). InputError for a
// measurement the reader would refuse (no name, ends or planes not those of its kind).
void write_case_measurements(const std::filesystem::path& json_path,
                             const std::vector<CaseMeasurement>& measurements);
// The CSV (header, one row per measurement, withdrawn ones with their status).
std::string case_measurements_csv(const std::vector<CaseMeasurement>& measurements);
// Appends one to the case's files, stamped with the time now when `created` is empty; returns
// the case-relative paths written. The caller logs the step (CaseChange). InputError for an
// empty name.
std::vector<std::filesystem::path> append_case_measurement(const CaseFolder& folder,
                                                           CaseMeasurement measurement);

}  // namespace locard::forensics
