// End to end: `locard reconstruct` against Open3D's reconstruction system, through the peer
// harness (bench/harness), on the same frames with the same warm-up, repeats and threads.
//
// Data: the 7-Scenes subset in ../shared/data/7scenes-tsdf-fusion/data (374 frames of a
// 640x480 Kinect v1: frames 0..59, then every 3rd to 999; depth in mm, colour not registered
// to depth; reference poses frame-*.pose.txt). LOCARD_RECONSTRUCT_BENCH_FRAMES=N takes the
// first N frames on both sides (Locard: max_frames = N, as `--frames N`; Open3D: the first N
// lines of the frame list) for a quick look.
//
//  locard  in process, locard::forensics::reconstruct_case as `locard reconstruct DATA -o CASE
//          --no-pdf` runs it: the parameters the data's traits give
//          (ReconstructParameters::defaults_for: odometry mode, point-to-plane last ICP level,
//          0.3..3 m), no PDF; a fresh case folder per pass. Timed: the whole command (sequence
//          index, ingest hashes, align, mesh with its PLY/GLB/OBJ/FBX files, E57 export, floor
//          coverage, HTML report; 7-Scenes has no reference measurements), images read inside
//          the pass.
//  open3d  bench/peers/open3d_reconstruction_system.py: Open3D's reconstruction system
//          (make_fragments, register_fragments, refine_registration, integrate_scene) rebuilt
//          with Open3D 0.16's API and its documented default configuration, which the workload
//          passes (parameters.config); fragments and refinement pairs in worker processes as
//          the original's python_multi_threading. Timed: the four stages, images read inside
//          the pass. Keyframe loop closures need OpenCV (python3-opencv), as in the original.
//
// One evaluator scores both outputs, after the table:
//  - ATE RMSE (translation, TUM's rigid alignment) of each trajectory against the reference
//    poses, paired by frame index; frames posed / frames given;
//  - each mesh's size, and its accuracy against one oracle: the same frames fused by Locard's
//    TSDF at the reference poses (1 cm voxels, 4 cm truncation, depth 0..3 m). Each side's mesh
//    is moved into the reference frame by the rigid motion that best maps its own cameras
//    (centres and points 1 m along their axes) onto the reference cameras, then: distance
//    of its vertices to the oracle's surface (median, 90th percentile; "accuracy") and share of
//    the oracle's vertices within 2 cm of its surface ("completeness"). Distances are to the
//    closest triangle around the nearest vertex of the other mesh.
// CPU times include the Open3D peer's worker processes (peer_protocol.py counts finished
// children); its quality line also shows the workers' share. The load average is printed: on a shared machine it explains the noise.
//
//   build/release/bench/reconstruct_bench --repeats=1 --warmup=0
//   LOCARD_RECONSTRUCT_BENCH_FRAMES=60 build/release/bench/reconstruct_bench
#include "bench_data.hpp"
#include "peer_harness.hpp"

#include <locard/alignment/trajectory_eval.hpp>
#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/forensics/reconstruct.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/trajectory_io.hpp>
#include <locard/surface/tsdf_volume.hpp>

#include <Eigen/Geometry>
#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <optional>

namespace {

namespace bench = locard::bench;
namespace fx = locard::forensics;
namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kOracleVoxel = 0.01;
constexpr double kOracleTruncation = 0.04;
constexpr double kOracleMaxDepth = 3.0;
constexpr double kCompleteWithin = 0.02;

const locard::RgbdSequence& sequence() {
  static const locard::RgbdSequence seq = locard::open_rgbd_sequence(bench::kSevenScenes);
  return seq;
}

// Frames both sides take: the first LOCARD_RECONSTRUCT_BENCH_FRAMES (all when unset).
std::size_t frames_used() {
  const std::size_t all = sequence().frames.size();
  const char* s = std::getenv("LOCARD_RECONSTRUCT_BENCH_FRAMES");
  const long n = s ? std::atol(s) : 0;
  return n > 0 ? std::min(all, static_cast<std::size_t>(n)) : all;
}

// initialize_config.py's defaults, the configuration the Open3D side runs with.
json open3d_default_config() {
  return {{"n_frames_per_fragment", 100},
          {"n_keyframes_per_n_frame", 5},
          {"min_depth", 0.3},
          {"max_depth", 3.0},
          {"voxel_size", 0.05},
          {"max_depth_diff", 0.07},
          {"depth_scale", 1000.0},
          {"preference_loop_closure_odometry", 0.1},
          {"preference_loop_closure_registration", 5.0},
          {"tsdf_cubic_size", 3.0},
          {"icp_method", "color"},
          {"global_registration", "ransac"},
          {"python_multi_threading", true}};
}

bench::Workload prepare() {
  const locard::RgbdSequence& seq = sequence();
  const fs::path folder = bench::work_folder("reconstruct");
  bench::Workload w;
  w.kernel = "reconstruction_system";
  const std::size_t n = frames_used();
  {
    std::ofstream f(folder / "frames.txt");
    for (std::size_t i = 0; i < n; ++i)
      f << seq.frames[i].frame_index << ' ' << seq.frames[i].color_path.string() << ' '
        << seq.frames[i].depth_path.string() << '\n';
    // Open3D's PinholeCameraIntrinsic JSON (column-major K): the intrinsics Locard read.
    const locard::CameraIntrinsics& K = seq.intrinsics;
    std::ofstream(folder / "intrinsics.json")
        << json{{"width", K.width},
                {"height", K.height},
                {"intrinsic_matrix", {K.fx, 0.0, 0.0, 0.0, K.fy, 0.0, K.cx, K.cy, 1.0}}}
               .dump()
        << '\n';
  }
  fs::create_directories(folder / "open3d");
  w.inputs = {{"sequence", bench::kSevenScenes.string()},
              {"frames", (folder / "frames.txt").string()},
              {"intrinsics", (folder / "intrinsics.json").string()},
              {"output_folder", (folder / "open3d").string()}};
  w.parameters = {{"frames", n},
                  {"seed", 0},
                  {"locard", "ReconstructParameters::defaults_for(traits), pdf off"},
                  {"config", open3d_default_config()}};
  return w;
}

// One `locard reconstruct DATA -o CASE --no-pdf` (plus --frames N for a subset).
json run_locard(const bench::Workload& w) {
  static int pass = 0;
  const fs::path input = w.inputs["sequence"].get<std::string>();
  const fs::path case_dir = bench::work_folder("reconstruct") / fmt::format("locard-case-{}", ++pass);
  // As the CLI: defaults from what the data is.
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(input);
  fx::ReconstructParameters p = fx::ReconstructParameters::defaults_for(seq.traits);
  p.pdf = false;
  const std::size_t n = w.parameters["frames"].get<std::size_t>();
  if (n < seq.frames.size()) p.alignment.max_frames = n;
  const fx::ReconstructSummary s = fx::reconstruct_case(input, case_dir, p, false);

  // The trajectory the case holds (TUM, T_world_camera), back to frame indices by timestamp.
  std::map<double, std::int64_t> index_of;
  for (const auto& f : seq.frames) index_of.emplace(f.timestamp, f.frame_index);
  locard::Trajectory trajectory;
  for (locard::StampedPose pose :
       locard::read_tum_trajectory(case_dir / "alignment" / "trajectory.txt")) {
    auto it = index_of.lower_bound(pose.timestamp - 1e-4);
    if (it == index_of.end() || std::abs(it->first - pose.timestamp) > 1e-4) continue;
    pose.frame_index = it->second;
    trajectory.push_back(pose);
  }
  json stages = json::array();  // in the order the stages ran
  for (const auto& [name, seconds] : s.stage_seconds) stages.push_back({name, seconds});
  return {{"trajectory", bench::trajectory_rows(trajectory)},
          {"frames", s.frames},
          {"registered", s.registered},
          {"usable", s.usable},
          {"verified", s.verified},
          {"mesh", (case_dir / "mesh" / "mesh.ply").string()},
          {"vertices", s.vertices},
          {"triangles", s.triangles},
          {"stage_seconds", stages}};
}

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3f closest_on_triangle(const Eigen::Vector3f& p, const Eigen::Vector3f& a,
                                    const Eigen::Vector3f& b, const Eigen::Vector3f& c) {
  const Eigen::Vector3f ab = b - a, ac = c - a, ap = p - a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3f bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3f cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const float denom = 1.f / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// Distance to a mesh's surface: the closest triangle around the nearest vertex.
class SurfaceDistance {
 public:
  explicit SurfaceDistance(const locard::TriangleMesh& mesh)
      : mesh_(mesh), tree_(mesh.vertices), offsets_(mesh.vertices.size() + 1, 0) {
    for (const auto& t : mesh.triangles)
      for (std::uint32_t v : t) ++offsets_[v + 1];
    for (std::size_t i = 1; i < offsets_.size(); ++i) offsets_[i] += offsets_[i - 1];
    ring_.resize(offsets_.back());
    std::vector<std::size_t> fill(offsets_.begin(), offsets_.end() - 1);
    for (std::size_t k = 0; k < mesh.triangles.size(); ++k)
      for (std::uint32_t v : mesh.triangles[k]) ring_[fill[v]++] = static_cast<std::uint32_t>(k);
  }

  float operator()(const Eigen::Vector3f& p) const {
    locard::Neighbor n;
    if (!tree_.nearest(p, n)) return std::numeric_limits<float>::infinity();
    float best = std::sqrt(n.squared_distance);
    for (std::size_t k = offsets_[n.index]; k < offsets_[n.index + 1]; ++k) {
      const auto& t = mesh_.triangles[ring_[k]];
      const Eigen::Vector3f q = closest_on_triangle(p, mesh_.vertices[t[0]],
                                                    mesh_.vertices[t[1]], mesh_.vertices[t[2]]);
      best = std::min(best, (p - q).norm());
    }
    return best;
  }

  // Every point's distance, in parallel.
  std::vector<float> all(const std::vector<Eigen::Vector3f>& points) const {
    std::vector<float> d(points.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i < r.end(); ++i) d[i] = (*this)(points[i]);
                      });
    return d;
  }

 private:
  const locard::TriangleMesh& mesh_;
  locard::KdTree tree_;
  std::vector<std::size_t> offsets_;
  std::vector<std::uint32_t> ring_;
};

// The rigid motion that best maps a trajectory's cameras onto the reference cameras of the
// same frames: each camera's centre and the points 1 m along its three axes (Umeyama, no
// scale). Unlike the ATE's alignment of centres alone, it is well posed for a short, nearly
// straight camera path.
std::optional<Eigen::Isometry3f> camera_alignment(const locard::Trajectory& reference,
                                                  const locard::Trajectory& estimate) {
  std::map<std::int64_t, const locard::Isometry3d*> by_index;
  for (const auto& p : reference) by_index.emplace(p.frame_index, &p.T_world_camera);
  std::vector<Eigen::Vector3d> from, to;
  for (const auto& p : estimate) {
    const auto it = by_index.find(p.frame_index);
    if (it == by_index.end()) continue;
    for (const Eigen::Vector3d& a : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                                    Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0, 1)}) {
      from.push_back(p.T_world_camera * a);
      to.push_back(*it->second * a);
    }
  }
  if (from.size() < 8) return std::nullopt;
  Eigen::Matrix3Xd src(3, from.size()), dst(3, to.size());
  for (std::size_t i = 0; i < from.size(); ++i) {
    src.col(static_cast<Eigen::Index>(i)) = from[i];
    dst.col(static_cast<Eigen::Index>(i)) = to[i];
  }
  Eigen::Isometry3d S;
  S.matrix() = Eigen::umeyama(src, dst, false);
  return S.cast<float>();
}

double quantile(std::vector<float> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// The oracle: the frames both sides took, fused at their reference poses.
locard::TriangleMesh oracle_mesh(std::size_t frames) {
  locard::TsdfVolume volume({.voxel_size = kOracleVoxel,
                             .truncation = kOracleTruncation,
                             .max_depth_m = kOracleMaxDepth});
  const locard::RgbdSequence& seq = sequence();
  for (std::size_t i = 0; i < frames; ++i)
    if (seq.frames[i].T_world_camera) volume.integrate(seq.load_frame(i), *seq.frames[i].T_world_camera);
  return volume.extract_mesh();
}

void report(const bench::Comparison& c) {
  const std::size_t total = frames_used();
  const locard::Trajectory& reference = sequence().ground_truth;
  struct Scored {
    std::string side;
    const bench::SideRun* run = nullptr;
    std::optional<locard::AteResult> ate;
    std::size_t posed = 0;
  };
  std::vector<Scored> scored;
  for (const auto& side : c.sides()) {
    const bench::SideRun* run = c.run_of(side->name());
    if (!run) continue;
    Scored s{side->name(), run, std::nullopt, 0};
    const locard::Trajectory t = bench::trajectory_from_rows(run->output.value("trajectory", json::array()));
    s.posed = t.size();
    try {
      locard::AssociationOptions a;
      a.match_by_frame_index = true;
      s.ate = locard::absolute_trajectory_error(reference, t, a);
    } catch (const locard::Error& e) {
      fmt::print("  {:<8} ATE not computed: {}\n", s.side, e.what());
    }
    scored.push_back(std::move(s));
  }

  fmt::print("  {:<8} {:>9} {:>10} {:>10} {:>10} {:>10} {:>11} {:>9}\n", "side", "posed",
             "ATE rmse", "median", "max", "vertices", "triangles", "CPU s");
  for (const Scored& s : scored) {
    const json& o = s.run->output;
    const double cpu = s.run->timings.median_cpu();  // workers included (peer_protocol.py)
    fmt::print("  {:<8} {:>4}/{:<4} {:>7.1f} mm {:>7.1f} mm {:>7.1f} mm {:>10} {:>11} {:>9.1f}\n",
               s.side, s.posed, total, s.ate ? 1e3 * s.ate->translation.rmse : NAN,
               s.ate ? 1e3 * s.ate->translation.median : NAN,
               s.ate ? 1e3 * s.ate->translation.max : NAN, o.value("vertices", 0),
               o.value("triangles", 0), cpu);
  }
  for (const Scored& s : scored) {
    std::string stages;
    const json stage_seconds = s.run->output.value("stage_seconds", json::object());
    const auto add = [&](const std::string& name, const json& seconds) {
      stages += fmt::format("{}{} {:.1f} s", stages.empty() ? "" : ", ", name, seconds.get<double>());
    };
    if (stage_seconds.is_array())  // [[name, seconds], ...]
      for (const json& stage : stage_seconds) add(stage[0].get<std::string>(), stage[1]);
    else  // {name: seconds} (Python keeps the insertion order; nlohmann sorts the keys)
      for (const auto& [name, seconds] : stage_seconds.items()) add(name, seconds);
    fmt::print("  {:<8} stages (last pass): {}\n", s.side, stages);
  }
  for (const Scored& s : scored) {
    const json& o = s.run->output;
    if (s.side == "locard")
      fmt::print("  locard   {} of {} frames registered, {} usable, {} verified (fused)\n",
                 o.value("registered", 0), total, o.value("usable", 0), o.value("verified", 0));
    else if (o.contains("fragments"))
      fmt::print("  {:<8} {} fragments; keyframe loop closures: {} ({} of {} pairs); failed "
                 "odometry {}; scene edges {} found of {} pairs, {} kept; {} worker processes, "
                 "{:.1f} s worker CPU\n",
                 s.side, o.value("fragments", 0), o.value("keyframe_loop_closures", ""),
                 o.value("loop_edges", 0), o.value("keyframe_pairs", 0),
                 o.value("failed_odometry", 0), o.value("scene_edges_found", 0),
                 o.value("scene_pairs", 0), o.value("scene_edges_kept", 0),
                 o.value("workers", 0), o.value("worker_cpu_s", 0.0));
  }

  // Mesh accuracy against the oracle.
  const locard::TriangleMesh oracle = oracle_mesh(total);
  const SurfaceDistance to_oracle(oracle);
  fmt::print("  oracle: the {} frames fused by Locard's TSDF at the reference poses ({} m voxels, "
             "{} m truncation, depth to {} m): {} vertices\n",
             total, kOracleVoxel, kOracleTruncation, kOracleMaxDepth, oracle.vertex_count());
  for (const Scored& s : scored) {
    const std::string path = s.run->output.value("mesh", std::string());
    const auto S = camera_alignment(reference, bench::trajectory_from_rows(s.run->output.value("trajectory", json::array())));
    if (!S || path.empty() || !fs::exists(path)) {
      fmt::print("  {:<8} mesh not scored ({})\n", s.side, path.empty() ? "no mesh" : path);
      continue;
    }
    locard::TriangleMesh mesh = locard::read_ply_mesh(path);
    for (Eigen::Vector3f& v : mesh.vertices) v = *S * v;
    const std::vector<float> accuracy = to_oracle.all(mesh.vertices);
    const std::vector<float> coverage = SurfaceDistance(mesh).all(oracle.vertices);
    const auto within = std::count_if(coverage.begin(), coverage.end(),
                                      [](float d) { return d <= kCompleteWithin; });
    fmt::print("  {:<8} mesh to oracle: median {:.1f} mm, 90% {:.1f} mm; oracle within {:.0f} mm "
               "of the mesh: {:.1f} %\n",
               s.side, 1e3 * quantile(accuracy, 0.5), 1e3 * quantile(accuracy, 0.9),
               1e3 * kCompleteWithin,
               oracle.vertices.empty() ? 0.0
                                       : 100.0 * static_cast<double>(within) /
                                             static_cast<double>(oracle.vertices.size()));
  }
  double load[3] = {0, 0, 0};
  if (::getloadavg(load, 3) == 3)
    fmt::print("  load average at the end: {:.2f} {:.2f} {:.2f} (1, 5, 15 min)\n", load[0],
               load[1], load[2]);
}

}  // namespace

int main(int argc, char** argv) {
  bench::add_comparison(
      "reconstruct_7scenes",
      fmt::format("RGB-D sequence to mesh end to end, 7-Scenes ({} frames): `locard reconstruct` "
                  "vs Open3D's reconstruction system",
                  frames_used()),
      {.warmup = 0, .repeats = 1}, prepare)
      .side(bench::in_process_side("locard", run_locard))
      .side(bench::open3d_side("open3d_reconstruction_system.py"))
      .report(report);
  return bench::run_main(argc, argv);
}
