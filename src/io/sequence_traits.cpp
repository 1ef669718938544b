// Sequence traits from the data: capture.json / simulation.json of `locard scan-sim`, frame
// timing, ground-truth motion, hole-free depth; and the negative-fy convention of ICL-NUIM.
// Which evidence sets which trait for each dataset: docs/sensors.md.
#include "io/json_file.hpp"
#include "io/sequence_detail.hpp"

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace locard::io_detail {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

double median(std::vector<double> v) {
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

// A scan-sim sensor model name, parsed once here.
std::optional<DepthSensorKind> sensor_of_model(const std::string& model) {
  if (model == "kinect_v2") return DepthSensorKind::TimeOfFlight;
  if (model == "kinect_v1") return DepthSensorKind::StructuredLight;
  return std::nullopt;
}

std::optional<DepthSensorKind> parse_depth_sensor(const std::string& s) {
  for (DepthSensorKind k : {DepthSensorKind::StructuredLight, DepthSensorKind::TimeOfFlight,
                            DepthSensorKind::Synthetic})
    if (s == to_string(k)) return k;
  return std::nullopt;
}

std::optional<CaptureKind> parse_capture(const std::string& s) {
  for (CaptureKind k : {CaptureKind::HandHeldVideo, CaptureKind::TripodTurn})
    if (s == to_string(k)) return k;
  return std::nullopt;
}

std::string string_field(const fs::path& path, const json& j, const char* key) {
  if (!j[key].is_string())
    throw_input_error(path, fmt::format("\"{}\" must be a string, found {}", key, j[key].dump()));
  return j[key].get<std::string>();
}

}  // namespace

std::optional<double> median_frame_interval(const std::vector<FrameEntry>& frames) {
  if (frames.size() < 2) return std::nullopt;
  std::vector<double> dt;
  for (std::size_t i = 1; i < frames.size(); ++i)
    dt.push_back(frames[i].timestamp - frames[i - 1].timestamp);
  return median(std::move(dt));
}

CaptureKind capture_from_timestamps(const std::vector<FrameEntry>& frames) {
  const auto dt = median_frame_interval(frames);
  return dt && *dt < kMaxVideoFrameInterval ? CaptureKind::HandHeldVideo : CaptureKind::Unknown;
}

std::optional<MotionStep> median_ground_truth_step(const std::vector<FrameEntry>& frames) {
  std::vector<double> dt, dr;
  for (std::size_t i = 1; i < frames.size(); ++i) {
    const auto& a = frames[i - 1].T_world_camera;
    const auto& b = frames[i].T_world_camera;
    if (!a || !b) continue;
    dt.push_back(translation_difference_m(*a, *b));
    dr.push_back(rotation_difference_deg(*a, *b));
  }
  if (dt.empty()) return std::nullopt;
  return MotionStep{median(std::move(dt)), median(std::move(dr))};
}

std::optional<SequenceTraits> read_capture_json(const fs::path& folder) {
  const fs::path path = folder / "capture.json";
  if (!fs::is_regular_file(path)) return std::nullopt;
  const json j = io_detail::read_json_file(path);
  if (!j.is_object()) throw_input_error(path, "expected a JSON object");
  SequenceTraits t;
  t.source = "capture.json";
  std::optional<DepthSensorKind> from_model;
  std::string model;
  if (j.contains("sensor")) {
    model = string_field(path, j, "sensor");
    from_model = sensor_of_model(model);
    if (!from_model)
      throw_input_error(path, fmt::format("\"sensor\": unknown sensor '{}' (kinect_v2, kinect_v1)",
                                          model));
  }
  if (j.contains("depth_sensor")) {
    const std::string s = string_field(path, j, "depth_sensor");
    const auto kind = parse_depth_sensor(s);
    if (!kind)
      throw_input_error(path, fmt::format("\"depth_sensor\": unknown kind '{}' (time_of_flight, "
                                          "structured_light, synthetic)",
                                          s));
    if (from_model && *from_model != *kind)
      throw_input_error(path, fmt::format("\"depth_sensor\" is {} but \"sensor\" {} is {}", s,
                                          model, to_string(*from_model)));
    t.sensor = *kind;
  } else if (from_model) {
    t.sensor = *from_model;
  } else {
    throw_input_error(path, "needs \"depth_sensor\" (or \"sensor\")");
  }
  if (!j.contains("capture")) throw_input_error(path, "needs \"capture\"");
  const std::string capture = string_field(path, j, "capture");
  const auto kind = parse_capture(capture);
  if (!kind)
    throw_input_error(path, fmt::format("\"capture\": unknown kind '{}' (tripod_turn, "
                                        "hand_held_video)",
                                        capture));
  t.capture = *kind;
  if (!j.contains("color_registered_to_depth"))
    throw_input_error(path, "needs \"color_registered_to_depth\"");
  if (!j["color_registered_to_depth"].is_boolean())
    throw_input_error(path, fmt::format("\"color_registered_to_depth\" must be true or false, "
                                        "found {}",
                                        j["color_registered_to_depth"].dump()));
  t.color_registered_to_depth = j["color_registered_to_depth"].get<bool>();
  if (j.contains("ring_sizes")) {
    const json& rings = j["ring_sizes"];
    if (!rings.is_array())
      throw_input_error(path, fmt::format("\"ring_sizes\" must be an array of positive integers, "
                                          "found {}",
                                          rings.dump()));
    for (std::size_t i = 0; i < rings.size(); ++i) {
      if (!rings[i].is_number_integer() || rings[i].get<long long>() <= 0)
        throw_input_error(path, fmt::format("\"ring_sizes\"[{}] must be a positive integer, "
                                            "found {}",
                                            i, rings[i].dump()));
      t.ring_sizes.push_back(rings[i].get<std::size_t>());
    }
  }
  if (t.capture != CaptureKind::TripodTurn && !t.ring_sizes.empty())
    throw_input_error(path, "\"ring_sizes\" only applies to \"capture\": \"tripod_turn\"");
  if (!model.empty()) t.source += " (" + model + ")";
  return t;
}

std::optional<SequenceTraits> traits_from_simulation_json(const fs::path& folder) {
  const fs::path path = folder / "simulation.json";
  if (!fs::is_regular_file(path)) return std::nullopt;
  const json j = io_detail::read_json_file(path);
  if (!j.is_object() || j.value("generator", "") != "locard scan-sim") return std::nullopt;
  const auto bad = [&](const std::string& key, const std::string& what) {
    throw_input_error(path, fmt::format("\"{}\": {}", key, what));
  };
  if (!j.contains("sensor") || !j["sensor"].is_object() || !j["sensor"].contains("model") ||
      !j["sensor"]["model"].is_string())
    bad("sensor.model", "expected the simulated sensor's model name");
  const std::string model = j["sensor"]["model"].get<std::string>();
  const auto sensor = sensor_of_model(model);
  if (!sensor) bad("sensor.model", "unknown sensor '" + model + "' (kinect_v2, kinect_v1)");
  SequenceTraits t;
  t.sensor = *sensor;
  t.capture = CaptureKind::TripodTurn;  // scan-sim simulates a tripod turn-around scan
  t.color_registered_to_depth = true;   // rgb/ is rendered on the depth pixel grid
  t.source = "simulation.json (locard scan-sim, " + model + ")";
  if (j.contains("ring_views")) {  // rings of different sizes
    const json& rings = j["ring_views"];
    if (!rings.is_array() || rings.empty()) bad("ring_views", "expected an array of view counts");
    for (const json& r : rings) {
      if (!r.is_number_integer() || r.get<long long>() <= 0)
        bad("ring_views", "each ring's views must be a positive integer");
      t.ring_sizes.push_back(r.get<std::size_t>());
    }
  } else if (j.contains("views") && j.contains("views_per_pitch_row")) {
    if (!j["views"].is_number_integer() || !j["views_per_pitch_row"].is_number_integer())
      bad("views", "\"views\" and \"views_per_pitch_row\" must be integers");
    const auto views = j["views"].get<long long>();
    const auto per_row = j["views_per_pitch_row"].get<long long>();
    if (per_row <= 0 || views <= 0 || views % per_row != 0)
      bad("views", fmt::format("{} views are not whole rings of {}", views, per_row));
    t.ring_sizes.assign(static_cast<std::size_t>(views / per_row),
                        static_cast<std::size_t>(per_row));
  }
  return t;
}

double valid_depth_share(const fs::path& depth_png, std::optional<std::uint16_t> invalid_value) {
  const DepthImage depth = read_depth_image(depth_png);
  if (depth.data().empty()) return 0.0;
  std::size_t valid = 0;
  for (const std::uint16_t d : depth.data())
    valid += d != 0 && (!invalid_value || d != *invalid_value);
  return static_cast<double>(valid) / static_cast<double>(depth.data().size());
}

void flip_negative_fy(RgbdSequence& sequence) {
  if (!(sequence.intrinsics.fy < 0.0)) return;
  const double fy = sequence.intrinsics.fy;
  sequence.intrinsics.fy = -fy;
  sequence.intrinsics_source += fmt::format(
      "; fy {:g} (image y up) used as {:g} with y down, ground truth as S T S, S = diag(1,-1,1)",
      fy, -fy);
  Isometry3d S = Isometry3d::Identity();
  S.linear().diagonal() << 1.0, -1.0, 1.0;
  // S T S is rigid: its rotation S R S has determinant +1. Applied here as a matrix product
  // so Isometry3d's affine part stays exact.
  const auto flip = [&](Isometry3d& T) {
    Isometry3d out;
    out.matrix() = S.matrix() * T.matrix() * S.matrix();
    T = out;
  };
  for (StampedPose& p : sequence.ground_truth) flip(p.T_world_camera);
  for (FrameEntry& f : sequence.frames)
    if (f.T_world_camera) flip(*f.T_world_camera);
}

}  // namespace locard::io_detail
