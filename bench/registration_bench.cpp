// Registration against Open3D (and PCL when its peer is built), same clouds, same run:
//
//  RANSAC  the six neighbouring Stanford bunny scan pairs (bun000-045-090-180-270-315-000),
//          each scan voxel-down-sampled to 5 mm with normals (radius 1 cm, 30 neighbours,
//          towards the scanner). FPFH (radius 2.5 cm, 100 neighbours) is computed outside the
//          timing; timed: mutual descriptor matching + RANSAC (inlier distance 7.5 mm,
//          edge-length 0.9, distance check, 100000 hypotheses at most, confidence 0.999), for
//          kSeeds seeds per pair. Success: within 5 degrees and 1 cm of bun.conf, the basin
//          from which ICP reaches the 2 degree / 5 mm bound of the tests.
//  ICP     point-to-plane from the identity on the 59 consecutive 7-Scenes frame pairs
//          (frames 0..59, 30 Hz), each frame back-projected and voxel-down-sampled to 1 cm,
//          normals radius 3 cm / 30 neighbours. Correspondence distance 5 cm, at most 30
//          iterations, each library's own convergence test (Open3D: relative fitness and RMSE
//          1e-6). Timed: the registration call (kd-tree build included). Every final
//          transform, Locard's and the peers', is then scored by the same evaluator (fitness
//          and inlier RMSE at 5 cm), and compared with the ground-truth relative pose.
//
//   build/release/bench/registration_bench
#include "bench_peers.hpp"

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
#include <tbb/task_arena.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>

namespace {

namespace fs = std::filesystem;
using locard::Isometry3d;
using locard::PointCloud;

constexpr double kBunnyVoxel = 0.005;
constexpr double kRansacDistance = 1.5 * kBunnyVoxel;
constexpr float kFpfhRadius = 5 * kBunnyVoxel;
constexpr int kFpfhMaxNeighbors = 100;
constexpr int kSeeds = 10;
constexpr double kSuccessDeg = 5.0;
constexpr double kSuccessM = 0.01;

constexpr double kFrameVoxel = 0.01;
constexpr double kIcpDistance = 0.05;
constexpr int kIcpMaxIterations = 30;
constexpr int kPeerRepeats = 3;

const fs::path kWork = fs::temp_directory_path() / "locard-registration-bench";

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The rotation closest to a nearly orthonormal matrix (7-Scenes poses are stored with ~1e-4
// of scale error, enough to read as ~1 degree of rotation between identical frames).
Isometry3d orthonormalised(Isometry3d T) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(T.linear(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  return T;
}

struct Pair {
  std::string name;
  PointCloud source, target;
  Isometry3d T_target_source_truth;
  fs::path source_file, target_file;
  std::vector<locard::Fpfh> source_features, target_features;  // RANSAC only
  std::vector<locard::Correspondence> matches;                  // mutual FPFH matches
  fs::path matches_file;
};

// --- data -----------------------------------------------------------------------------------

std::vector<Pair> make_bunny_pairs() {
  const fs::path dir = fs::path(LOCARD_SHARED_DATA) / "stanford-bunny" / "bunny" / "data";
  const locard::StanfordConf conf = locard::read_stanford_conf(dir / "bun.conf");
  std::map<std::string, std::pair<PointCloud, Isometry3d>> scans;
  for (const auto& s : conf.scans) {
    PointCloud c = locard::voxel_down_sample(locard::read_point_cloud(s.file),
                                             static_cast<float>(kBunnyVoxel)).cloud;
    locard::NormalOptions n;
    n.radius = static_cast<float>(2 * kBunnyVoxel);
    n.max_neighbors = 30;
    locard::estimate_normals(c, n);
    scans[s.file.stem().string()] = {std::move(c), s.T_world_scan};
  }
  const std::vector<std::pair<std::string, std::string>> ring = {
      {"bun045", "bun000"}, {"bun090", "bun045"}, {"bun180", "bun090"},
      {"bun270", "bun180"}, {"bun315", "bun270"}, {"bun000", "bun315"}};
  std::vector<Pair> pairs;
  for (const auto& [s, t] : ring) {
    Pair p;
    p.name = s + "->" + t;
    p.source = scans.at(s).first;
    p.target = scans.at(t).first;
    p.T_target_source_truth = scans.at(t).second.inverse() * scans.at(s).second;
    p.source_file = kWork / (s + ".ply");
    p.target_file = kWork / (t + ".ply");
    locard::FpfhOptions f;
    f.radius = kFpfhRadius;
    f.max_neighbors = kFpfhMaxNeighbors;
    p.source_features = locard::compute_fpfh(p.source, f);
    p.target_features = locard::compute_fpfh(p.target, f);
    p.matches = locard::match_descriptors(p.source_features, p.target_features);
    p.matches_file = kWork / (s + "-" + t + ".matches.txt");
    std::ofstream m(p.matches_file);
    for (const auto& c : p.matches) m << c.source << ' ' << c.target << '\n';
    pairs.push_back(std::move(p));
  }
  for (const auto& [name, scan] : scans) locard::write_ply(kWork / (name + ".ply"), scan.first);
  return pairs;
}

std::vector<Pair> make_frame_pairs() {
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(locard::bench::kSevenScenes);
  std::vector<PointCloud> frames;
  std::vector<Isometry3d> poses;
  for (std::size_t i = 0; i < 60; ++i) {
    const locard::RgbdFrame frame = seq.load_frame(i);
    locard::DepthToPointsOptions d;
    d.with_color = false;
    PointCloud c = locard::voxel_down_sample(locard::depth_to_points(frame, d),
                                             static_cast<float>(kFrameVoxel)).cloud;
    locard::NormalOptions n;
    n.radius = static_cast<float>(3 * kFrameVoxel);
    n.max_neighbors = 30;
    locard::estimate_normals(c, n);
    locard::write_ply(kWork / fmt::format("frame-{:06d}.ply", i), c);
    frames.push_back(std::move(c));
    poses.push_back(orthonormalised(*seq.frames[i].T_world_camera));
  }
  std::vector<Pair> pairs;
  for (std::size_t i = 0; i + 1 < frames.size(); ++i) {
    Pair p;
    p.name = fmt::format("{}->{}", i + 1, i);
    p.source = frames[i + 1];
    p.target = frames[i];
    p.T_target_source_truth = poses[i].inverse() * poses[i + 1];
    p.source_file = kWork / fmt::format("frame-{:06d}.ply", i + 1);
    p.target_file = kWork / fmt::format("frame-{:06d}.ply", i);
    pairs.push_back(std::move(p));
  }
  return pairs;
}

const std::vector<Pair>& bunny_pairs() {
  static const std::vector<Pair> pairs = (fs::create_directories(kWork), make_bunny_pairs());
  return pairs;
}
const std::vector<Pair>& frame_pairs() {
  static const std::vector<Pair> pairs = (fs::create_directories(kWork), make_frame_pairs());
  return pairs;
}

fs::path write_pair_list(const std::vector<Pair>& pairs, const std::string& name) {
  const fs::path path = kWork / name;
  std::ofstream out(path);
  for (const Pair& p : pairs) out << p.source_file.string() << ' ' << p.target_file.string() << '\n';
  return path;
}

// --- shared scoring ----------------------------------------------------------------------------

struct Score {
  double fitness = 0.0;
  double rmse = 0.0;
};

// Open3D's RegistrationResult definition: source points whose nearest target point lies
// within max_distance; fitness = their fraction, RMSE over them.
Score evaluate(const Pair& p, const Isometry3d& T, double max_distance) {
  const locard::KdTree tree(p.target.positions);
  std::size_t n = 0;
  double sse = 0.0;
  locard::Neighbor nb;
  for (const auto& s : p.source.positions) {
    const Eigen::Vector3d q = T * s.cast<double>();
    if (!tree.nearest(q.cast<float>(), nb, static_cast<float>(max_distance))) continue;
    ++n;
    sse += (q - tree.points()[nb.index].cast<double>()).squaredNorm();
  }
  return {static_cast<double>(n) / p.source.size(), n ? std::sqrt(sse / n) : 0.0};
}

Isometry3d from_row_major(const nlohmann::json& values) {
  Isometry3d T = Isometry3d::Identity();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = values.at(4 * r + c).get<double>();
  return T;
}

bool ransac_success(const Pair& p, const Isometry3d& T) {
  return locard::rotation_difference_deg(p.T_target_source_truth, T) <= kSuccessDeg &&
         locard::translation_difference_m(p.T_target_source_truth, T) <= kSuccessM;
}

// --- Locard --------------------------------------------------------------------------------------

struct RansacRun {
  double seconds = std::numeric_limits<double>::infinity();
  std::vector<Isometry3d> transforms;  // pair-major, seed-minor
  std::size_t hypotheses = 0;
};
RansacRun g_ransac;

void BM_RansacBunnyPairs(benchmark::State& state) {
  const auto& pairs = bunny_pairs();
  locard::RansacOptions o;
  o.max_correspondence_distance = kRansacDistance;
  o.edge_length_ratio = 0.9;
  o.max_iterations = 100000;
  o.confidence = 0.999;
  for (auto _ : state) {
    RansacRun run;
    run.seconds = 0.0;
    for (const Pair& p : pairs) {
      for (int seed = 0; seed < kSeeds; ++seed) {
        o.seed = static_cast<std::uint64_t>(seed);
        const auto start = std::chrono::steady_clock::now();
        const auto matches = locard::match_descriptors(p.source_features, p.target_features);
        const locard::RansacResult r = locard::ransac_registration(p.source, p.target, matches, o);
        run.seconds += seconds_since(start);
        run.transforms.push_back(r.T_target_source);
        run.hypotheses += r.hypotheses;
      }
    }
    if (run.seconds < g_ransac.seconds) g_ransac = std::move(run);
  }
  state.counters["registrations"] = static_cast<double>(pairs.size() * kSeeds);
}
BENCHMARK(BM_RansacBunnyPairs)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

// RANSAC alone on the same correspondences (Locard's mutual FPFH matches, also handed to
// Open3D's registration_ransac_based_on_correspondence).
RansacRun g_ransac_only;

void BM_RansacOnlyBunnyPairs(benchmark::State& state) {
  const auto& pairs = bunny_pairs();
  locard::RansacOptions o;
  o.max_correspondence_distance = kRansacDistance;
  for (auto _ : state) {
    RansacRun run;
    run.seconds = 0.0;
    for (const Pair& p : pairs) {
      for (int seed = 0; seed < kSeeds; ++seed) {
        o.seed = static_cast<std::uint64_t>(seed);
        const auto start = std::chrono::steady_clock::now();
        const locard::RansacResult r = locard::ransac_registration(p.source, p.target, p.matches, o);
        run.seconds += seconds_since(start);
        run.transforms.push_back(r.T_target_source);
        run.hypotheses += r.hypotheses;
      }
    }
    if (run.seconds < g_ransac_only.seconds) g_ransac_only = std::move(run);
  }
}
BENCHMARK(BM_RansacOnlyBunnyPairs)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

struct IcpRun {
  double seconds = std::numeric_limits<double>::infinity();
  std::vector<Isometry3d> transforms;
  int iterations = 0;
};
IcpRun g_icp;

void BM_PointToPlaneIcp7ScenesPairs(benchmark::State& state) {
  const auto& pairs = frame_pairs();
  locard::IcpOptions o;
  o.method = locard::IcpMethod::PointToPlane;
  o.max_correspondence_distance = kIcpDistance;
  o.convergence.max_iterations = kIcpMaxIterations;
  for (auto _ : state) {
    IcpRun run;
    run.seconds = 0.0;
    for (const Pair& p : pairs) {
      const auto start = std::chrono::steady_clock::now();
      const locard::IcpResult r = locard::icp(p.source, p.target, Isometry3d::Identity(), o);
      run.seconds += seconds_since(start);
      run.transforms.push_back(r.T_target_source);
      run.iterations += r.iterations;
    }
    if (run.seconds < g_icp.seconds) g_icp = std::move(run);
  }
  state.counters["pairs"] = static_cast<double>(pairs.size());
}
BENCHMARK(BM_PointToPlaneIcp7ScenesPairs)->Unit(benchmark::kMillisecond)->UseRealTime()
    ->Iterations(kPeerRepeats);

// --- reports -------------------------------------------------------------------------------------

// Runs a peer and parses the last output line that starts with '{' (the peers print one JSON
// object with nested objects, so bench_peers.hpp's "from the last '{'" does not apply).
nlohmann::json run_peer(const std::string& command) {
  FILE* pipe = ::popen((command + " 2>/dev/null").c_str(), "r");
  if (!pipe) return nlohmann::json(nlohmann::json::value_t::discarded);
  std::string out;
  std::array<char, 4096> buffer{};
  std::size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out.append(buffer.data(), n);
  if (::pclose(pipe) != 0) return nlohmann::json(nlohmann::json::value_t::discarded);
  std::size_t start = std::string::npos;
  for (std::size_t line = 0; line < out.size();) {
    if (out[line] == '{') start = line;
    const std::size_t next = out.find('\n', line);
    if (next == std::string::npos) break;
    line = next + 1;
  }
  if (start == std::string::npos) return nlohmann::json(nlohmann::json::value_t::discarded);
  return nlohmann::json::parse(out.substr(start), nullptr, false);
}

fs::path pcl_peer(const char* argv0) {
  if (const char* env = std::getenv("LOCARD_PCL_REGISTRATION_PEER")) return env;
  return fs::absolute(argv0).parent_path() / "pcl" / "locard_pcl_registration";
}

void report_ransac(const fs::path& script, const fs::path& pcl) {
  const auto& pairs = bunny_pairs();
  const auto success_rate = [&](const std::vector<Isometry3d>& transforms) {
    std::size_t ok = 0;
    for (std::size_t i = 0; i < transforms.size(); ++i)
      ok += ransac_success(pairs[i / kSeeds], transforms[i]);
    return std::pair{ok, transforms.size()};
  };
  const auto [ok, runs] = success_rate(g_ransac.transforms);
  fmt::print("\nRANSAC global registration, bunny ring pairs: {} pairs x {} seeds, 5 mm voxels "
             "({}..{} points), success = within {} deg and {} cm of bun.conf\n"
             "matching (mutual FPFH nearest neighbours) + RANSAC:\n",
             pairs.size(), kSeeds, pairs[0].source.size(), pairs[3].source.size(), kSuccessDeg,
             kSuccessM * 100);
  fmt::print("  locard : {:9.1f} ms  success {}/{}  ({:.0f} hypotheses per run on average)\n",
             1e3 * g_ransac.seconds, ok, runs, static_cast<double>(g_ransac.hypotheses) / runs);
  const auto list = write_pair_list(pairs, "bunny_pairs.txt");
  const auto show = [&](const std::string& name, const nlohmann::json& peer) {
    if (peer.is_discarded()) {
      fmt::print("  {:7}: not measured\n", name);
      return;
    }
    std::vector<Isometry3d> transforms;
    for (const auto& r : peer["runs"]) transforms.push_back(from_row_major(r["T"]));
    const auto [pok, pruns] = success_rate(transforms);
    const double seconds = peer["seconds"].get<double>();
    fmt::print("  {:7}: {:9.1f} ms  success {}/{}  -> locard is {:.2f}x faster ({})\n", name,
               1e3 * seconds, pok, pruns, seconds / g_ransac.seconds,
               peer["peer"].get<std::string>());
  };
  show("open3d", run_peer(fmt::format(
                     "/usr/bin/python3 {} ransac {} {} {} {} {}", locard::bench::quoted(script),
                     locard::bench::quoted(list), kFpfhRadius, kFpfhMaxNeighbors,
                     kRansacDistance, kSeeds)));
  if (fs::exists(pcl))
    show("pcl", run_peer(fmt::format("{} ransac {} {} {} {}", locard::bench::quoted(pcl),
                                     locard::bench::quoted(list), kFpfhRadius, kRansacDistance,
                                     kSeeds)));
  else
    fmt::print("  pcl    : not measured ({} not built)\n", pcl.string());
  // RANSAC alone, identical correspondences.
  const auto [ook, oruns] = success_rate(g_ransac_only.transforms);
  fmt::print("RANSAC alone on identical correspondences (Locard's mutual matches, {}..{} per "
             "pair):\n", pairs[2].matches.size(), pairs[0].matches.size());
  fmt::print("  locard : {:9.1f} ms  success {}/{}  ({:.0f} hypotheses per run on average)\n",
             1e3 * g_ransac_only.seconds, ook, oruns,
             static_cast<double>(g_ransac_only.hypotheses) / oruns);
  const fs::path corr_list = kWork / "bunny_pairs_matches.txt";
  {
    std::ofstream out(corr_list);
    for (const Pair& p : pairs)
      out << p.source_file.string() << ' ' << p.target_file.string() << ' '
          << p.matches_file.string() << '\n';
  }
  const nlohmann::json only = run_peer(fmt::format("/usr/bin/python3 {} ransac_corr {} {} {}",
                                                   locard::bench::quoted(script),
                                                   locard::bench::quoted(corr_list),
                                                   kRansacDistance, kSeeds));
  if (only.is_discarded()) {
    fmt::print("  open3d : not measured\n");
  } else {
    std::vector<Isometry3d> transforms;
    for (const auto& r : only["runs"]) transforms.push_back(from_row_major(r["T"]));
    const auto [pok, pruns] = success_rate(transforms);
    const double seconds = only["seconds"].get<double>();
    fmt::print("  open3d : {:9.1f} ms  success {}/{}  -> locard is {:.2f}x faster ({})\n",
               1e3 * seconds, pok, pruns, seconds / g_ransac_only.seconds,
               only["peer"].get<std::string>());
  }
}

void report_icp(const fs::path& script, const fs::path& pcl) {
  const auto& pairs = frame_pairs();
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
  const Summary ours = summarise(g_icp.transforms);
  fmt::print("\npoint-to-plane ICP, 7-Scenes consecutive frames 0..59: {} pairs, 1 cm voxels "
             "(~{} points per frame), max distance {} m, {} threads\n",
             pairs.size(), pairs[0].source.size(), kIcpDistance,
             tbb::this_task_arena::max_concurrency());
  fmt::print("  locard : {:9.1f} ms  {:.2f} iterations/pair  fitness {:.4f}  RMSE {:.3f} mm  "
             "max error vs truth {:.3f} deg {:.2f} mm\n",
             1e3 * g_icp.seconds, static_cast<double>(g_icp.iterations) / pairs.size(),
             ours.mean_fitness, 1e3 * ours.mean_rmse, ours.max_deg, 1e3 * ours.max_m);
  const auto list = write_pair_list(pairs, "frame_pairs.txt");
  const auto show = [&](const std::string& name, const nlohmann::json& peer) {
    if (peer.is_discarded()) {
      fmt::print("  {:7}: not measured\n", name);
      return;
    }
    std::vector<Isometry3d> transforms;
    for (const auto& r : peer["runs"]) transforms.push_back(from_row_major(r["T"]));
    const Summary theirs = summarise(transforms);
    std::size_t not_worse = 0;
    for (std::size_t i = 0; i < pairs.size(); ++i)
      not_worse += ours.rmse[i] <= theirs.rmse[i] + 1e-6;  // 1 um: float noise
    const double seconds = peer["seconds"].get<double>();
    fmt::print("  {:7}: {:9.1f} ms                    fitness {:.4f}  RMSE {:.3f} mm  max "
               "error vs truth {:.3f} deg {:.2f} mm\n",
               name, 1e3 * seconds, theirs.mean_fitness, 1e3 * theirs.mean_rmse,
               theirs.max_deg, 1e3 * theirs.max_m);
    fmt::print("           -> locard is {:.2f}x faster; its RMSE is lower or equal (within 1 um) "
               "on {}/{} pairs ({})\n",
               seconds / g_icp.seconds, not_worse, pairs.size(), peer["peer"].get<std::string>());
  };
  show("open3d", run_peer(fmt::format(
                     "/usr/bin/python3 {} icp {} {} {} {}", locard::bench::quoted(script),
                     locard::bench::quoted(list), kIcpDistance, kIcpMaxIterations,
                     kPeerRepeats)));
  if (fs::exists(pcl))
    show("pcl", run_peer(fmt::format("{} icp {} {} {} {}", locard::bench::quoted(pcl),
                                     locard::bench::quoted(list), kIcpDistance,
                                     kIcpMaxIterations, kPeerRepeats)));
  else
    fmt::print("  pcl    : not measured ({} not built)\n", pcl.string());
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  const fs::path script = fs::path(__FILE__).parent_path() / "peers" / "open3d_registration.py";
  const fs::path pcl = pcl_peer(argv[0]);
  if (!g_ransac.transforms.empty()) report_ransac(script, pcl);
  if (!g_icp.transforms.empty()) report_icp(script, pcl);
  fs::remove_all(kWork);
  return 0;
}
