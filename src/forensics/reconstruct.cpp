#include <locard/forensics/reconstruct.hpp>

#include "forensics/json_util.hpp"
#include "forensics/reconstruct_stages.hpp"

#include <locard/alignment/alignment_defaults.hpp>
#include <locard/alignment/sequential_alignment.hpp>
#include <locard/alignment/stage_report.hpp>
#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_model.hpp>
#include <locard/forensics/floor_coverage.hpp>
#include <locard/forensics/floor_level.hpp>
#include <locard/forensics/integrity.hpp>
#include <locard/forensics/measurement.hpp>
#include <locard/forensics/pose_covariance.hpp>
#include <locard/forensics/report.hpp>
#include <locard/io/mesh_export.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/range_scans.hpp>
#include <locard/io/gravity.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/trajectory_io.hpp>
#include <locard/preprocess/depth_to_points.hpp>
#include <locard/surface/fusion.hpp>
#include <locard/surface/mesh_cleanup.hpp>
#include <locard/io/matrix_json.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace locard::forensics {
namespace {

// Points of up to `max_views` trusted views (evenly spread, every 8th pixel) in the frame
// T_world_estimate puts the model in, and the cameras' mean up (image -y) there: what
// find_floor_level needs to level a case whose data records no gravity.
std::pair<std::vector<Eigen::Vector3d>, Eigen::Vector3d> floor_evidence(
    const RgbdSequence& sequence, const AlignmentResult& result,
    const Isometry3d& T_world_estimate, std::size_t max_views) {
  std::vector<const FrameAlignment*> trusted;
  for (const FrameAlignment& f : result.frames)
    if (f.trusted() && f.T_world_camera_final) trusted.push_back(&f);
  std::vector<Eigen::Vector3d> points;
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  const std::size_t n = std::min(max_views, trusted.size());
  DepthToPointsOptions o;
  o.with_color = false;
  o.stride = 8;
  o.max_depth_m = 5.0;
  for (std::size_t k = 0; k < n; ++k) {
    const FrameAlignment& f = *trusted[k * trusted.size() / n];
    const Isometry3d T = T_world_estimate * *f.T_world_camera_final;
    up += T.linear() * -Eigen::Vector3d::UnitY();
    const PointCloud cloud = depth_to_points(sequence.load_frame(f.sequence_index), o, T);
    for (const Eigen::Vector3f& p : cloud.positions) points.push_back(p.cast<double>());
  }
  return {std::move(points), up};
}

}  // namespace

namespace fs = std::filesystem;
using nlohmann::json;

namespace detail {

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

void write_json(const fs::path& path, const json& j) {
  AtomicFile f(path, false);
  f.stream() << j.dump(1) << '\n';
  f.commit();
}

void write_text(const fs::path& path, const std::string& text) {
  AtomicFile f(path, false);
  f.stream() << text;
  f.commit();
}

// The parameters a file may set, with their JSON types checked on reading.
template <typename F>
void for_each_field(ReconstructParameters& p, F&& f) {
  f("mode", p.alignment.mode);
  f("odometry_icp", p.alignment.odometry_method);
  f("align_voxel_m", p.alignment.voxel_size);
  f("stride", p.alignment.stride);
  f("min_depth_m", p.alignment.min_depth_m);
  f("max_depth_m", p.alignment.max_depth_m);
  f("first_frame", p.alignment.first_frame);
  f("max_frames", p.alignment.max_frames);
  f("loop_closure", p.alignment.loop_closure);
  f("loop_max_angle_deg", p.alignment.loop_max_angle_deg);
  f("loop_max_distance_m", p.alignment.loop_max_distance_m);
  f("loop_min_fitness", p.alignment.loop_min_fitness);
  f("seed", p.alignment.seed);
  f("scan_poses", p.scan_poses);
  f("scan_voxel_m", p.scan_voxel_m);
  f("mesh_voxel_m", p.fusion.voxel_size);
  f("truncation_m", p.fusion.truncation);
  f("min_component", p.min_component);
  f("formats", p.formats);
  f("up", p.up);
  f("cloud_voxel_m", p.cloud_voxel_m);
  f("world_frame", p.world_frame);
  f("snap_radius_m", p.snap_radius_m);
  f("pdf", p.pdf);
  f("render_width", p.render_width);
  f("render_height", p.render_height);
  f("paper", p.paper);
  f("title", p.title);
}

// A parameter's JSON value: numbers, flags and text as they are, enums by their names.
template <typename T>
json field_json(const T& value) {
  return value;
}
json field_json(AlignmentMode v) { return std::string(to_string(v)); }
json field_json(IcpMethod v) { return std::string(to_string(v)); }
json field_json(ScanPoseSource v) { return std::string(to_string(v)); }
json field_json(UpAxis v) { return std::string(to_string(v)); }
json field_json(WorldFrameChoice v) { return std::string(to_string(v)); }
json field_json(PaperSize v) { return std::string(to_string(v)); }
json field_json(const std::vector<MeshFormat>& v) { return mesh_formats_text(v); }

// A named value from JSON text through its parser; false when it is not one of the names.
template <typename T, typename Parse>
bool named_from_json(const json& v, T& out, Parse parse) {
  if (!v.is_string()) return false;
  const auto parsed = parse(v.get<std::string>());
  if (!parsed) return false;
  out = *parsed;
  return true;
}

// Reads a parameter from JSON, checking its type (and for names, the name); false when wrong.
template <typename T>
bool field_from_json(const json& v, T& out) {
  const bool ok = std::is_same_v<T, bool>          ? v.is_boolean()
                  : std::is_same_v<T, std::string> ? v.is_string()
                  : std::is_floating_point_v<T>    ? v.is_number()
                                                   : v.is_number_integer() && v.get<double>() >= 0;
  if (ok) out = v.get<T>();
  return ok;
}
bool field_from_json(const json& v, AlignmentMode& out) {
  return named_from_json(v, out, parse_alignment_mode);
}
bool field_from_json(const json& v, IcpMethod& out) { return named_from_json(v, out, parse_icp_method); }
bool field_from_json(const json& v, ScanPoseSource& out) {
  return named_from_json(v, out, parse_scan_pose_source);
}
bool field_from_json(const json& v, UpAxis& out) { return named_from_json(v, out, parse_up_axis); }
bool field_from_json(const json& v, WorldFrameChoice& out) {
  return named_from_json(v, out, parse_world_frame_choice);
}
bool field_from_json(const json& v, PaperSize& out) { return named_from_json(v, out, parse_paper_size); }
bool field_from_json(const json& v, std::vector<MeshFormat>& out) {
  if (!v.is_string()) return false;
  try {
    out = parse_mesh_formats(v.get<std::string>());
  } catch (const InputError&) {
    return false;
  }
  return !out.empty();
}

// The names a named parameter accepts (for the error message); empty for the rest.
template <typename T>
std::string field_choices(const T&) {
  return "";
}
std::string field_choices(AlignmentMode) { return "cumulative, odometry"; }
std::string field_choices(IcpMethod) { return "colored, point-to-plane"; }
std::string field_choices(ScanPoseSource) { return "input, global"; }
std::string field_choices(UpAxis) { return "y, z"; }
std::string field_choices(WorldFrameChoice) { return "auto, first-camera"; }
std::string field_choices(PaperSize) { return "A4, letter"; }
std::string field_choices(const std::vector<MeshFormat>&) {
  return "a comma-separated list of ply, obj, gltf, glb, fbx";
}

json parameters_json(const ReconstructParameters& p) {
  json j = json::object();
  ReconstructParameters copy = p;
  for_each_field(copy, [&](const char* key, auto& value) { j[key] = field_json(value); });
  j["reference"] = p.reference.string();
  return j;
}

// Every file of the input, hashed (in parallel), sorted by path.
std::vector<FileRecord> hash_inputs(const fs::path& root, const ProgressCallback& progress) {
  std::vector<std::string> rel;
  if (fs::is_directory(root))
    rel = list_files_recursive(root);
  else
    rel.push_back(root.filename().string());
  const fs::path base = fs::is_directory(root) ? root : root.parent_path();
  std::vector<FileRecord> out(rel.size());
  std::atomic<std::size_t> done{0};
  tbb::parallel_for(std::size_t{0}, rel.size(), [&](std::size_t i) {
    out[i].path = rel[i];
    out[i].bytes = fs::file_size(base / rel[i]);
    out[i].sha256 = sha256_file(base / rel[i]);
    if (progress) progress(++done, rel.size());
  });
  return out;
}

std::string software_version() { return LOCARD_VERSION; }

}  // namespace detail

using namespace detail;

std::string ReconstructParameters::to_json() const { return parameters_json(*this).dump(1); }

ReconstructParameters ReconstructParameters::from_json_file(const fs::path& path,
                                                            const ReconstructParameters& defaults) {
  std::ifstream in(path);
  if (!in) throw_input_error(path, "cannot read the config file");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    throw_input_error(path, fmt::format("not valid JSON: {}", e.what()));
  }
  if (!j.is_object()) throw_input_error(path, "expected a JSON object of parameters");
  ReconstructParameters p = defaults;
  std::set<std::string> seen;
  std::vector<std::string> names;
  for_each_field(p, [&](const char* key, auto& value) {
    names.push_back(key);
    if (!j.contains(key)) return;
    seen.insert(key);
    if (!field_from_json(j[key], value)) {
      const std::string choices = field_choices(value);
      throw_input_error(path, fmt::format("\"{}\": wrong type or value{}", key,
                                          choices.empty() ? "" : " (expected " + choices + ")"));
    }
  });
  if (j.contains("reference")) {
    if (!j["reference"].is_string()) throw_input_error(path, "\"reference\": expected a path");
    p.reference = j["reference"].get<std::string>();
    seen.insert("reference");
  }
  for (const auto& [key, value] : j.items())
    if (!seen.count(key)) {
      std::string list;
      for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
      throw_input_error(path, fmt::format("unknown parameter '{}' (known: {}, reference)", key, list));
    }
  return p;
}

ReconstructParameters ReconstructParameters::defaults_for(const SequenceTraits& traits) {
  ReconstructParameters p;
  p.alignment = default_alignment_options(traits);
  return p;
}

// Per registered view: the self-check's confidence and, when flagged, why.
static json view_confidence_json(const AlignmentResult& result) {
  json views = json::array();
  for (const FrameAlignment& f : result.frames) {
    if (f.status != FrameStatus::Registered) continue;
    views.push_back({{"frame_index", f.frame_index},
                     {"verified", f.trusted()},
                     {"confidence", f.check.checked ? f.check.confidence : 1.0},
                     {"reason", f.check.reason}});
  }
  return views;
}

namespace {

// What the checks before anything is written found: the input, its format and sequence.
struct ReconstructPlan {
  fs::path input;
  fs::path input_root;  // absolute, normalised
  DatasetFormat format = DatasetFormat::Unknown;
  RgbdSequence sequence;
  fs::path reference;
  std::vector<ReferenceMeasurement> refs;
};

// Frames a list names outside the input folder (an absolute or ../ path) are read like any
// other, so they are inputs: hashed and recorded by their absolute path.
std::vector<fs::path> frames_outside(const RgbdSequence& sequence, const fs::path& input_root) {
  std::set<fs::path> outside;
  for (const FrameEntry& f : sequence.frames)
    for (const fs::path& p : {f.depth_path, f.color_path}) {
      if (p.empty()) continue;
      const fs::path full = fs::absolute(p).lexically_normal();
      const fs::path rel = full.lexically_relative(input_root);
      if (rel.empty() || *rel.begin() == "..") outside.insert(full);
    }
  return {outside.begin(), outside.end()};
}

// Every check that can be made before the case folder is touched (bad input: exit 2, nothing
// written).
ReconstructPlan plan_reconstruct(const fs::path& input, const ReconstructParameters& P) {
  ReconstructPlan plan;
  plan.input = input;
  if (!fs::exists(input)) throw_input_error(input, "no such file or folder");
  plan.format = detect_format(input);
  if (plan.format != DatasetFormat::Tum && plan.format != DatasetFormat::SevenScenes &&
      plan.format != DatasetFormat::Redwood)
    throw_input_error(input, fmt::format("expected an RGB-D sequence folder (TUM, 7-Scenes, "
                                         "Redwood or `locard scan-sim` output) or range scans "
                                         "(a Stanford .conf, a folder of two or more PLY/PCD "
                                         "scans, an E57 file of two or more scans), found {}",
                                         to_string(plan.format)));
  if (P.alignment.odometry_method == IcpMethod::PointToPoint)
    throw InputError("odometry_icp must be colored or point-to-plane, got 'point-to-point'");
  plan.sequence = open_rgbd_sequence(input);
  if (plan.sequence.frames.size() < 2)
    throw_input_error(input, "the sequence needs at least two frames");
  plan.reference = P.reference;
  if (plan.reference.empty() && fs::is_regular_file(input / "measurements.json"))
    plan.reference = input / "measurements.json";
  if (!plan.reference.empty()) plan.refs = read_reference_measurements(plan.reference);  // fail early
  plan.input_root = fs::absolute(input).lexically_normal();
  return plan;
}

// ---- coverage: what of the floor the views observed, with advice (floor_coverage.hpp). Only
// in a levelled case: without a floor plane there is nothing to judge, and the case says so.
void run_coverage_stage(CaseFolder& folder, const RgbdSequence& sequence,
                        const AlignmentResult& result,
                        const std::vector<std::optional<Isometry3d>>& poses,
                        const ReconstructParameters& P, ReconstructSummary& summary,
                        const std::function<void(const std::string&)>& note) {
  const auto t0 = Clock::now();
  const auto [points, up] = floor_evidence(sequence, result, Isometry3d::Identity(), 12);
  const std::optional<double> floor_z = floor_height(points);
  if (!floor_z) {
    note("coverage not computed: no horizontal floor plane in the levelled case");
    return;
  }
  FloorCoverageOptions options;
  options.min_depth_m = P.alignment.min_depth_m;
  options.max_depth_m = P.alignment.max_depth_m;
  const FloorCoverage coverage = compute_floor_coverage(sequence, poses, *floor_z, options);
  write_text(folder.path("coverage/floor_coverage.json"), floor_coverage_json(coverage));
  summary.floor_seen_share = coverage.seen_share();
  summary.coverage_advice = coverage.advice;
  LogStep s;
  s.step = "coverage";
  s.parameters_json = json{{"cell_m", options.cell_m}, {"floor_z_m", *floor_z},
                           {"views", coverage.views_used}}.dump();
  s.duration_s = seconds_since(t0);
  s.inputs = {"alignment/trajectory.txt"};
  s.outputs = {"coverage/floor_coverage.json"};
  folder.append_log_step(s);
  summary.stage_seconds.emplace_back("coverage", seconds_since(t0));
}

// What every stage of one reconstruction reads, and the progress and notes it reports.
struct StageContext : StageHooks {
  CaseFolder& folder;
  const ReconstructPlan& plan;
  const ReconstructParameters& P;
  ReconstructSummary& summary;
};

// ---- ingest: hash the inputs (and frames named outside the input folder), write case.json
json ingest_stage(const StageContext& c, const SensorNoiseModel& noise) {
  CaseFolder& folder = c.folder;
  const ReconstructParameters& P = c.P;
  const fs::path& input_root = c.plan.input_root;
  const fs::path& case_dir = folder.root();
  const RgbdSequence& sequence = c.plan.sequence;
  const DatasetFormat format = c.plan.format;
  ReconstructSummary& summary = c.summary;
  auto t0 = Clock::now();
  std::vector<FileRecord> inputs = hash_inputs(input_root, c.begin("hash inputs", 0));
  c.end("hash inputs");
  for (const fs::path& p : frames_outside(sequence, input_root))
    inputs.push_back({p.string(), fs::file_size(p), sha256_file(p)});
  json input_files = json::array();
  for (const FileRecord& r : inputs)
    input_files.push_back({{"path", r.path}, {"bytes", r.bytes}, {"sha256", r.sha256}});
  json seeds = {{"ransac", P.alignment.seed}};
  if (fs::is_regular_file(input_root / "simulation.json")) {
    std::ifstream sim_in(input_root / "simulation.json");
    try {
      const json sim = json::parse(sim_in);
      if (sim.contains("seed")) seeds["simulation"] = sim["seed"];
    } catch (const json::parse_error& e) {  // the seed is a record, not an input: say so, go on
      c.note(fmt::format("{}: not JSON ({}); the simulation seed is not recorded",
                         (input_root / "simulation.json").string(), e.what()));
    }
  }
  json case_json = {
      {"format", "locard-case/1"},
      {"title", P.title.empty() ? "Case " + fs::absolute(case_dir).filename().string() : P.title},
      {"created", utc_now_iso8601()},
      {"software", {{"name", "locard"}, {"version", software_version()}}},
      {"command", "reconstruct"},
      {"inputs",
       {{"root", input_root.string()},
        {"format", std::string(to_string(format))},
        {"frames", sequence.frames.size()},
        {"ground_truth", sequence.ground_truth_source},
        {"files", input_files}}},
      {"sensor",
       {{"intrinsics_name", sequence.intrinsics.name},
        {"intrinsics_source", sequence.intrinsics_source},
        {"width", sequence.intrinsics.width},
        {"height", sequence.intrinsics.height},
        {"fx", sequence.intrinsics.fx},
        {"fy", sequence.intrinsics.fy},
        {"cx", sequence.intrinsics.cx},
        {"cy", sequence.intrinsics.cy},
        {"depth_scale", sequence.depth_scale},
        {"noise_model", noise.name},
        {"depth_step_m", noise.depth_step_m},
        {"depth_sensor", std::string(to_string(sequence.traits.sensor))},
        {"capture", std::string(to_string(sequence.traits.capture))},
        {"color_registered_to_depth", sequence.traits.color_registered_to_depth},
        {"ring_sizes", sequence.traits.ring_sizes},
        {"traits_source", sequence.traits.source}}},
      {"parameters", parameters_json(P)},
      {"seeds", seeds},
      {"units", {{"length", "m"}, {"angle", "deg"}}}};
  write_json(folder.path("case.json"), case_json);
  {
    LogStep s;
    s.step = "ingest";
    s.parameters_json = json{{"input", input_root.string()}, {"files", inputs.size()}}.dump();
    s.duration_s = seconds_since(t0);
    s.outputs = {"case.json"};
    folder.append_log_step(s);
  }
  summary.stage_seconds.emplace_back("ingest", seconds_since(t0));
  return case_json;
}

// ---- align: the sequence's views registered, loop-closed and checked (align_sequence)
AlignmentResult align_stage(const StageContext& c, AlignmentOptions& ao) {
  const ReconstructParameters& P = c.P;
  const RgbdSequence& sequence = c.plan.sequence;
  ReconstructSummary& summary = c.summary;
  ao = P.alignment;
  // What the data is, whatever the parameters say: a turn's rings, and whether its colour
  // may pull (registered to depth).
  const AlignmentOptions from_data = default_alignment_options(sequence.traits);
  ao.ring_sizes = from_data.ring_sizes;
  ao.refinement_color = from_data.refinement_color;
  ao.pose_graph.max_correspondence_distance = 1.5 * P.alignment.voxel_size;
  const std::size_t first = std::min(P.alignment.first_frame, sequence.frames.size());
  const std::size_t left = sequence.frames.size() - first;
  const std::size_t total = P.alignment.max_frames ? std::min(P.alignment.max_frames, left) : left;
  ao.progress = c.begin("align", total);
  AlignmentResult result = align_sequence(sequence, ao);
  c.end("align");
  for (const FrameAlignment& f : result.frames) summary.registered += f.status == FrameStatus::Registered;
  summary.usable = result.usable_frames();
  summary.verified = result.trusted_frames();
  summary.flagged = result.flagged_frame_indices();
  summary.enough_verified = result.enough_trusted();
  for (const FrameAlignment& f : result.frames)
    if (f.status == FrameStatus::Registered && f.check.checked && !f.check.verified)
      c.note(fmt::format("frame {} flagged by the self-check, left out of the mesh and the "
                       "measurements: {}",
                       f.frame_index, f.check.reason));
  if (summary.registered < 2)
    throw InputError(fmt::format("{}: fewer than two frames could be registered; nothing to "
                                 "reconstruct",
                                 c.plan.input.string()));
  if (result.pieces > 1)
    c.note(fmt::format("the sequence falls into {} unconnected pieces; only piece 0 is meshed",
                     result.pieces));
  return result;
}

// Where the model goes: the input's world frame where the first registered view's pose is
// known (the gauge), levelled from the data's gravity or else from the floor.
struct WorldFrame {
  Isometry3d T_world_estimate = Isometry3d::Identity();
  std::string description;   // the case's world_frame sentence
  std::string level_source;  // "gravity", "floor", "floor, level as given"; empty: not levelled
};

WorldFrame choose_world_frame(const StageContext& c, const AlignmentResult& result) {
  // Gauge: move the model so the first registered view sits at its known pose, if any.
  WorldFrame frame;
  Isometry3d& T_world_estimate = frame.T_world_estimate;
  std::string& world_frame = frame.description;
  world_frame = "camera frame of the first registered view";
  bool in_input_frame = false;  // the data's world frame (its gravity, if recorded, applies)
  if (c.P.world_frame == WorldFrameChoice::Auto && !result.node_frames.empty()) {
    const FrameAlignment& f0 = result.frames[result.node_frames[0]];
    const auto& gt = c.plan.sequence.frames[f0.sequence_index].T_world_camera;
    if (gt && f0.T_world_camera_final) {
      T_world_estimate = *gt * f0.T_world_camera_final->inverse();
      in_input_frame = true;
      world_frame = fmt::format("the input's world frame, fixed by the known pose of frame {} "
                                "(the gauge); every other pose is estimated",
                                f0.frame_index);
    }
  }
  // Levelled: where the data records gravity in its world frame (and the model is in that
  // frame), the case turns about the origin so gravity points along -z - top views, plans,
  // walk mode and clipping assume z up.
  std::string& level_source = frame.level_source;  // empty: not levelled
  const std::optional<GravityDirection> gravity =
      in_input_frame ? read_gravity_direction(c.plan.sequence) : std::nullopt;
  if (gravity) {
    const Eigen::Matrix3d R_level = Eigen::Quaterniond::FromTwoVectors(gravity->down_world, -Eigen::Vector3d::UnitZ())
                  .toRotationMatrix();
    Isometry3d level = Isometry3d::Identity();
    level.linear() = R_level;
    T_world_estimate = level * T_world_estimate;
    level_source = "gravity";
    world_frame += fmt::format(", levelled: turned {:.1f} deg about the origin so the data's "
                               "gravity ({}) points along -z",
                               Eigen::AngleAxisd(R_level).angle() * 180.0 / M_PI, gravity->source);
  }
  // No recorded gravity: level from the floor. A frame that is the data's own and already level
  // within kKeepLevelDeg (a simulated scan, a survey) is kept as it is; a first camera's frame,
  // or a data frame that is not level, is turned so the floor's normal is +z.
  if (!gravity) {
    constexpr double kKeepLevelDeg = 5.0;
    const auto [points, up] = floor_evidence(c.plan.sequence, result, T_world_estimate, 12);
    const std::optional<FloorLevel> floor = find_floor_level(points, up);
    if (!floor) {
      world_frame += ", not levelled: the data records no gravity and no floor plane was found";
      c.note("not levelled: the data records no gravity and no floor was found in the views; "
           "top views and walk mode assume z up");
    } else if (in_input_frame && floor->tilt_deg <= kKeepLevelDeg) {
      level_source = "floor, level as given";
      world_frame += fmt::format(", level as given: the floor ({} points) lies within {:.2f} deg "
                                 "of the xy plane",
                                 floor->inliers, floor->tilt_deg);
    } else {
      Isometry3d level = Isometry3d::Identity();
      level.linear() = floor->R_level;
      T_world_estimate = level * T_world_estimate;
      level_source = "floor";
      world_frame += fmt::format(", levelled from the floor: turned {:.1f} deg about the origin so "
                                 "the floor plane ({} of {} sampled points, rms {:.1f} mm) is "
                                 "horizontal, z up",
                                 floor->tilt_deg, floor->inliers, floor->points, 1000 * floor->rms_m);
    }
  }
  return frame;
}

// Every estimated pose of the result moved by T (the gauge and the levelling).
void move_into_world(AlignmentResult& result, const Isometry3d& T_world_estimate) {
  for (FrameAlignment& f : result.frames) {
    if (f.T_world_camera_svd) f.T_world_camera_svd = T_world_estimate * *f.T_world_camera_svd;
    if (f.T_world_camera_icp) f.T_world_camera_icp = T_world_estimate * *f.T_world_camera_icp;
    if (f.T_world_camera_final) f.T_world_camera_final = T_world_estimate * *f.T_world_camera_final;
  }
  for (Isometry3d& T : result.graph.nodes) T = T_world_estimate * T;
}

// alignment/: stage report (JSON, SVG), trajectory (TUM), pose graph and pose covariances.
void write_alignment_files(const StageContext& c, const AlignmentResult& result,
                           const StageReport& stage, const ViewCovariances& cov,
                           const std::string& world_frame) {
  write_stage_report_json(c.folder.path("alignment/stage_report.json"), result, stage);
  write_stage_report_svg(c.folder.path("alignment/stage_report.svg"), result, stage);
  write_tum_trajectory(c.folder.path("alignment/trajectory.txt"), result.trajectory(0));
  json nodes = json::array(), edges = json::array(), rejected = json::array(), views = json::array();
  for (std::size_t k = 0; k < result.graph.nodes.size(); ++k) {
    const FrameAlignment& f = result.frames[result.node_frames[k]];
    nodes.push_back({{"node", k}, {"frame_index", f.frame_index}, {"timestamp", f.timestamp},
                     {"piece", f.piece}, {"T_world_camera", pose_json(result.graph.nodes[k])}});
    if (f.piece != 0) continue;
    views.push_back({{"node", k},
                     {"frame_index", f.frame_index},
                     {"timestamp", f.timestamp},
                     {"depth_path", fs::absolute(c.plan.sequence.frames[f.sequence_index].depth_path)
                                        .lexically_normal()
                                        .string()},
                     {"T_world_camera", pose_json(result.graph.nodes[k])},
                     {"verified", f.trusted()},
                     {"covariance", matrix_json(cov.covariances[k])},
                     {"sigma_translation_m", std::sqrt(cov.covariances[k].block<3, 3>(3, 3).trace())},
                     {"sigma_rotation_deg",
                      std::sqrt(cov.covariances[k].block<3, 3>(0, 0).trace()) * 180.0 / M_PI}});
  }
  auto edge_json = [&](const PoseGraphEdge& e) {
    return json{{"source_node", e.source},
                {"target_node", e.target},
                {"source_frame", result.frames[result.node_frames[e.source]].frame_index},
                {"target_frame", result.frames[result.node_frames[e.target]].frame_index},
                {"kind", e.uncertain ? "loop" : "odometry"},
                {"T_target_source", pose_json(e.T_target_source)},
                {"information", matrix_json(e.information)},
                {"line_process_weight", e.confidence},
                {"chi2", e.chi2}};
  };
  for (const PoseGraphEdge& e : result.graph.edges) edges.push_back(edge_json(e));
  for (const RejectedEdge& e : result.pose_graph.rejected) {
    json j = edge_json(e.edge);
    j["reason"] = e.reason;
    rejected.push_back(j);
  }
  write_json(c.folder.path("alignment/pose_graph.json"),
             {{"convention", "T_world_camera maps camera points to the world; an edge's "
                             "T_target_source maps source-camera points into the target "
                             "camera; information is 6x6, rotation then translation"},
              {"world_frame", world_frame},
              {"nodes", nodes},
              {"edges", edges},
              {"rejected_edges", rejected}});
  write_json(c.folder.path("alignment/pose_covariance.json"),
             {{"convention", "covariance: 6x6, left perturbation exp(delta) T_world_camera, "
                             "delta = (rotation rad, translation m) in the world frame"},
              {"residual_sigma_m", cov.sigmas},
              {"variance_factor", cov.variance_factor},
              {"views", views}});
}

// case.json's world frame, level and alignment summary, and the align step in the log.
void record_alignment(const StageContext& c, json& case_json, const AlignmentResult& result,
                      const StageReport& stage, const WorldFrame& frame, Clock::time_point t0) {
  const ReconstructParameters& P = c.P;
  ReconstructSummary& summary = c.summary;
  std::size_t loops = 0;
  for (const LoopCandidate& loop : result.loops) loops += loop.accepted;
  case_json["world_frame"] = frame.description;
  // Typed, for the report and the viewer: whether +z is up, and from what (not read from the
  // world_frame sentence).
  case_json["level"] = frame.level_source.empty()
                           ? json{{"levelled", false}}
                           : json{{"levelled", true}, {"source", frame.level_source}, {"up", {0.0, 0.0, 1.0}}};
  case_json["alignment"] = {
      {"frames", result.frames.size()},
      {"registered", summary.registered},
      {"pieces", result.pieces},
      {"loop_closures", loops},
      {"pose_graph", {{"initial_cost", result.pose_graph.initial_cost},
                      {"final_cost", result.pose_graph.final_cost}}},
      {"unregistered_frames", result.unregistered_frame_indices()},
      {"verified", summary.verified},
      {"usable", summary.usable},
      {"verified_share", result.trusted_share()},
      {"min_verified_share", result.options.min_verified_share},
      {"flagged_frames", summary.flagged},
      {"view_confidence", view_confidence_json(result)},
      {"seconds", result.timings.total_s}};
  if (stage.has_ground_truth) {
    json s = json::array();
    for (int k = 0; k < 3; ++k)
      s.push_back({{"stage", std::string(to_string(static_cast<AlignmentStage>(k)))},
                   {"views", stage.summary[k].views},
                   {"mean_translation_m", stage.summary[k].mean_translation_m},
                   {"max_translation_m", stage.summary[k].max_translation_m},
                   {"ate_rmse_m", stage.summary[k].ate_rmse_m ? json(*stage.summary[k].ate_rmse_m) : json()}});
    case_json["alignment"]["stage_errors"] = s;
  }
  write_json(c.folder.path("case.json"), case_json);
  {
    LogStep s;
    s.step = "align";
    s.parameters_json = json{{"mode", to_string(P.alignment.mode)}, {"odometry_icp", to_string(P.alignment.odometry_method)},
                             {"voxel_m", P.alignment.voxel_size}, {"stride", P.alignment.stride},
                             {"depth_range_m", {P.alignment.min_depth_m, P.alignment.max_depth_m}},
                             {"loop_closure", P.alignment.loop_closure}, {"seed", P.alignment.seed},
                             {"world_frame", frame.description}}.dump();
    s.duration_s = seconds_since(t0);
    s.outputs = {"alignment/trajectory.txt", "alignment/pose_graph.json",
                 "alignment/pose_covariance.json", "alignment/stage_report.json",
                 "alignment/stage_report.svg", "case.json"};
    c.folder.append_log_step(s);
  }
  summary.stage_seconds.emplace_back("align", seconds_since(t0));
}

// ---- mesh: the verified views of piece 0 fused (TSDF), cleaned and exported; their poses
std::vector<std::optional<Isometry3d>> mesh_stage(const StageContext& c, const AlignmentResult& result) {
  const ReconstructParameters& P = c.P;
  ReconstructSummary& summary = c.summary;
  const auto t0 = Clock::now();
  std::vector<std::optional<Isometry3d>> poses(c.plan.sequence.frames.size());
  for (const FrameAlignment& f : result.frames)
    if (f.trusted() && f.piece == 0)
      poses[f.sequence_index] = *f.T_world_camera_final;
  FusionOptions fo;
  fo.tsdf = P.fusion;
  if (fo.tsdf.truncation <= 0) fo.tsdf.truncation = 4.0 * fo.tsdf.voxel_size;
  fo.tsdf.max_depth_m = P.alignment.max_depth_m;
  fo.tsdf.min_depth_m = P.alignment.min_depth_m;
  fo.cloud_voxel = P.cloud_voxel_m;
  fo.progress = c.begin("mesh", summary.registered);
  FusionResult fused = fuse_sequence(c.plan.sequence, poses, fo);
  c.end("mesh");
  const std::size_t raw_triangles = fused.mesh.triangle_count();
  const ComponentReport components = remove_small_components(fused.mesh, P.min_component);
  const std::vector<fs::path> mesh_outputs = write_mesh_files(c.folder, fused.mesh, P.formats, P.up);
  write_ply(c.folder.path("cloud/registered.ply"), fused.cloud);
  write_json(c.folder.path("mesh/mesh.json"),
             {{"method", "tsdf"},
              {"voxel_size", fo.tsdf.voxel_size},
              {"truncation", fo.tsdf.truncation},
              {"depth_range", {fo.tsdf.min_depth_m, fo.tsdf.max_depth_m}},
              {"frames_fused", fused.frames_fused},
              {"raw_triangles", raw_triangles},
              {"removed_components", components.removed_components},
              {"removed_triangles", components.removed_triangles},
              {"inferred_triangles", 0},
              {"vertices", fused.mesh.vertex_count()},
              {"triangles", fused.mesh.triangle_count()},
              {"cloud_points", fused.cloud.size()},
              {"cloud_voxel", P.cloud_voxel_m}});
  summary.vertices = fused.mesh.vertex_count();
  summary.triangles = fused.mesh.triangle_count();
  {
    LogStep s;
    s.step = "mesh";
    s.parameters_json = json{{"method", "tsdf"}, {"voxel_m", P.fusion.voxel_size},
                             {"truncation_m", fo.tsdf.truncation},
                             {"min_component", P.min_component}, {"formats", mesh_formats_text(P.formats)},
                             {"cloud_voxel_m", P.cloud_voxel_m}}.dump();
    s.duration_s = seconds_since(t0);
    s.inputs = {"alignment/trajectory.txt"};
    s.outputs = mesh_outputs;
    s.outputs.push_back("mesh/mesh.json");
    s.outputs.push_back("cloud/registered.ply");
    c.folder.append_log_step(s);
  }
  summary.stage_seconds.emplace_back("mesh", seconds_since(t0));
  return poses;
}

// The stages, each a logged step, between the "begin" and "complete" lines.
void run_stages(CaseFolder& folder, const ReconstructPlan& plan, const ReconstructParameters& P,
                const StageCallbacks& cb, ReconstructSummary& summary) {
  const StageContext c{{cb}, folder, plan, P, summary};
  const SensorNoiseModel noise = SensorNoiseModel::for_sensor(plan.sequence.traits.sensor);
  json case_json = ingest_stage(c, noise);

  const auto t0 = Clock::now();
  AlignmentOptions ao;
  AlignmentResult result = align_stage(c, ao);
  const WorldFrame frame = choose_world_frame(c, result);
  move_into_world(result, frame.T_world_estimate);
  // Pose covariances: edge information scaled by the registration residual (at least the
  // sensor's noise floor at 1.5 m), inflated by the graph's variance factor.
  const ViewCovariances covariances =
      view_covariances(result, noise.axial_sigma_m(1.5, 0.0), ao.pose_graph.fixed_node);
  const StageReport stage = make_stage_report(result, plan.sequence);
  write_alignment_files(c, result, stage, covariances, frame.description);
  record_alignment(c, case_json, result, stage, frame, t0);

  const std::vector<std::optional<Isometry3d>> poses = mesh_stage(c, result);

  // ---- export e57: one scan per verified view (the views the mesh fused), at its pose
  write_views_e57(folder, rgbd_e57_views(plan.sequence, poses, P), {"alignment/trajectory.txt"},
                  json{{"views", "verified"}, {"points", "depth in the camera frame"},
                       {"voxel_m", P.cloud_voxel_m}}.dump(),
                  summary);

  run_coverage_stage(folder, plan.sequence, result, poses, P, summary,
                     [&c](const std::string& message) { c.note(message); });
  run_measure_stage(folder, plan.reference, plan.refs, P, StageHooks{cb}, summary);
  run_report_stage(folder, case_json["title"].get<std::string>(), P, StageHooks{cb}, summary);
}

}  // namespace

ReconstructSummary reconstruct_case(const fs::path& input, const fs::path& case_dir,
                                    const ReconstructParameters& P, bool force,
                                    const StageCallbacks& cb) {
  // Range scans (a .conf, a folder of scans, an E57 of several scans) take their own ingest,
  // alignment and surface stages, then the shared ones.
  if (fs::exists(input))
    if (const std::optional<RangeScanSet> scans = find_range_scans(input))
      return reconstruct_scan_case(*scans, case_dir, P, force, cb);
  const ReconstructPlan plan = plan_reconstruct(input, P);
  return run_bracketed(plan.input_root, case_dir, force,
                       [&](CaseFolder& folder, ReconstructSummary& summary) {
                         summary.frames = plan.sequence.frames.size();
                         run_stages(folder, plan, P, cb, summary);
                       });
}

}  // namespace locard::forensics
