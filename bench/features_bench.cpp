// Normals + FPFH on a ~50k-point cloud (10 fused 7-Scenes frames, voxel-down-sampled to the
// whole-millimetre voxel whose output is closest to 50,000 points), against Open3D
// (estimate_normals + orient_normals_towards_camera_location + compute_fpfh_feature) and PCL
// (NormalEstimationOMP + FPFHEstimationOMP), through the peer harness (bench/harness): the same
// PLY file (positions only), parameters, warm-up, repeats and thread count on every side:
//   normals: hybrid search, radius 2 x voxel, at most 30 neighbours, oriented to the origin;
//   FPFH:    hybrid search, radius 5 x voxel, at most 100 neighbours.
// (PCL's radius search has no neighbour cap, so it does more work; shown for reference.)
// Two comparisons: "normals" (a search structure + normals) and "normals_fpfh" (the same, then
// FPFH of every point). Every timed pass starts from the positions alone; reading the PLY is
// outside the clock.
// Quality, scored here for every side on every 100th point: the normals against a brute-force
// reference (the same hybrid neighbourhood, PCA in double, oriented to the viewpoint), the
// descriptors against Locard's (defined as Open3D's).
// Also: ISS keypoints and descriptor matching on the same cloud (Locard only, plain Google
// Benchmarks).
//
//   build/release/bench/features_bench [--benchmark_filter=normals_fpfh] [--repeats=N]
// PCL is measured when <build>/bench/pcl/locard_pcl_peer exists (configure with
// -DLOCARD_WITH_PCL=ON) or LOCARD_PCL_PEER_DIR names its folder.

#include "bench_data.hpp"
#include "peer_harness.hpp"

#include <locard/core/kdtree.hpp>
#include <locard/features/descriptor_matching.hpp>
#include <locard/features/fpfh.hpp>
#include <locard/features/iss_keypoints.hpp>
#include <locard/io/ply.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace {

namespace bench = locard::bench;

constexpr std::size_t kTargetPoints = 50000;
constexpr std::size_t kSampleEvery = 100;  // points whose normals and descriptors are scored

struct Input {
  locard::PointCloud cloud;  // positions only
  int voxel_mm = 0;
  float voxel() const { return static_cast<float>(voxel_mm) / 1000.f; }
};

const Input& input() {
  static const Input in = [] {
    const locard::PointCloud fused = bench::fused_seven_scenes(10);
    // Bisection on whole millimetres (the voxel count falls as the voxel grows).
    int low = 2, high = 100;
    while (high - low > 1) {
      const int mid = (low + high) / 2;
      const std::size_t count = locard::voxel_down_sample(fused, mid / 1000.f).cloud.size();
      (count > kTargetPoints ? low : high) = mid;
    }
    Input best;
    for (int mm : {low, high}) {
      locard::PointCloud down = locard::voxel_down_sample(fused, mm / 1000.f).cloud;
      const auto error = [](std::size_t n) {
        return n > kTargetPoints ? n - kTargetPoints : kTargetPoints - n;
      };
      if (best.cloud.empty() || error(down.size()) < error(best.cloud.size())) {
        best.voxel_mm = mm;
        best.cloud.positions = std::move(down.positions);
      }
    }
    return best;
  }();
  return in;
}

const std::filesystem::path& input_ply() {
  static const std::filesystem::path path = [] {
    const auto p = bench::work_folder("features") / "cloud_50k.ply";
    locard::write_ply(p, input().cloud);
    return p;
  }();
  return path;
}

locard::NormalOptions normal_options(float voxel) {
  locard::NormalOptions options;
  options.radius = 2 * voxel;
  options.max_neighbors = 30;
  return options;
}
locard::FpfhOptions fpfh_options(float voxel) { return {5 * voxel, 100}; }

// --- normals and normals + FPFH against the peers ---------------------------------------------

bench::Workload features_workload(const std::string& kernel) {
  const Input& in = input();
  bench::Workload w;
  w.kernel = kernel;
  w.inputs = {{"cloud", input_ply().string()}};
  w.parameters = {{"normal_radius", 2 * in.voxel_mm / 1000.0},
                  {"normal_max_nn", 30},
                  {"viewpoint", {0.0, 0.0, 0.0}},
                  {"sample_every", kSampleEvery}};
  if (kernel == "normals_fpfh") {
    w.parameters["fpfh_radius"] = 5 * in.voxel_mm / 1000.0;
    w.parameters["fpfh_max_nn"] = 100;
  }
  return w;
}

template <typename Vector>
std::vector<float> sampled(const std::vector<Vector>& values, std::size_t every) {
  std::vector<float> out;
  for (std::size_t i = 0; i < values.size(); i += every)
    out.insert(out.end(), values[i].data(), values[i].data() + values[i].size());
  return out;
}

// One timed pass: from the positions alone, a kd-tree, normals and (with_fpfh) FPFH.
nlohmann::json locard_features(const bench::Workload& w, bool with_fpfh) {
  const nlohmann::json& p = w.parameters;
  locard::NormalOptions normals;
  normals.radius = p["normal_radius"].get<float>();
  normals.max_neighbors = p["normal_max_nn"].get<int>();
  normals.orientation = locard::NormalOrientation::TowardsViewpoint;
  const auto viewpoint = p["viewpoint"].get<std::vector<float>>();
  normals.viewpoint = Eigen::Vector3f(viewpoint.at(0), viewpoint.at(1), viewpoint.at(2));
  const std::size_t every = p["sample_every"].get<std::size_t>();

  locard::PointCloud cloud;
  cloud.positions = input().cloud.positions;
  const locard::KdTree tree(cloud.positions);
  locard::estimate_normals(cloud, normals, &tree);
  nlohmann::json out = {{"points", cloud.size()}, {"normals", sampled(cloud.normals, every)}};
  if (with_fpfh) {
    const std::vector<locard::Fpfh> descriptors = locard::compute_fpfh(
        cloud, {p["fpfh_radius"].get<float>(), p["fpfh_max_nn"].get<int>()}, &tree);
    benchmark::DoNotOptimize(descriptors.data());
    out["descriptors"] = descriptors.size();
    out["fpfh"] = sampled(descriptors, every);
  }
  return out;
}

// The evaluator's reference normal at point i: the at most `max_nn` nearest points within
// `radius` (brute force), PCA in double, oriented towards the viewpoint; none below 3 points.
std::optional<Eigen::Vector3d> reference_normal(const std::vector<Eigen::Vector3f>& points,
                                                std::size_t i, double radius, std::size_t max_nn,
                                                const Eigen::Vector3d& viewpoint) {
  const Eigen::Vector3d p = points[i].cast<double>();
  std::vector<std::pair<double, std::size_t>> near;
  for (std::size_t j = 0; j < points.size(); ++j) {
    const double d2 = (points[j].cast<double>() - p).squaredNorm();
    if (d2 <= radius * radius) near.emplace_back(d2, j);
  }
  if (near.size() > max_nn) {
    std::nth_element(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(max_nn),
                     near.end());
    near.resize(max_nn);
  }
  if (near.size() < 3) return std::nullopt;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& [d2, j] : near) mean += points[j].cast<double>();
  mean /= static_cast<double>(near.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const auto& [d2, j] : near) {
    const Eigen::Vector3d q = points[j].cast<double>() - mean;
    covariance += q * q.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  Eigen::Vector3d n = solver.eigenvectors().col(0);
  if (n.dot(viewpoint - p) < 0) n = -n;
  return n;
}

// A peer's output read leniently: a missing key or a non-number (NaN is written as null)
// reads as NaN, so one odd value cannot stop the report.
double number(const nlohmann::json& output, const char* key) {
  const auto it = output.find(key);
  return it != output.end() && it->is_number() ? it->get<double>()
                                               : std::numeric_limits<double>::quiet_NaN();
}
std::vector<double> numbers(const nlohmann::json& output, const char* key) {
  std::vector<double> out;
  const auto it = output.find(key);
  if (it == output.end() || !it->is_array()) return out;
  for (const nlohmann::json& v : *it)
    out.push_back(v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN());
  return out;
}

// Prints, for every measured side, counts and scores on the sampled points.
void report_features(const bench::Comparison& c, const nlohmann::json& parameters) {
  const auto& points = input().cloud.positions;
  const std::size_t every = parameters["sample_every"].get<std::size_t>();
  const auto vp = parameters["viewpoint"].get<std::vector<double>>();
  std::vector<std::optional<Eigen::Vector3d>> reference;
  for (std::size_t i = 0; i < points.size(); i += every)
    reference.push_back(reference_normal(points, i, parameters["normal_radius"].get<double>(),
                                         parameters["normal_max_nn"].get<std::size_t>(),
                                         Eigen::Vector3d(vp.at(0), vp.at(1), vp.at(2))));
  const bench::SideRun* locard = c.run_of("locard");
  const auto locard_fpfh = locard ? numbers(locard->output, "fpfh") : std::vector<double>{};
  const bool with_fpfh = parameters.contains("fpfh_radius");
  fmt::print("  input: {} points (voxel {} m); normals radius {} m / {} nn", points.size(),
             input().voxel_mm / 1000.0, parameters["normal_radius"].get<double>(),
             parameters["normal_max_nn"].get<int>());
  if (with_fpfh)
    fmt::print(", FPFH radius {} m / {} nn", parameters["fpfh_radius"].get<double>(),
               parameters["fpfh_max_nn"].get<int>());
  fmt::print("\n");
  fmt::print("  {:<8} {:>7} {:>11}  normals of {} sampled points vs brute-force PCA: mean angle, "
             "> 1 deg, flipped{}\n",
             "side", "points", with_fpfh ? "descriptors" : "", reference.size(),
             with_fpfh ? "; FPFH vs locard's: relative L1 difference, descriptors > 1% off" : "");
  for (const auto& side : c.sides()) {
    const bench::SideRun* run = c.run_of(side->name());
    if (!run) continue;
    const auto normals = numbers(run->output, "normals");
    std::string score;
    if (normals.size() != 3 * reference.size()) {
      score = fmt::format("{} sampled normal values, expected {}", normals.size(),
                          3 * reference.size());
    } else {
      double angle_sum = 0;
      std::size_t scored = 0, off = 0, flipped = 0, invalid = 0;
      for (std::size_t k = 0; k < reference.size(); ++k) {
        if (!reference[k]) continue;
        const Eigen::Vector3d n(normals[3 * k], normals[3 * k + 1], normals[3 * k + 2]);
        if (!n.allFinite() || n.norm() < 0.5) {
          ++invalid;
          continue;
        }
        const double cosine = std::clamp(n.normalized().dot(*reference[k]), -1.0, 1.0);
        const double angle = std::acos(cosine) * 180 / std::numbers::pi;
        angle_sum += std::min(angle, 180 - angle);  // the line's angle; the sign is `flipped`
        off += std::min(angle, 180 - angle) > 1;
        flipped += angle > 90;
        ++scored;
      }
      const double count = static_cast<double>(std::max<std::size_t>(1, scored));
      score = fmt::format("{:.1e} deg, {:.1f}%, {:.1f}%", angle_sum / count, 100.0 * off / count,
                          100.0 * flipped / count);
      if (invalid) score += fmt::format(" ({} not unit or not finite)", invalid);
    }
    if (with_fpfh) {
      const auto fpfh = numbers(run->output, "fpfh");
      if (locard_fpfh.empty() || fpfh.size() != locard_fpfh.size()) {
        score += fmt::format("; FPFH: {} values, locard's {}", fpfh.size(), locard_fpfh.size());
      } else {
        double difference = 0, total = 0;
        std::size_t off = 0;
        for (std::size_t k = 0; k < fpfh.size(); k += 33) {
          double d = 0, t = 0;
          for (std::size_t b = k; b < k + 33; ++b) {
            d += std::abs(fpfh[b] - locard_fpfh[b]);
            t += std::abs(locard_fpfh[b]);
          }
          if (!std::isfinite(d)) {  // counted as off, left out of the sum
            ++off;
            continue;
          }
          difference += d;
          total += t;
          off += d > 0.01 * t;
        }
        score += fmt::format("; {:.2e}, {:.1f}%", difference / std::max(total, 1e-300),
                             100.0 * off / static_cast<double>(fpfh.size() / 33));
      }
    }
    // A peer without the neighbour cap (PCL) uses every point within the radius: another
    // neighbourhood, so its normals and descriptors differ by construction.
    if (!run->output.value("neighbour_caps_applied", true))
      score += " (no neighbour cap: every point within the radius)";
    fmt::print("  {:<8} {:>7} {:>11}  {}\n", run->side, number(run->output, "points"),
               with_fpfh ? fmt::format("{}", number(run->output, "descriptors")) : "", score);
  }
}

void add_features_comparison(const std::string& kernel, const std::string& title) {
  const bool with_fpfh = kernel == "normals_fpfh";
  // The parameters the workload was prepared with, for the report.
  auto parameters = std::make_shared<nlohmann::json>();
  bench::add_comparison(kernel, title, {.warmup = 1, .repeats = 5},
                        [kernel, parameters] {
                          bench::Workload w = features_workload(kernel);
                          *parameters = w.parameters;
                          return w;
                        })
      .side(bench::in_process_side("locard",
                                   [with_fpfh](const bench::Workload& w) {
                                     return locard_features(w, with_fpfh);
                                   }))
      .side(bench::open3d_side("open3d_features.py"))
      .side(bench::pcl_side("locard_pcl_peer"))
      .report([parameters](const bench::Comparison& c) { report_features(c, *parameters); });
}

// --- Locard only -------------------------------------------------------------------------------

void BM_IssKeypoints(benchmark::State& state) {
  const Input& in = input();
  locard::IssOptions options;
  options.salient_radius = 6 * in.voxel();
  options.non_max_radius = 4 * in.voxel();
  std::size_t keypoints = 0;
  for (auto _ : state) keypoints = locard::iss_keypoints(in.cloud, options).size();
  state.counters["keypoints"] = static_cast<double>(keypoints);
}
BENCHMARK(BM_IssKeypoints)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_MutualMatching(benchmark::State& state) {
  // All-point descriptors of the cloud against those of the cloud shifted by half a voxel.
  const Input& in = input();
  locard::PointCloud a = in.cloud, b = in.cloud;
  for (auto& p : b.positions) p += Eigen::Vector3f::Constant(in.voxel() / 2);
  locard::estimate_normals(a, normal_options(in.voxel()));
  locard::estimate_normals(b, normal_options(in.voxel()));
  const auto fa = locard::compute_fpfh(a, fpfh_options(in.voxel()));
  const auto fb = locard::compute_fpfh(b, fpfh_options(in.voxel()));
  std::size_t matches = 0;
  for (auto _ : state) matches = locard::match_descriptors(fa, fb).size();
  state.counters["matches"] = static_cast<double>(matches);
}
BENCHMARK(BM_MutualMatching)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  add_features_comparison("normals", "normals, ~50k-point cloud (10 fused 7-Scenes frames, "
                                     "voxel-down-sampled)");
  add_features_comparison("normals_fpfh", "normals + FPFH, ~50k-point cloud (10 fused 7-Scenes "
                                          "frames, voxel-down-sampled)");
  return bench::run_main(argc, argv);
}
