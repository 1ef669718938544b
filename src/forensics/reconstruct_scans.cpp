// `reconstruct` on range scans (docs/laser-scans.md): its own ingest, alignment and surface
// stages, then the stages every case shares (E57 export, measurements, report). Each stage is
// a function over ScanCase; the case folder has the RGB-D case's layout.
#include "forensics/reconstruct_stages.hpp"

#include <locard/alignment/scan_alignment.hpp>
#include <locard/alignment/sequential_alignment.hpp>
#include <locard/core/error.hpp>
#include <locard/forensics/pose_covariance.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/trajectory_io.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/surface/mesh_cleanup.hpp>
#include <locard/surface/point_cloud_meshing.hpp>

#include "forensics/json_util.hpp"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace locard::forensics::detail {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// What the checks before anything is written found.
struct ScanPlan {
  RangeScanSet set;
  fs::path input_root;  // the folder holding the input (every file in it is hashed)
  fs::path reference;
  std::vector<ReferenceMeasurement> refs;
  std::vector<PointCloud> scans;  // each in its own frame
};

struct ScanCase {
  const ScanPlan& plan;
  const ReconstructParameters& P;
  StageHooks hooks;
  json case_json;
  double spacing = 0.0;  // median point spacing of the scans (metres)
  ScanAlignmentResult alignment;
  PointCloud surface_cloud;  // world frame, with normals
};

ScanPlan plan_scans(const RangeScanSet& set, const ReconstructParameters& P) {
  ScanPlan plan;
  plan.set = set;
  if (!(P.scan_voxel_m >= 0.0)) throw InputError("scan_voxel_m must be 0 (automatic) or positive");
  if (set.scans.size() < 2)
    throw_input_error(set.input, fmt::format("expected at least two scans, found {}", set.scans.size()));
  const fs::path input = fs::absolute(set.input).lexically_normal();
  plan.input_root = fs::is_directory(input) ? input : input.parent_path();
  plan.reference = P.reference;
  if (plan.reference.empty() && fs::is_regular_file(plan.input_root / "measurements.json"))
    plan.reference = plan.input_root / "measurements.json";
  if (!plan.reference.empty()) plan.refs = read_reference_measurements(plan.reference);
  plan.scans = load_range_scans(set);
  for (std::size_t i = 0; i < plan.scans.size(); ++i)
    if (plan.scans[i].size() < 6)
      throw_input_error(set.scans[i].file, fmt::format("scan {} ({}) has {} points; a scan needs "
                                                       "at least 6",
                                                       i, set.scans[i].name, plan.scans[i].size()));
  return plan;
}

std::string_view viewpoint_text(ScanViewpoint v) {
  return v == ScanViewpoint::Origin ? "origin of the scan's frame" : "far along the scan's +z";
}

// ---- ingest: hash the input folder, write case.json
void ingest(CaseFolder& folder, ScanCase& c) {
  const auto t0 = Clock::now();
  const std::vector<FileRecord> inputs = hash_inputs(c.plan.input_root, c.hooks.begin("hash inputs", 0));
  c.hooks.end("hash inputs");
  json files = json::array();
  for (const FileRecord& r : inputs) files.push_back({{"path", r.path}, {"bytes", r.bytes}, {"sha256", r.sha256}});
  const RangeScanSet& set = c.plan.set;
  c.case_json = {
      {"format", "locard-case/1"},
      {"title", c.P.title.empty() ? "Case " + fs::absolute(folder.root()).filename().string() : c.P.title},
      {"created", utc_now_iso8601()},
      {"software", {{"name", "locard"}, {"version", software_version()}}},
      {"command", "reconstruct"},
      {"inputs", {{"root", c.plan.input_root.string()}, {"format", std::string(to_string(set.source))},
                  {"input", fs::absolute(set.input).lexically_normal().string()},
                  {"frames", set.scans.size()}, {"ground_truth", ""}, {"files", files}}},
      {"sensor", {{"kind", "range_scan"}, {"noise_model", "range_scanner"},
                  {"depth_sensor", "unknown"}, {"viewpoint", std::string(viewpoint_text(set.viewpoint))},
                  {"point_spacing_m", c.spacing}}},
      {"parameters", parameters_json(c.P)},
      {"seeds", {{"ransac", c.P.alignment.seed}}},
      {"units", {{"length", "m"}, {"angle", "deg"}}}};
  write_json(folder.path("case.json"), c.case_json);
  LogStep s;
  s.step = "ingest";
  s.parameters_json = json{{"input", c.plan.input_root.string()}, {"files", inputs.size()}}.dump();
  s.duration_s = seconds_since(t0);
  s.outputs = {"case.json"};
  folder.append_log_step(s);
}

std::string scan_name(const ScanCase& c, std::size_t i) { return c.plan.set.scans[i].name; }

// Per-scan confidence and why a scan was left out (the stage report's rows).
json scan_rows(const ScanCase& c) {
  const ScanAlignmentResult& r = c.alignment;
  json rows = json::array();
  for (std::size_t i = 0; i < r.placed.size(); ++i) {
    std::string reason;
    if (!r.placed[i]) reason = "no verified overlap with the registered scans: left out";
    rows.push_back({{"frame_index", i}, {"name", scan_name(c, i)}, {"verified", r.placed[i] != 0},
                    {"confidence", r.fit[i].fitness}, {"inlier_rmse_m", r.fit[i].inlier_rmse},
                    {"input_pose", c.plan.set.scans[i].T_world_scan.has_value()},
                    {"root", i == r.root}, {"reason", reason}});
  }
  return rows;
}

json pair_rows(const ScanCase& c) {
  json rows = json::array();
  for (const ScanPair& p : c.alignment.pairs)
    rows.push_back({{"source", p.source}, {"target", p.target}, {"verified", p.verified},
                    {"spanning_tree", p.in_tree}, {"kept", p.kept}, {"fitness", p.fitness},
                    {"inlier_rmse_m", p.inlier_rmse}, {"reason", p.reason},
                    {"T_target_source", pose_json(p.T_target_source)}});
  return rows;
}

// Pose covariances from the graph, each edge weighted by its scans' residual (at least a tenth
// of the point spacing).
std::vector<Matrix6d> scan_covariances(const ScanCase& c) {
  const ScanAlignmentResult& r = c.alignment;
  std::vector<double> sigmas;
  for (const PoseGraphEdge& e : r.graph.edges) {
    const std::size_t a = r.graph_scans[e.source], b = r.graph_scans[e.target];
    sigmas.push_back(std::max({0.1 * c.spacing, r.fit[a].inlier_rmse, r.fit[b].inlier_rmse}));
  }
  if (sigmas.empty()) return std::vector<Matrix6d>(r.graph.nodes.size(), Matrix6d::Zero());
  const auto root = std::find(r.graph_scans.begin(), r.graph_scans.end(), r.root);
  return pose_covariances(r.graph, sigmas, static_cast<std::size_t>(root - r.graph_scans.begin()));
}

void write_alignment_files(CaseFolder& folder, const ScanCase& c, const std::string& world_frame) {
  const ScanAlignmentResult& r = c.alignment;
  Trajectory trajectory;
  for (std::size_t i = 0; i < r.placed.size(); ++i)
    if (r.placed[i]) trajectory.push_back({static_cast<std::int64_t>(i), static_cast<double>(i), r.T_world_scan[i]});
  write_tum_trajectory(folder.path("alignment/trajectory.txt"), trajectory);
  const std::vector<Matrix6d> cov = scan_covariances(c);
  json nodes = json::array(), views = json::array(), edges = json::array();
  for (std::size_t k = 0; k < r.graph_scans.size(); ++k) {
    const std::size_t i = r.graph_scans[k];
    nodes.push_back({{"node", k}, {"frame_index", i}, {"name", scan_name(c, i)}, {"piece", 0},
                     {"T_world_camera", pose_json(r.T_world_scan[i])}});
    views.push_back({{"node", k}, {"frame_index", i}, {"timestamp", static_cast<double>(i)},
                     {"name", scan_name(c, i)}, {"T_world_camera", pose_json(r.T_world_scan[i])},
                     {"covariance", matrix_json(cov[k])},
                     {"sigma_translation_m", std::sqrt(cov[k].block<3, 3>(3, 3).trace())},
                     {"sigma_rotation_deg", std::sqrt(cov[k].block<3, 3>(0, 0).trace()) * 180.0 / M_PI}});
  }
  for (const PoseGraphEdge& e : r.graph.edges)
    edges.push_back({{"source_node", e.source}, {"target_node", e.target},
                     {"kind", e.uncertain ? "loop" : "odometry"}, {"T_target_source", pose_json(e.T_target_source)},
                     {"information", matrix_json(e.information)}, {"line_process_weight", e.confidence}});
  write_json(folder.path("alignment/pose_graph.json"),
             {{"convention", "T_world_camera maps a scan's points into the world (the scan's frame "
                             "is its camera); odometry edges are the spanning tree's pairs, loop "
                             "edges the other verified pairs"},
              {"world_frame", world_frame}, {"nodes", nodes}, {"edges", edges}});
  write_json(folder.path("alignment/pose_covariance.json"),
             {{"convention", "covariance: 6x6, left perturbation exp(delta) T_world_camera, delta = "
                             "(rotation rad, translation m) in the world frame"},
              {"views", views}});
  write_json(folder.path("alignment/stage_report.json"),
             {{"kind", "range_scans"}, {"root", r.root}, {"scans", scan_rows(c)}, {"pairs", pair_rows(c)},
              {"seconds", r.seconds}});
}

std::string describe_world_frame(const ScanCase& c) {
  const ScanAlignmentResult& r = c.alignment;
  const bool input_frame = c.P.scan_poses == ScanPoseSource::Input && c.plan.set.all_posed();
  if (input_frame)
    return fmt::format("the input's frame: every scan pose re-estimated, scan {} ({}) kept at the "
                       "pose the input gives it (the gauge); not levelled",
                       r.root, scan_name(c, r.root));
  return fmt::format("the frame of scan {} ({}), the gauge; not levelled", r.root, scan_name(c, r.root));
}

// ---- align: multiway registration (scan_alignment.hpp)
void align(CaseFolder& folder, ScanCase& c, ReconstructSummary& summary) {
  const auto t0 = Clock::now();
  ScanAlignmentOptions o = scan_alignment_options_for_spacing(c.spacing);
  o.seed = c.P.alignment.seed;
  std::vector<std::optional<Isometry3d>> initial;
  if (c.P.scan_poses == ScanPoseSource::Input && c.plan.set.any_posed())
    for (const RangeScanEntry& s : c.plan.set.scans) initial.push_back(s.T_world_scan);
  c.hooks.begin("align", 0);
  c.alignment = align_scans(c.plan.scans, o, initial);
  c.hooks.end("align");
  const ScanAlignmentResult& r = c.alignment;
  summary.frames = summary.usable = r.placed.size();
  for (std::size_t i = 0; i < r.placed.size(); ++i) {
    if (r.placed[i]) continue;
    summary.flagged.push_back(static_cast<std::int64_t>(i));
    c.hooks.note(fmt::format("scan {} ({}) could not be registered: left out of the model", i, scan_name(c, i)));
  }
  summary.registered = summary.verified = summary.frames - summary.flagged.size();
  const double share = static_cast<double>(summary.verified) / static_cast<double>(summary.frames);
  const double min_share = AlignmentOptions{}.min_verified_share;
  summary.enough_verified = share >= min_share;
  if (summary.registered < 2)
    throw InputError(fmt::format("{}: fewer than two scans could be registered; nothing to reconstruct",
                                 c.plan.set.input.string()));
  const std::string world_frame = describe_world_frame(c);
  write_alignment_files(folder, c, world_frame);
  std::size_t loops = 0, kept = 0;
  for (const ScanPair& p : r.pairs) {
    loops += p.kept && !p.in_tree;
    kept += p.kept;
  }
  c.case_json["world_frame"] = world_frame;
  c.case_json["level"] = {{"levelled", false}};
  c.case_json["alignment"] = {
      {"kind", "range_scans"}, {"frames", summary.frames}, {"registered", summary.registered},
      {"pieces", 1}, {"loop_closures", loops}, {"pairs_kept", kept},
      {"pose_graph", {{"initial_cost", r.pose_graph.initial_cost}, {"final_cost", r.pose_graph.final_cost}}},
      {"unregistered_frames", summary.flagged}, {"verified", summary.verified}, {"usable", summary.usable},
      {"verified_share", share}, {"min_verified_share", min_share}, {"flagged_frames", summary.flagged},
      {"view_confidence", scan_rows(c)}, {"seconds", r.seconds}};
  write_json(folder.path("case.json"), c.case_json);
  LogStep s;
  s.step = "align";
  s.parameters_json = json{{"method", "multiway: pairwise point-to-plane ICP, pose graph, "
                                      "multi-view refinement"},
                           {"scan_poses", to_string(c.P.scan_poses)}, {"voxel_m", o.voxel_size},
                           {"feature_voxel_m", o.feature_voxel_size}, {"icp_gates_m", o.icp_gates},
                           {"min_fitness", o.min_fitness}, {"max_inlier_rmse_m", o.max_inlier_rmse},
                           {"seed", o.seed}, {"world_frame", world_frame}}.dump();
  s.duration_s = seconds_since(t0);
  s.outputs = {"alignment/trajectory.txt", "alignment/pose_graph.json",
               "alignment/pose_covariance.json", "alignment/stage_report.json", "case.json"};
  folder.append_log_step(s);
  summary.stage_seconds.emplace_back("align", seconds_since(t0));
}

double surface_voxel(const ScanCase& c) { return c.P.scan_voxel_m > 0.0 ? c.P.scan_voxel_m : 2.0 * c.spacing; }

// Scans without colour: grey from the intensity (0..1) when they have it, so the mesh (which
// takes its nearest point's colour) shows it; else none, and colour_mesh paints a light grey.
void colour_from_intensity(PointCloud& cloud) {
  const ScalarField* intensity = cloud.find_scalar("intensity");
  if (cloud.has_colors() || !intensity) return;
  cloud.colors.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto v = static_cast<std::uint8_t>(std::lround(255.0f * std::clamp(intensity->values[i], 0.0f, 1.0f)));
    cloud.colors[i] = Rgb8{v, v, v};
  }
}

// The registered scans thinned to the surface voxel, normals towards each scan's sensor (the
// side the scanner saw is outside), in the world frame, merged and thinned again.
PointCloud oriented_surface_points(const ScanCase& c) {
  const double voxel = surface_voxel(c);
  const std::size_t n = c.plan.scans.size();
  std::vector<PointCloud> parts(n);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    if (!c.alignment.placed[i]) return;
    PointCloud cloud = voxel_down_sample(c.plan.scans[i], static_cast<float>(voxel)).cloud;
    NormalOptions no;
    no.radius = static_cast<float>(3.0 * voxel);
    no.max_neighbors = 30;
    no.viewpoint = sensor_position(c.plan.set.viewpoint, cloud);
    estimate_normals(cloud, no);
    parts[i] = transformed(cloud, c.alignment.T_world_scan[i]);
  });
  PointCloud merged;
  for (const PointCloud& p : parts)
    if (!p.empty()) merged.append(p);  // an unplaced scan's empty part has no normals
  PointCloud out = voxel_down_sample(merged, static_cast<float>(voxel)).cloud;
  for (Eigen::Vector3f& nrm : out.normals)
    if (nrm.norm() > 0.0f) nrm.normalize();
  colour_from_intensity(out);
  return out;
}

void colour_mesh(TriangleMesh& mesh) {
  if (mesh.vertex_colors.size() != mesh.vertices.size())
    mesh.vertex_colors.assign(mesh.vertices.size(), Rgb8{190, 190, 190});
}

// ---- mesh: Poisson over the oriented points, trimmed where no point supports it
void mesh(CaseFolder& folder, ScanCase& c, ReconstructSummary& summary) {
  const auto t0 = Clock::now();
  c.hooks.begin("mesh", 0);
  c.surface_cloud = oriented_surface_points(c);
  PoissonOptions po;
  po.trim_distance = 2.0 * surface_voxel(c);
  // Triangles of about two spacings (CGAL's default, 30, gives a tenth of the scans' detail).
  po.sm_radius = 2.0;
  po.sm_distance = 0.25;
  TriangleMesh m = poisson_mesh(c.surface_cloud, po);
  c.hooks.end("mesh");
  const std::size_t raw_triangles = m.triangle_count();
  const ComponentReport components = remove_small_components(m, c.P.min_component);
  colour_mesh(m);
  std::vector<fs::path> outputs = write_mesh_files(folder, m, c.P.formats, c.P.up);
  write_ply(folder.path("cloud/registered.ply"), c.surface_cloud);
  write_json(folder.path("mesh/mesh.json"),
             {{"method", "poisson"}, {"voxel_size", surface_voxel(c)}, {"trim_distance", po.trim_distance},
              {"frames_fused", summary.registered}, {"raw_triangles", raw_triangles},
              {"removed_components", components.removed_components},
              {"removed_triangles", components.removed_triangles}, {"inferred_triangles", 0},
              {"vertices", m.vertex_count()}, {"triangles", m.triangle_count()},
              {"cloud_points", c.surface_cloud.size()}, {"cloud_voxel", surface_voxel(c)}});
  summary.vertices = m.vertex_count();
  summary.triangles = m.triangle_count();
  LogStep s;
  s.step = "mesh";
  s.parameters_json = json{{"method", "poisson"}, {"voxel_m", surface_voxel(c)},
                           {"trim_distance_m", po.trim_distance}, {"min_component", c.P.min_component},
                           {"formats", mesh_formats_text(c.P.formats)}}.dump();
  s.duration_s = seconds_since(t0);
  s.inputs = {"alignment/trajectory.txt"};
  s.outputs = outputs;
  s.outputs.push_back("mesh/mesh.json");
  s.outputs.push_back("cloud/registered.ply");
  folder.append_log_step(s);
  summary.stage_seconds.emplace_back("mesh", seconds_since(t0));
}

// The placed scans, every point in the scan's own frame, at their registered poses.
std::vector<E57View> scan_e57_views(const ScanCase& c) {
  std::vector<E57View> views;
  for (std::size_t i = 0; i < c.plan.scans.size(); ++i)
    if (c.alignment.placed[i]) views.push_back({scan_name(c, i), c.plan.scans[i], c.alignment.T_world_scan[i]});
  return views;
}

}  // namespace

ReconstructSummary reconstruct_scan_case(const RangeScanSet& set, const fs::path& case_dir,
                                         const ReconstructParameters& P, bool force,
                                         const StageCallbacks& cb) {
  const ScanPlan plan = plan_scans(set, P);
  return run_bracketed(plan.input_root, case_dir, force, [&](CaseFolder& folder, ReconstructSummary& summary) {
    ScanCase c{plan, P, StageHooks{cb}, {}, median_point_spacing(plan.scans), {}, {}};
    if (!(c.spacing > 0.0)) throw InputError("range scans: every point of every scan is at the same place");
    const auto t0 = Clock::now();
    ingest(folder, c);
    summary.stage_seconds.emplace_back("ingest", seconds_since(t0));
    align(folder, c, summary);
    mesh(folder, c, summary);
    write_views_e57(folder, scan_e57_views(c), {"alignment/trajectory.txt"},
                    json{{"views", "registered scans"}, {"points", "every point, in the scan's frame"}}.dump(),
                    summary);
    run_measure_stage(folder, plan.reference, plan.refs, P, c.hooks, summary);
    run_report_stage(folder, c.case_json["title"].get<std::string>(), P, c.hooks, summary);
  });
}

}  // namespace locard::forensics::detail
