#include <locard/forensics/case_model.hpp>

#include "forensics/json_util.hpp"
#include "io/json_file.hpp"

#include <locard/core/depth_noise.hpp>
#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/core/raycaster.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/ply.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <mutex>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

Isometry3d pose_from_json(const json& rows, const std::string& where) {
  if (!rows.is_array() || rows.size() != 4) throw InputError(where + ": expected a 4x4 matrix");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = rows.at(static_cast<std::size_t>(r)).at(static_cast<std::size_t>(c)).get<double>();
  Isometry3d T;
  T.matrix() = m;
  return T;
}

// A finite number > 0 at j[key], or InputError naming the file and the key.
double positive_number(const json& j, const char* key, const fs::path& path) {
  const json& v = j.at(key);
  if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() <= 0.0)
    throw_input_error(path, fmt::format("\"{}\" must be a positive number, found {}", key,
                                        v.dump()));
  return v.get<double>();
}

// alignment/pose_covariance.json: {"views": [{"frame_index", "timestamp", "T_world_camera"
// (4x4 rows), "verified"?, "covariance" (6x6 rows), "depth_path"?}, ...]}; views with
// "verified": false are not read. Any other shape, a missing key
// or a wrong type is an InputError naming the file and the view (never a raw JSON error).
std::vector<ViewRecord> read_view_records(const fs::path& path) {
  const json views_json = io_detail::read_json_file(path);
  std::vector<ViewRecord> views;
  std::size_t i = 0;
  try {
    if (!views_json.is_object() || !views_json.contains("views") ||
        !views_json.at("views").is_array())
      throw_input_error(path, "expected an object with a \"views\" array");
    for (const json& v : views_json.at("views")) {
      const std::string where = fmt::format("{}: views[{}]", path.string(), i);
      ViewRecord r;
      r.frame_index = v.at("frame_index").get<std::int64_t>();
      r.timestamp = v.at("timestamp").get<double>();
      r.T_world_camera = pose_from_json(v.at("T_world_camera"), where + ": T_world_camera");
      if (!r.T_world_camera.matrix().allFinite())
        throw InputError(where + ": T_world_camera must be finite");
      const json& c = v.at("covariance");
      if (!c.is_array() || c.size() != 6) throw InputError(where + ": covariance must be 6x6");
      for (int a = 0; a < 6; ++a) {
        const json& row = c.at(static_cast<std::size_t>(a));
        if (!row.is_array() || row.size() != 6)
          throw InputError(where + ": covariance must be 6x6");
        for (int b = 0; b < 6; ++b) r.covariance(a, b) = row.at(static_cast<std::size_t>(b)).get<double>();
      }
      r.depth_path = v.value("depth_path", "");
      ++i;
      // A view the self-check flagged is left out of the measurements as it is of the mesh:
      // its depth would lay a second, displaced copy of the surfaces beside the verified ones.
      // Cases written before the flag (and laser scans) have every view verified.
      const json& verified = v.contains("verified") ? v.at("verified") : json(true);
      if (!verified.is_boolean()) throw InputError(where + ": verified must be true or false");
      if (verified.get<bool>()) views.push_back(std::move(r));
    }
  } catch (const json::exception& e) {
    throw_input_error(path, fmt::format("views[{}]: {}", i, e.what()));
  }
  return views;
}

struct CaseSensor {
  CameraIntrinsics intrinsics;
  double depth_scale = 1000.0;
  SensorNoiseModel noise;
};

// case.json's "sensor": intrinsics, depth scale and the noise model (named, or from the kind
// of depth sensor, or for a legacy case from the intrinsics' preset name).
CaseSensor read_case_sensor(const fs::path& path) {
  const json case_json = io_detail::read_json_file(path);
  CaseSensor out;
  try {
    if (!case_json.is_object() || !case_json.contains("sensor") ||
        !case_json.at("sensor").is_object())
      throw_input_error(path, "expected an object with a \"sensor\" object");
    const json& sensor = case_json.at("sensor");
    // Range scans have no camera model: intrinsics stay invalid (observing_views then counts
    // every view) and the noise is the range scanner's.
    if (sensor.value("kind", "") == "range_scan") {
      out.noise.name = sensor.value("noise_model", "range_scanner");
      return out;
    }
    CameraIntrinsics& K = out.intrinsics;
    for (const char* key : {"width", "height"}) {
      const json& v = sensor.at(key);
      if (!v.is_number_integer() || v.get<std::int64_t>() < 1 || v.get<std::int64_t>() > 100000)
        throw_input_error(path, fmt::format("sensor: \"{}\" must be a whole number of pixels "
                                            "(1-100000), found {}", key, v.dump()));
    }
    K.width = sensor.at("width").get<int>();
    K.height = sensor.at("height").get<int>();
    K.fx = positive_number(sensor, "fx", path);
    K.fy = positive_number(sensor, "fy", path);
    K.cx = sensor.at("cx").get<double>();
    K.cy = sensor.at("cy").get<double>();
    K.name = sensor.value("intrinsics_name", "");
    SensorNoiseModel& noise = out.noise;
    if (sensor.contains("noise_model")) {
      noise.name = sensor.at("noise_model").get<std::string>();
    } else if (sensor.contains("depth_sensor")) {
      const std::string kind = sensor.at("depth_sensor").get<std::string>();
      DepthSensorKind parsed = DepthSensorKind::Unknown;
      for (DepthSensorKind k : {DepthSensorKind::StructuredLight, DepthSensorKind::TimeOfFlight,
                                DepthSensorKind::Synthetic})
        if (kind == to_string(k)) parsed = k;
      noise = SensorNoiseModel::for_sensor(parsed);
    } else {
      // Legacy case.json (before sequence traits): only the intrinsics' preset name.
      noise.name = K.name == "kinect_v2" ? "kinect_v2" : "structured_light";
    }
    noise.depth_step_m = sensor.contains("depth_step_m")
                             ? positive_number(sensor, "depth_step_m", path) : 0.001;
    out.depth_scale = sensor.contains("depth_scale")
                          ? positive_number(sensor, "depth_scale", path) : 1000.0;
  } catch (const json::exception& e) {
    throw_input_error(path, fmt::format("sensor: {}", e.what()));
  }
  return out;
}

}  // namespace

double SensorNoiseModel::axial_sigma_m(double z_m, double incidence_rad) const {
  if (name == "kinect_v2") return time_of_flight_axial_sigma_m(z_m, incidence_rad);
  const double grazing = 1.0 / std::max(0.2, std::cos(std::clamp(incidence_rad, 0.0, 1.5)));
  if (name == "structured_light") return (0.0012 + 0.0019 * (z_m - 0.4) * (z_m - 0.4)) * grazing;
  if (name == "realsense") return 0.008 * z_m * grazing;
  // Laser range scans: 1 mm, a terrestrial scanner's ranging noise at 10-25 m (an object
  // scanner's is lower: this overstates it, never understates it).
  if (name == "range_scanner") return 0.001 * grazing;
  throw InputError(fmt::format("unknown sensor noise model '{}' (kinect_v2, structured_light, "
                               "realsense, range_scanner)",
                               name));
}

double SensorNoiseModel::lateral_sigma_m(double z_m) const {
  if (name == "kinect_v2") return 0.0016;
  return 0.0015 * std::max(z_m, 0.5);  // about 1.5 mrad: a pixel and a half of jitter
}

SensorNoiseModel SensorNoiseModel::for_sensor(DepthSensorKind sensor) {
  SensorNoiseModel m;
  m.depth_step_m = 0.001;
  switch (sensor) {
    case DepthSensorKind::TimeOfFlight: m.name = "kinect_v2"; break;
    case DepthSensorKind::StructuredLight:
    case DepthSensorKind::Synthetic:
    case DepthSensorKind::Unknown: m.name = "structured_light"; break;
  }
  return m;
}

struct CaseModel::Impl {
  TriangleMesh mesh;
  Raycaster raycaster;
  KdTree vertex_tree;
  std::vector<ViewRecord> views;
  CameraIntrinsics intrinsics;
  double depth_scale = 1000.0;
  SensorNoiseModel noise;
  double voxel = 0.01;
  double truncation = 0.04;
  std::mutex mutex;
  std::vector<std::shared_ptr<const DepthImage>> depth;  // cache, per view
  std::vector<bool> depth_failed;

  Impl(TriangleMesh m, std::vector<ViewRecord> v)
      : mesh(std::move(m)), raycaster(mesh), vertex_tree(mesh.vertices), views(std::move(v)),
        depth(views.size()), depth_failed(views.size(), false) {}

  std::shared_ptr<const DepthImage> load_depth(std::size_t k) {
    std::lock_guard lock(mutex);
    if (depth[k] || depth_failed[k]) return depth[k];
    try {
      if (views[k].depth_path.empty() || !fs::is_regular_file(views[k].depth_path))
        throw InputError("missing");
      depth[k] = std::make_shared<const DepthImage>(read_depth_image(views[k].depth_path));
      if (depth[k]->width() != intrinsics.width || depth[k]->height() != intrinsics.height) {
        depth[k].reset();
        depth_failed[k] = true;
      }
    } catch (const Error&) {
      depth_failed[k] = true;
    }
    return depth[k];
  }
};

CaseModel::CaseModel(TriangleMesh mesh, std::vector<ViewRecord> views, CameraIntrinsics intrinsics,
                     double depth_scale, SensorNoiseModel noise, double model_voxel_m,
                     double model_truncation_m) {
  if (mesh.triangles.empty()) throw InputError("the model has no triangles to measure on");
  impl_ = std::make_unique<Impl>(std::move(mesh), std::move(views));
  impl_->intrinsics = std::move(intrinsics);
  impl_->depth_scale = depth_scale;
  impl_->noise = std::move(noise);
  impl_->voxel = model_voxel_m;
  impl_->truncation = model_truncation_m > 0 ? model_truncation_m : 4.0 * model_voxel_m;
}

CaseModel::~CaseModel() = default;
CaseModel::CaseModel(CaseModel&&) noexcept = default;
CaseModel& CaseModel::operator=(CaseModel&&) noexcept = default;

CaseModel CaseModel::load(const CaseFolder& folder) {
  const fs::path root = folder.root();
  TriangleMesh mesh = folder.load_mesh();
  const fs::path case_path = root / "case.json";
  const fs::path cov_path = root / "alignment" / "pose_covariance.json";
  std::vector<ViewRecord> views = read_view_records(cov_path);
  const CaseSensor sensor = read_case_sensor(case_path);
  double voxel = 0.01, truncation = 0.0;
  const fs::path mesh_json = root / "mesh" / "mesh.json";
  if (fs::exists(mesh_json)) {
    const json j = io_detail::read_json_file(mesh_json);
    if (!j.is_object()) throw_input_error(mesh_json, "expected a JSON object");
    if (j.contains("voxel_size")) voxel = positive_number(j, "voxel_size", mesh_json);
    if (j.contains("truncation")) truncation = positive_number(j, "truncation", mesh_json);
  }
  return CaseModel(std::move(mesh), std::move(views), sensor.intrinsics, sensor.depth_scale,
                   sensor.noise, voxel, truncation);
}

const TriangleMesh& CaseModel::mesh() const { return impl_->mesh; }
const Raycaster& CaseModel::raycaster() const { return impl_->raycaster; }
const std::vector<ViewRecord>& CaseModel::views() const { return impl_->views; }
const CameraIntrinsics& CaseModel::intrinsics() const { return impl_->intrinsics; }
const SensorNoiseModel& CaseModel::noise() const { return impl_->noise; }
double CaseModel::model_voxel_m() const { return impl_->voxel; }
double CaseModel::model_truncation_m() const { return impl_->truncation; }

double CaseModel::distance_to_mesh(const Eigen::Vector3d& p) const {
  Neighbor n;
  if (!impl_->vertex_tree.nearest(p.cast<float>(), n)) return std::numeric_limits<double>::infinity();
  return std::sqrt(static_cast<double>(n.squared_distance));
}

std::vector<std::uint32_t> CaseModel::observing_views(const Eigen::Vector3d& p,
                                                      double tolerance_m) const {
  std::vector<std::uint32_t> out;
  const CameraIntrinsics& K = impl_->intrinsics;
  if (!K.valid()) {  // range scans: no camera model to test visibility with
    for (std::uint32_t k = 0; k < impl_->views.size(); ++k) out.push_back(k);
    return out;
  }
  for (std::uint32_t k = 0; k < impl_->views.size(); ++k) {
    const Isometry3d& T = impl_->views[k].T_world_camera;
    const Eigen::Vector3d pc = T.inverse() * p;
    if (pc.z() <= 0.05) continue;
    const double u = K.fx * pc.x() / pc.z() + K.cx, v = K.fy * pc.y() / pc.z() + K.cy;
    if (u < 0 || v < 0 || u > K.width - 1 || v > K.height - 1) continue;
    const Eigen::Vector3d c = T.translation();
    const Eigen::Vector3d d = p - c;
    const double len = d.norm();
    const RayHit hit = impl_->raycaster.intersect(c.cast<float>(), d.cast<float>(), 0.0f, 2.0f);
    if (hit.hit() && hit.t * len < len - tolerance_m) continue;  // something in front of p
    out.push_back(k);
  }
  return out;
}

LocalPoints CaseModel::local_points(const Eigen::Vector3d& p, double radius_m) const {
  LocalPoints out;
  const std::vector<std::uint32_t> seen = observing_views(p);
  out.views_observing = seen.size();
  const CameraIntrinsics& K = impl_->intrinsics;
  bool any_depth = false;
  const double r2 = radius_m * radius_m;
  for (std::uint32_t k : seen) {
    const std::shared_ptr<const DepthImage> depth = impl_->load_depth(k);
    if (!depth) continue;
    any_depth = true;
    const Isometry3d& T = impl_->views[k].T_world_camera;
    const Eigen::Vector3d pc = T.inverse() * p;
    const double u0 = K.fx * pc.x() / pc.z() + K.cx, v0 = K.fy * pc.y() / pc.z() + K.cy;
    const int half = static_cast<int>(std::ceil(radius_m * K.fx / pc.z() * 1.5)) + 1;
    const int ulo = std::max(0, static_cast<int>(u0) - half), uhi = std::min(K.width - 1, static_cast<int>(u0) + half);
    const int vlo = std::max(0, static_cast<int>(v0) - half), vhi = std::min(K.height - 1, static_cast<int>(v0) + half);
    for (int v = vlo; v <= vhi; ++v)
      for (int u = ulo; u <= uhi; ++u) {
        const std::uint16_t raw = depth->at(u, v);
        if (raw == 0) continue;
        const double z = raw / impl_->depth_scale;
        // Mixed ("flying") pixels: strictly between two neighbours across a depth jump, on
        // either axis. They belong to neither surface, so they are left out. A surface seen at
        // grazing incidence climbs in depth by centimetres a pixel, every pixel strictly
        // between its neighbours: it is a slope, not a jump, where the next pixels out on both
        // sides go on climbing the same way, each by more than the 4 mm of a plateau's noise and
        // one by at least a third of the jump - else the filter leaves a table top seen from
        // just above a quarter of its pixels. A mixed pixel has a side that stops: the plateau
        // it was pulled away from (even where the surface behind climbs steeply, a floor seen
        // edge-on).
        auto depth_at = [&](int uu, int vv) {
          if (uu < 0 || vv < 0 || uu >= K.width || vv >= K.height) return 0.0;
          return depth->at(uu, vv) / impl_->depth_scale;
        };
        auto mixed = [&](int du, int dv) {
          const double z0 = depth_at(u - du, v - dv), z1 = depth_at(u + du, v + dv);
          if (z0 == 0.0 || z1 == 0.0) return false;
          const double a = z0 - z, b = z1 - z, jump = std::abs(a - b);
          if (!(a * b < 0 && jump > 0.04 && std::min(std::abs(a), std::abs(b)) > 0.004)) return false;
          const double zm = depth_at(u - 2 * du, v - 2 * dv), zp = depth_at(u + 2 * du, v + 2 * dv);
          if (zm == 0.0 || zp == 0.0) return true;
          const double inner = b - a, before = z0 - zm, after = zp - z1;
          const bool slope = before * inner > 0 && after * inner > 0 &&
                             std::min(std::abs(before), std::abs(after)) > 0.004 &&
                             std::max(std::abs(before), std::abs(after)) >= jump / 3.0;
          return !slope;
        };
        if (mixed(1, 0) || mixed(0, 1)) continue;
        const Eigen::Vector3d q = T * Eigen::Vector3d((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z);
        if ((q - p).squaredNorm() > r2) continue;
        out.points.push_back(q);
        out.axial_sigma_m.push_back(impl_->noise.axial_sigma_m(z, 0.0));
        out.view.push_back(k);
      }
  }
  if (!any_depth) {
    out.from_raw_depth = false;
    std::vector<Neighbor> near;
    impl_->vertex_tree.radius(p.cast<float>(), static_cast<float>(radius_m), near);
    for (const Neighbor& n : near) {
      out.points.push_back(impl_->mesh.vertices[n.index].cast<double>());
      out.axial_sigma_m.push_back(impl_->voxel / std::sqrt(12.0));
      out.view.push_back(0);
    }
  }
  return out;
}

}  // namespace locard::forensics
