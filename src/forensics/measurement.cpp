// The three measurements on a case's model (point to point, point to plane, angle between
// planes) from snapped ends and fitted planes (snapping.cpp), and their entry in the case's
// measurements (case_measurements.hpp).
#include <locard/forensics/measurement.hpp>

#include "forensics/case_measurements_json.hpp"

#include <locard/core/error.hpp>
#include <locard/forensics/case_measurements.hpp>

#include <algorithm>
#include <cmath>

namespace locard::forensics {
namespace {
using Eigen::Vector3d;
}  // namespace

PointToPointMeasurement measure_point_to_point(const CaseModel& model, const Vector3d& a,
                                               const Vector3d& b, const SnapOptions& options) {
  const Vector3d ab = b - a;
  if (ab.norm() < 1e-6) throw InputError("the two measurement points coincide");
  const Vector3d d = ab.normalized();
  PointToPointMeasurement m;
  m.a = snap_point(model, a, -d, options);
  m.b = snap_point(model, b, d, options);
  const Vector3d diff = m.b.snapped - m.a.snapped;
  m.distance_m = diff.norm();
  const Vector3d u = diff.normalized();
  const double var = u.dot(m.a.covariance * u) + u.dot(m.b.covariance * u);
  m.standard_uncertainty_m = std::sqrt(std::max(0.0, var));
  m.coverage_factor = options.coverage_factor;
  m.expanded_uncertainty_m = m.coverage_factor * m.standard_uncertainty_m;
  return m;
}

PointToPlaneMeasurement measure_point_to_plane(const CaseModel& model, const Vector3d& point,
                                               const Vector3d& on_plane, double plane_radius_m,
                                               const SnapOptions& options) {
  PointToPlaneMeasurement m;
  m.plane = fit_plane_at(model, on_plane, plane_radius_m, options);
  m.point = snap_point(model, point, std::nullopt, options);
  m.distance_m = m.plane.normal.dot(m.point.snapped - m.plane.point);
  const double lever = (m.point.snapped - m.plane.point).norm() * m.plane.normal_sigma_rad;
  const double var = m.plane.normal.dot(m.point.covariance * m.plane.normal) +
                     m.plane.offset_sigma_m * m.plane.offset_sigma_m + lever * lever;
  m.standard_uncertainty_m = std::sqrt(var);
  m.expanded_uncertainty_m = options.coverage_factor * m.standard_uncertainty_m;
  return m;
}

PlaneAngleMeasurement measure_plane_angle(const CaseModel& model, const Vector3d& on_first,
                                          const Vector3d& on_second, double plane_radius_m,
                                          const SnapOptions& options) {
  PlaneAngleMeasurement m;
  m.first = fit_plane_at(model, on_first, plane_radius_m, options);
  m.second = fit_plane_at(model, on_second, plane_radius_m, options);
  const double c = std::clamp(std::abs(m.first.normal.dot(m.second.normal)), 0.0, 1.0);
  m.angle_deg = std::acos(c) * 180.0 / M_PI;
  m.standard_uncertainty_deg =
      std::hypot(m.first.normal_sigma_rad, m.second.normal_sigma_rad) * 180.0 / M_PI;
  m.expanded_uncertainty_deg = options.coverage_factor * m.standard_uncertainty_deg;
  return m;
}

std::string measurement_json(const PointToPointMeasurement& m) {
  return measurement_content_json(case_measurement("", m)).dump();
}

std::vector<std::filesystem::path> append_measurement(const CaseFolder& folder, const std::string& name,
                                                      const PointToPointMeasurement& m) {
  return append_case_measurement(folder, case_measurement(name, m));
}

std::vector<std::filesystem::path> append_measurement(const CaseFolder& folder, const std::string& name,
                                                      const PointToPlaneMeasurement& m) {
  return append_case_measurement(folder, case_measurement(name, m));
}

std::vector<std::filesystem::path> append_measurement(const CaseFolder& folder, const std::string& name,
                                                      const PlaneAngleMeasurement& m) {
  return append_case_measurement(folder, case_measurement(name, m));
}

}  // namespace locard::forensics
