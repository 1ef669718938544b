// Registration against Open3D and PCL through the peer harness (bench/harness): every side gets
// the same input files, the same parameters (hypothesis cap, confidence, seed list, distances,
// iteration limits), the same warm-up, repeats and thread count; each reads its inputs outside
// the clock, times the same pass, and returns the last pass's transforms, which the one
// evaluator below scores.
//
//  ransac_matching         the six neighbouring Stanford bunny scan pairs
//                          (bun000-045-090-180-270-315-000), each scan voxel-down-sampled to
//                          5 mm with normals (radius 1 cm, 30 neighbours). FPFH (radius 2.5 cm,
//                          100 neighbours) is given: computed once by Locard and written beside
//                          the clouds (Locard's FPFH is defined as Open3D's), read untimed by
//                          every side. One timed pass: for every pair and every seed of the
//                          seed list, mutual descriptor matching + RANSAC (inlier distance
//                          7.5 mm, edge-length 0.9, distance check, the same hypothesis cap and
//                          confidence on every side). Success: within 5 degrees and 1 cm of
//                          bun.conf, the basin from which ICP reaches the 2 degree / 5 mm bound
//                          of the tests.
//  ransac_correspondences  RANSAC alone, the same pairs, seeds and parameters, on identical
//                          correspondences (Locard's mutual FPFH matches, written to a file).
//  icp_7scenes             point-to-plane from the identity on the 59 consecutive 7-Scenes frame
//                          pairs (frames 0..59, 30 Hz), each frame back-projected and
//                          voxel-down-sampled to 1 cm, normals radius 3 cm / 30 neighbours, in
//                          the files. Correspondence distance 5 cm, at most 30 iterations, each
//                          library's own convergence test on the given thresholds. Timed: the
//                          registration calls (kd-tree builds included). Every final transform
//                          is scored by the same evaluator (fitness and inlier RMSE at 5 cm) and
//                          compared with the ground-truth relative pose.
//
// What each library cannot take from the workload (each side's header says how it reads it):
// Open3D's ICP has no step-size test (it stops on relative fitness and RMSE); PCL's ICP stops on
// the step or on the relative change of the MSE, and runs on one thread; PCL's RANSAC
// (RandomSampleConsensus over SampleConsensusModelRegistration) has no edge-length check, and
// its matching is its own reciprocal nearest neighbours in FPFH space, and it runs on one
// thread (PCL's default; its OpenMP loop is far slower on problems this small).
//
//   build/release/bench/registration_bench [--benchmark_filter=icp] [--repeats=N] [--warmup=N]
// PCL is measured when <build>/bench/pcl/locard_pcl_registration exists (configure with
// -DLOCARD_WITH_PCL=ON) or LOCARD_PCL_PEER_DIR names its folder.
#include "bench_data.hpp"
#include "peer_harness.hpp"

#include <locard/core/kdtree.hpp>
#include <locard/features/descriptor_matching.hpp>
#include <locard/features/fpfh.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/io/stanford_conf.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/registration/icp.hpp>
#include <locard/registration/ransac.hpp>

#include <Eigen/SVD>
#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <numeric>
#include <optional>
#include <string_view>

namespace {

namespace fs = std::filesystem;
namespace bench = locard::bench;
using locard::Isometry3d;
using locard::PointCloud;
using nlohmann::json;

constexpr double kBunnyVoxel = 0.005;
constexpr double kRansacDistance = 1.5 * kBunnyVoxel;
constexpr float kFpfhRadius = 5 * kBunnyVoxel;
constexpr int kFpfhMaxNeighbors = 100;
constexpr int kSeeds = 10;
constexpr std::size_t kRansacMaxHypotheses = 100000;
constexpr double kRansacConfidence = 0.999;
constexpr double kEdgeLengthRatio = 0.9;
constexpr double kSuccessDeg = 5.0;
constexpr double kSuccessM = 0.01;

constexpr double kFrameVoxel = 0.01;
constexpr std::size_t kFrames = 60;
constexpr double kIcpDistance = 0.05;
constexpr int kIcpMaxIterations = 30;

const fs::path& work() {
  static const fs::path folder = bench::work_folder("registration");
  return folder;
}

// The rotation closest to a nearly orthonormal matrix (7-Scenes poses are stored with ~1e-4
// of scale error, enough to read as ~1 degree of rotation between identical frames).
Isometry3d orthonormalised(Isometry3d T) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(T.linear(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  return T;
}

struct Scan {
  PointCloud cloud;
  std::vector<locard::Fpfh> features;  // bunny only
  fs::path file, features_file;
};

struct Pair {
  std::string name;
  const Scan* source = nullptr;
  const Scan* target = nullptr;
  Isometry3d T_target_source_truth;
  std::vector<locard::Correspondence> matches;  // bunny: Locard's mutual FPFH matches
  fs::path matches_file;
};

struct Data {
  std::map<std::string, Scan> scans;  // node-based: Pair points into it
  std::vector<Pair> pairs;
};

// --- data: written once, read by every side ----------------------------------------------------

void write_features(const fs::path& path, const std::vector<locard::Fpfh>& features) {
  std::ofstream out(path, std::ios::binary);
  for (const locard::Fpfh& f : features)
    out.write(reinterpret_cast<const char*>(f.data()),
              static_cast<std::streamsize>(sizeof(float) * f.size()));
}

Data make_bunny() {
  const fs::path dir = fs::path(LOCARD_SHARED_DATA) / "stanford-bunny" / "bunny" / "data";
  const locard::StanfordConf conf = locard::read_stanford_conf(dir / "bun.conf");
  Data data;
  std::map<std::string, Isometry3d> poses;
  const std::vector<std::pair<std::string, std::string>> ring = {
      {"bun045", "bun000"}, {"bun090", "bun045"}, {"bun180", "bun090"},
      {"bun270", "bun180"}, {"bun315", "bun270"}, {"bun000", "bun315"}};
  for (const auto& s : conf.scans) {
    const std::string name = s.file.stem().string();
    if (std::none_of(ring.begin(), ring.end(), [&](const auto& p) { return p.first == name; }))
      continue;  // chin, ear_back, top2, top3
    Scan& scan = data.scans[name];
    scan.cloud = locard::voxel_down_sample(locard::read_point_cloud(s.file),
                                           static_cast<float>(kBunnyVoxel)).cloud;
    locard::NormalOptions n;
    n.radius = static_cast<float>(2 * kBunnyVoxel);
    n.max_neighbors = 30;
    locard::estimate_normals(scan.cloud, n);
    locard::FpfhOptions f;
    f.radius = kFpfhRadius;
    f.max_neighbors = kFpfhMaxNeighbors;
    scan.features = locard::compute_fpfh(scan.cloud, f);
    scan.file = work() / (name + ".ply");
    scan.features_file = work() / (name + ".fpfh.f32");
    locard::write_ply(scan.file, scan.cloud);
    write_features(scan.features_file, scan.features);
    poses[name] = s.T_world_scan;
  }
  for (const auto& [s, t] : ring) {
    Pair p;
    p.name = s + "->" + t;
    p.source = &data.scans.at(s);
    p.target = &data.scans.at(t);
    p.T_target_source_truth = poses.at(t).inverse() * poses.at(s);
    p.matches = locard::match_descriptors(p.source->features, p.target->features);
    p.matches_file = work() / (s + "-" + t + ".matches.txt");
    std::ofstream m(p.matches_file);
    for (const auto& c : p.matches) m << c.source << ' ' << c.target << '\n';
    data.pairs.push_back(std::move(p));
  }
  return data;
}

Data make_frames() {
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(bench::kSevenScenes);
  Data data;
  std::vector<Isometry3d> poses;
  for (std::size_t i = 0; i < kFrames; ++i) {
    const locard::RgbdFrame frame = seq.load_frame(i);
    locard::DepthToPointsOptions d;
    d.with_color = false;
    Scan& scan = data.scans[fmt::format("frame-{:06d}", i)];
    scan.cloud = locard::voxel_down_sample(locard::depth_to_points(frame, d),
                                           static_cast<float>(kFrameVoxel)).cloud;
    locard::NormalOptions n;
    n.radius = static_cast<float>(3 * kFrameVoxel);
    n.max_neighbors = 30;
    locard::estimate_normals(scan.cloud, n);
    scan.file = work() / fmt::format("frame-{:06d}.ply", i);
    locard::write_ply(scan.file, scan.cloud);
    poses.push_back(orthonormalised(*seq.frames[i].T_world_camera));
  }
  for (std::size_t i = 0; i + 1 < kFrames; ++i) {
    Pair p;
    p.name = fmt::format("{}->{}", i + 1, i);
    p.source = &data.scans.at(fmt::format("frame-{:06d}", i + 1));
    p.target = &data.scans.at(fmt::format("frame-{:06d}", i));
    p.T_target_source_truth = poses[i].inverse() * poses[i + 1];
    data.pairs.push_back(std::move(p));
  }
  return data;
}

const Data& bunny() {
  static const Data data = make_bunny();
  return data;
}
const Data& frames() {
  static const Data data = make_frames();
  return data;
}

// --- the one evaluator ---------------------------------------------------------------------------

// A side's transforms, or nothing when its output does not hold one per expected run.
std::optional<std::vector<Isometry3d>> transforms_of(const bench::SideRun& run,
                                                     std::size_t expected) {
  const json& t = run.output.contains("transforms") ? run.output["transforms"] : json();
  if (!t.is_array() || t.size() != expected) {
    fmt::print("  {:<8} output has {} transforms, {} expected: not scored\n", run.side,
               t.is_array() ? t.size() : 0, expected);
    return std::nullopt;
  }
  std::vector<Isometry3d> out;
  for (const json& T : t) out.push_back(bench::from_row_major(T));
  return out;
}

// Mean of an optional per-run count the side reports ("hypotheses", "iterations").
std::string mean_of(const bench::SideRun& run, const char* key, const char* unit) {
  if (!run.output.contains(key) || !run.output[key].is_array() || run.output[key].empty())
    return std::string(8 + std::string_view(unit).size(), ' ');
  const auto values = run.output[key].get<std::vector<double>>();
  const double mean = std::accumulate(values.begin(), values.end(), 0.0) / values.size();
  return fmt::format("{:>7.0f} {}", mean, unit);
}

struct Score {
  double fitness = 0.0;
  double rmse = 0.0;
};

// Open3D's RegistrationResult definition: source points whose nearest target point lies
// within max_distance; fitness = their fraction, RMSE over them.
Score evaluate(const Pair& p, const Isometry3d& T, double max_distance) {
  const locard::KdTree tree(p.target->cloud.positions);
  std::size_t n = 0;
  double sse = 0.0;
  locard::Neighbor nb;
  for (const auto& s : p.source->cloud.positions) {
    const Eigen::Vector3d q = T * s.cast<double>();
    if (!tree.nearest(q.cast<float>(), nb, static_cast<float>(max_distance))) continue;
    ++n;
    sse += (q - tree.points()[nb.index].cast<double>()).squaredNorm();
  }
  return {static_cast<double>(n) / p.source->cloud.size(), n ? std::sqrt(sse / n) : 0.0};
}

bool ransac_success(const Pair& p, const Isometry3d& T) {
  return locard::rotation_difference_deg(p.T_target_source_truth, T) <= kSuccessDeg &&
         locard::translation_difference_m(p.T_target_source_truth, T) <= kSuccessM;
}

// --- RANSAC --------------------------------------------------------------------------------------

json ransac_parameters() {
  std::vector<int> seeds(kSeeds);
  std::iota(seeds.begin(), seeds.end(), 0);
  return {{"max_correspondence_distance", kRansacDistance},
          {"edge_length_ratio", kEdgeLengthRatio},
          {"ransac_n", 3},
          {"max_iterations", kRansacMaxHypotheses},
          {"confidence", kRansacConfidence},
          {"seeds", seeds}};
}

locard::RansacOptions ransac_options(const json& p) {
  locard::RansacOptions o;
  o.max_correspondence_distance = p.at("max_correspondence_distance").get<double>();
  o.edge_length_ratio = p.at("edge_length_ratio").get<double>();
  o.max_iterations = p.at("max_iterations").get<std::size_t>();
  o.confidence = p.at("confidence").get<double>();
  return o;
}

// One pass over every pair and seed; `matches(pair)` gives the RANSAC input.
template <typename Matches>
json locard_ransac_pass(const bench::Workload& w, Matches&& matches) {
  locard::RansacOptions o = ransac_options(w.parameters);
  json transforms = json::array(), hypotheses = json::array(), correspondences = json::array();
  for (const Pair& p : bunny().pairs) {
    for (const json& seed : w.parameters.at("seeds")) {
      o.seed = seed.get<std::uint64_t>();
      const auto& putative = matches(p);
      const locard::RansacResult r =
          locard::ransac_registration(p.source->cloud, p.target->cloud, putative, o);
      transforms.push_back(bench::row_major(r.T_target_source));
      hypotheses.push_back(r.hypotheses);
      correspondences.push_back(putative.size());
    }
  }
  return {{"transforms", transforms}, {"hypotheses", hypotheses},
          {"correspondences", correspondences}};
}

void report_ransac(const bench::Comparison& c) {
  const auto& pairs = bunny().pairs;
  const std::size_t seeds = kSeeds;
  std::size_t fewest = SIZE_MAX, most = 0;
  for (const auto& [name, scan] : bunny().scans) {
    fewest = std::min(fewest, scan.cloud.size());
    most = std::max(most, scan.cloud.size());
  }
  fmt::print("  {}..{} points per scan; success = within {} deg and {} cm of bun.conf; {} pairs "
             "x {} seeds per pass, the last pass scored\n",
             fewest, most, kSuccessDeg, kSuccessM * 100, pairs.size(), seeds);
  for (const auto& side : c.sides()) {
    const bench::SideRun* run = c.run_of(side->name());
    if (!run) continue;
    const auto transforms = transforms_of(*run, pairs.size() * seeds);
    if (!transforms) continue;
    std::size_t ok = 0;
    std::string per_pair;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      std::size_t pair_ok = 0;
      for (std::size_t s = 0; s < seeds; ++s)
        pair_ok += ransac_success(pairs[i], (*transforms)[i * seeds + s]);
      ok += pair_ok;
      per_pair += fmt::format(" {}", pair_ok);
    }
    fmt::print("  {:<8} success {:>2}/{}  {}  {}  successes per pair:{}\n", run->side, ok,
               transforms->size(), mean_of(*run, "correspondences", "matches/run"),
               mean_of(*run, "hypotheses", "hypotheses/run"), per_pair);
  }
}

void add_ransac_comparisons() {
  bench::add_comparison(
      "ransac_matching",
      fmt::format("matching (mutual FPFH nearest neighbours, FPFH given) + RANSAC, bunny ring "
                  "pairs, 5 mm voxels; {} seeds per pair, at most {} hypotheses, confidence {}",
                  kSeeds, kRansacMaxHypotheses, kRansacConfidence),
      {.warmup = 1, .repeats = 3},
      [] {
        bench::Workload w;
        w.kernel = "ransac_feature_matching";
        w.inputs = {{"pairs", json::array()}};
        for (const Pair& p : bunny().pairs)
          w.inputs["pairs"].push_back({{"name", p.name},
                                       {"source", p.source->file.string()},
                                       {"target", p.target->file.string()},
                                       {"source_features", p.source->features_file.string()},
                                       {"target_features", p.target->features_file.string()}});
        w.parameters = ransac_parameters();
        w.parameters["mutual"] = true;
        return w;
      })
      .side(bench::in_process_side("locard",
                                   [](const bench::Workload& w) {
                                     locard::MatchOptions m;
                                     m.mutual = w.parameters.at("mutual").get<bool>();
                                     return locard_ransac_pass(w, [&m](const Pair& p) {
                                       return locard::match_descriptors(
                                           p.source->features, p.target->features, m);
                                     });
                                   }))
      .side(bench::open3d_side("open3d_registration.py"))
      .side(bench::pcl_side("locard_pcl_registration"))
      .report(report_ransac);

  bench::add_comparison(
      "ransac_correspondences",
      fmt::format("RANSAC alone on identical correspondences (Locard's mutual FPFH matches), "
                  "bunny ring pairs; {} seeds per pair, at most {} hypotheses, confidence {}",
                  kSeeds, kRansacMaxHypotheses, kRansacConfidence),
      {.warmup = 1, .repeats = 3},
      [] {
        bench::Workload w;
        w.kernel = "ransac_correspondences";
        w.inputs = {{"pairs", json::array()}};
        for (const Pair& p : bunny().pairs)
          w.inputs["pairs"].push_back({{"name", p.name},
                                       {"source", p.source->file.string()},
                                       {"target", p.target->file.string()},
                                       {"correspondences", p.matches_file.string()}});
        w.parameters = ransac_parameters();
        return w;
      })
      .side(bench::in_process_side("locard",
                                   [](const bench::Workload& w) {
                                     return locard_ransac_pass(
                                         w, [](const Pair& p) -> const auto& { return p.matches; });
                                   }))
      .side(bench::open3d_side("open3d_registration.py"))
      .side(bench::pcl_side("locard_pcl_registration"))
      .report([](const bench::Comparison& c) {
        std::size_t fewest = SIZE_MAX, most = 0;
        for (const Pair& p : bunny().pairs) {
          fewest = std::min(fewest, p.matches.size());
          most = std::max(most, p.matches.size());
        }
        fmt::print("  {}..{} correspondences per pair\n", fewest, most);
        report_ransac(c);
      });
}

// --- ICP -----------------------------------------------------------------------------------------

void report_icp(const bench::Comparison& c) {
  const auto& pairs = frames().pairs;
  struct Summary {
    double mean_fitness = 0, mean_rmse = 0, max_deg = 0, max_m = 0;
    std::vector<double> rmse;
  };
  const auto summarise = [&](const std::vector<Isometry3d>& transforms) {
    Summary s;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const Score sc = evaluate(pairs[i], transforms[i], kIcpDistance);
      s.mean_fitness += sc.fitness / pairs.size();
      s.mean_rmse += sc.rmse / pairs.size();
      s.rmse.push_back(sc.rmse);
      s.max_deg = std::max(s.max_deg, locard::rotation_difference_deg(
                                          pairs[i].T_target_source_truth, transforms[i]));
      s.max_m = std::max(s.max_m, locard::translation_difference_m(
                                      pairs[i].T_target_source_truth, transforms[i]));
    }
    return s;
  };
  std::size_t points = 0;
  for (const auto& [name, scan] : frames().scans) points += scan.cloud.size();
  fmt::print("  ~{} points per frame; scored by one evaluator: fitness and inlier RMSE at {} m "
             "(means over {} pairs), largest error vs ground truth\n",
             points / frames().scans.size(), kIcpDistance, pairs.size());
  std::optional<Summary> reference;  // the first side's (Locard's)
  for (std::size_t k = 0; k < c.sides().size(); ++k) {
    const bench::SideRun* run = c.run_of(c.sides()[k]->name());
    if (!run) continue;
    const auto transforms = transforms_of(*run, pairs.size());
    if (!transforms) continue;
    const Summary s = summarise(*transforms);
    std::string versus;
    if (k == 0) {
      reference = s;
    } else if (reference) {
      std::size_t not_worse = 0;
      for (std::size_t i = 0; i < pairs.size(); ++i)
        not_worse += reference->rmse[i] <= s.rmse[i] + 1e-6;  // 1 um: float noise
      versus = fmt::format("  {} RMSE lower or equal on {}/{} pairs", c.sides().front()->name(),
                           not_worse, pairs.size());
    }
    fmt::print("  {:<8} {}  fitness {:.4f}  RMSE {:.3f} mm  max error {:.3f} deg {:.2f} mm{}\n",
               run->side, mean_of(*run, "iterations", "iterations/pair"), s.mean_fitness,
               1e3 * s.mean_rmse, s.max_deg, 1e3 * s.max_m, versus);
  }
}

void add_icp_comparison() {
  bench::add_comparison(
      "icp_7scenes",
      fmt::format("point-to-plane ICP from the identity, 7-Scenes consecutive frames 0..{}, "
                  "1 cm voxels, max distance {} m, at most {} iterations",
                  kFrames - 1, kIcpDistance, kIcpMaxIterations),
      {.warmup = 1, .repeats = 3},
      [] {
        bench::Workload w;
        w.kernel = "icp_point_to_plane";
        w.inputs = {{"pairs", json::array()}};
        for (const Pair& p : frames().pairs)
          w.inputs["pairs"].push_back({{"name", p.name},
                                       {"source", p.source->file.string()},
                                       {"target", p.target->file.string()}});
        const locard::IcpConvergence defaults;
        w.parameters = {{"max_correspondence_distance", kIcpDistance},
                        {"max_iterations", kIcpMaxIterations},
                        {"relative_fitness", defaults.relative_fitness},
                        {"relative_rmse", defaults.relative_rmse},
                        {"rotation_eps_deg", defaults.rotation_eps_deg},
                        {"translation_eps_m", defaults.translation_eps_m}};
        return w;
      })
      .side(bench::in_process_side(
          "locard",
          [](const bench::Workload& w) {
            const json& p = w.parameters;
            locard::IcpOptions o;
            o.method = locard::IcpMethod::PointToPlane;
            o.max_correspondence_distance = p.at("max_correspondence_distance").get<double>();
            o.convergence.max_iterations = p.at("max_iterations").get<int>();
            o.convergence.relative_fitness = p.at("relative_fitness").get<double>();
            o.convergence.relative_rmse = p.at("relative_rmse").get<double>();
            o.convergence.rotation_eps_deg = p.at("rotation_eps_deg").get<double>();
            o.convergence.translation_eps_m = p.at("translation_eps_m").get<double>();
            json transforms = json::array(), iterations = json::array();
            for (const Pair& pair : frames().pairs) {
              const locard::IcpResult r =
                  locard::icp(pair.source->cloud, pair.target->cloud, Isometry3d::Identity(), o);
              transforms.push_back(bench::row_major(r.T_target_source));
              iterations.push_back(r.iterations);
            }
            return json{{"transforms", transforms}, {"iterations", iterations}};
          }))
      .side(bench::open3d_side("open3d_registration.py"))
      .side(bench::pcl_side("locard_pcl_registration"))
      .report(report_icp);
}

}  // namespace

int main(int argc, char** argv) {
  add_ransac_comparisons();
  add_icp_comparison();
  return bench::run_main(argc, argv);
}
