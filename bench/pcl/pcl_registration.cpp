// PCL peer for bench/registration_bench (protocol: peer_protocol.hpp). Clouds are the binary
// PLY files the benchmark wrote (float x y z nx ny nz; read by ply_reader.hpp, no pcl_io/VTK);
// features are raw little-endian float32, 33 per point, in the clouds' point order. Every input
// is read outside the clock. Outputs: "transforms", row-major 4x4, in the workload's order
// (pair-major, seed-minor for RANSAC), for the benchmark's one evaluator; RANSAC also returns
// "hypotheses" (drawn) and "correspondences" (putative, RANSAC's input) per run, ICP
// "iterations" per pair.
//
//  ransac_feature_matching  inputs.pairs[]: source, target, source_features, target_features.
//      Timed, for every pair and every seed of parameters.seeds: reciprocal nearest neighbours
//      in FPFH space (pcl::registration::CorrespondenceEstimation::
//      determineReciprocalCorrespondences; parameters.mutual must be true), then RANSAC alone
//      (below) on them.
//  ransac_correspondences   inputs.pairs[]: source, target, correspondences (text, one "s t"
//      per line). Timed, for every pair and seed: RANSAC alone:
//      pcl::RandomSampleConsensus over pcl::SampleConsensusModelRegistration (3-point Umeyama
//      hypotheses, inliers = correspondences within parameters.max_correspondence_distance),
//      at most parameters.max_iterations hypotheses, stopping early at parameters.confidence
//      (PCL's k = log(1 - p) / log(1 - w^3), the same rule as Locard's and Open3D's), its
//      sampler seeded with the seed, one thread (PCL's default); then the winner refitted on its
//      inliers (optimizeModelCoefficients). PCL's registration model has no edge-length
//      check: it rejects samples whose source points lie closer than its own spread-derived
//      distance instead.
//  icp_point_to_plane       inputs.pairs[]: source, target (with normals). Timed, per pair:
//      pcl::IterativeClosestPointWithNormals (point-to-plane, linear least squares) from the
//      identity with parameters.max_correspondence_distance and max_iterations; converged when
//      the step is below rotation_eps_deg and translation_eps_m, or when the correspondences'
//      MSE changes by less than relative_rmse (PCL's relative criterion is on the MSE).
//      PCL's ICP is single-threaded.

#include "peer_protocol.hpp"
#include "ply_reader.hpp"

#include <pcl/point_types.h>
#include <pcl/registration/correspondence_estimation.h>
#include <pcl/registration/icp.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_registration.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using nlohmann::json;
using PointCloud = pcl::PointCloud<pcl::PointXYZ>;
using NormalCloud = pcl::PointCloud<pcl::PointNormal>;
using Features = pcl::PointCloud<pcl::FPFHSignature33>;

Features::Ptr read_features(const std::string& path, std::size_t points) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  Features::Ptr out(new Features);
  out->resize(points);
  for (pcl::FPFHSignature33& f : *out)
    in.read(reinterpret_cast<char*>(f.histogram), sizeof f.histogram);
  if (!in)
    throw std::runtime_error(path + ": fewer than " + std::to_string(points) + " descriptors");
  locard_pcl::set_dense(*out);
  return out;
}

pcl::Correspondences read_correspondences(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  pcl::Correspondences out;
  for (int s, t; in >> s >> t;) out.emplace_back(s, t, 0.f);
  return out;
}

PointCloud::Ptr positions(const NormalCloud& cloud) {
  PointCloud::Ptr out(new PointCloud);
  out->resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    (*out)[i] = pcl::PointXYZ(cloud[i].x, cloud[i].y, cloud[i].z);
  locard_pcl::set_dense(*out);
  return out;
}

json row_major(const Eigen::Matrix4f& T) {
  json out = json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out.push_back(static_cast<double>(T(r, c)));
  return out;
}

// PCL's registration model with its sampler seeded (PCL seeds it with 12345 or the time).
class SeededRegistrationModel : public pcl::SampleConsensusModelRegistration<pcl::PointXYZ> {
 public:
  SeededRegistrationModel(const PointCloud::ConstPtr& source, std::uint32_t seed)
      : pcl::SampleConsensusModelRegistration<pcl::PointXYZ>(source) {
    rng_alg_.seed(seed);
  }
};

// RandomSampleConsensus that reports how many hypotheses it drew.
class CountingRansac : public pcl::RandomSampleConsensus<pcl::PointXYZ> {
 public:
  using pcl::RandomSampleConsensus<pcl::PointXYZ>::RandomSampleConsensus;
  int hypotheses() const { return iterations_; }
};

struct RansacParameters {
  double max_distance = 0.0;
  int max_iterations = 0;
  double confidence = 0.0;
  std::vector<std::uint32_t> seeds;

  explicit RansacParameters(const json& task) {
    const json& p = task.at("parameters");
    max_distance = p.at("max_correspondence_distance").get<double>();
    max_iterations = p.at("max_iterations").get<int>();
    confidence = p.at("confidence").get<double>();
    seeds = p.at("seeds").get<std::vector<std::uint32_t>>();
  }
};

struct RansacOutcome {
  Eigen::Matrix4f T = Eigen::Matrix4f::Identity();
  int hypotheses = 0;
  std::size_t correspondences = 0;
};

// RANSAC alone on putative correspondences (indices into the clouds).
RansacOutcome ransac(const PointCloud& source, const PointCloud& target,
                     const pcl::Correspondences& correspondences, std::uint32_t seed,
                     const RansacParameters& p) {
  RansacOutcome out;
  out.correspondences = correspondences.size();
  if (correspondences.size() < 3) return out;
  PointCloud::Ptr s(new PointCloud), t(new PointCloud);
  s->reserve(correspondences.size());
  t->reserve(correspondences.size());
  for (const pcl::Correspondence& c : correspondences) {
    s->push_back(source[static_cast<std::size_t>(c.index_query)]);
    t->push_back(target[static_cast<std::size_t>(c.index_match)]);
  }
  const auto model = std::make_shared<SeededRegistrationModel>(s, seed);
  model->setInputTarget(t);
  CountingRansac sac(model, p.max_distance);
  sac.setMaxIterations(p.max_iterations);
  sac.setProbability(p.confidence);
  // PCL's default serial loop: its OpenMP loop (setNumberOfThreads) takes a critical section
  // per hypothesis and was 20x slower than the serial one on these few hundred
  // correspondences with 2 threads.
  if (!sac.computeModel()) return out;
  out.hypotheses = sac.hypotheses();
  pcl::Indices inliers;
  sac.getInliers(inliers);
  Eigen::VectorXf coefficients, refined;
  sac.getModelCoefficients(coefficients);
  if (inliers.size() >= 3) {
    model->optimizeModelCoefficients(inliers, coefficients, refined);
    coefficients = refined;
  }
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out.T(r, c) = coefficients[4 * r + c];
  return out;
}

json ransac_output(const std::vector<RansacOutcome>& runs) {
  json transforms = json::array(), hypotheses = json::array(), correspondences = json::array();
  for (const RansacOutcome& r : runs) {
    transforms.push_back(row_major(r.T));
    hypotheses.push_back(r.hypotheses);
    correspondences.push_back(r.correspondences);
  }
  return {{"transforms", transforms}, {"hypotheses", hypotheses},
          {"correspondences", correspondences}};
}

locard_pcl::Pass prepare_ransac_feature_matching(const json& task) {
  if (!task.at("parameters").value("mutual", true))
    throw std::runtime_error("ransac_feature_matching: only mutual matching is implemented");
  struct Pair {
    PointCloud::Ptr source, target;
    Features::Ptr source_features, target_features;
  };
  auto pairs = std::make_shared<std::vector<Pair>>();
  for (const json& p : task.at("inputs").at("pairs")) {
    NormalCloud s, t;
    locard_pcl::read_ply(p.at("source").get<std::string>(), s);
    locard_pcl::read_ply(p.at("target").get<std::string>(), t);
    pairs->push_back({positions(s), positions(t),
                      read_features(p.at("source_features").get<std::string>(), s.size()),
                      read_features(p.at("target_features").get<std::string>(), t.size())});
  }
  const RansacParameters parameters(task);
  return [pairs, parameters] {
    std::vector<RansacOutcome> runs;
    for (const Pair& pair : *pairs) {
      for (const std::uint32_t seed : parameters.seeds) {
        pcl::registration::CorrespondenceEstimation<pcl::FPFHSignature33, pcl::FPFHSignature33>
            matching;
        matching.setInputSource(pair.source_features);
        matching.setInputTarget(pair.target_features);
        pcl::Correspondences matches;
        matching.determineReciprocalCorrespondences(matches);
        runs.push_back(ransac(*pair.source, *pair.target, matches, seed, parameters));
      }
    }
    return ransac_output(runs);
  };
}

locard_pcl::Pass prepare_ransac_correspondences(const json& task) {
  struct Pair {
    PointCloud::Ptr source, target;
    pcl::Correspondences correspondences;
  };
  auto pairs = std::make_shared<std::vector<Pair>>();
  for (const json& p : task.at("inputs").at("pairs")) {
    NormalCloud s, t;
    locard_pcl::read_ply(p.at("source").get<std::string>(), s);
    locard_pcl::read_ply(p.at("target").get<std::string>(), t);
    pairs->push_back({positions(s), positions(t),
                      read_correspondences(p.at("correspondences").get<std::string>())});
  }
  const RansacParameters parameters(task);
  return [pairs, parameters] {
    std::vector<RansacOutcome> runs;
    for (const Pair& pair : *pairs)
      for (const std::uint32_t seed : parameters.seeds)
        runs.push_back(ransac(*pair.source, *pair.target, pair.correspondences, seed, parameters));
    return ransac_output(runs);
  };
}

// IterativeClosestPointWithNormals that reports its iteration count.
class CountingIcp
    : public pcl::IterativeClosestPointWithNormals<pcl::PointNormal, pcl::PointNormal> {
 public:
  int iterations() const { return nr_iterations_; }
};

locard_pcl::Pass prepare_icp(const json& task) {
  struct Pair {
    NormalCloud::Ptr source, target;
  };
  auto pairs = std::make_shared<std::vector<Pair>>();
  for (const json& p : task.at("inputs").at("pairs")) {
    Pair pair{NormalCloud::Ptr(new NormalCloud), NormalCloud::Ptr(new NormalCloud)};
    locard_pcl::read_ply(p.at("source").get<std::string>(), *pair.source);
    locard_pcl::read_ply(p.at("target").get<std::string>(), *pair.target);
    pairs->push_back(std::move(pair));
  }
  const json& p = task.at("parameters");
  const double max_distance = p.at("max_correspondence_distance").get<double>();
  const int max_iterations = p.at("max_iterations").get<int>();
  const double translation_eps = p.at("translation_eps_m").get<double>();
  const double rotation_eps_rad = p.at("rotation_eps_deg").get<double>() * M_PI / 180.0;
  const double relative_rmse = p.at("relative_rmse").get<double>();
  return [=] {
    json transforms = json::array(), iterations = json::array();
    for (const Pair& pair : *pairs) {
      NormalCloud aligned;
      CountingIcp icp;
      icp.setInputSource(pair.source);
      icp.setInputTarget(pair.target);
      icp.setMaxCorrespondenceDistance(max_distance);
      icp.setMaximumIterations(max_iterations);
      icp.setTransformationEpsilon(translation_eps * translation_eps);  // squared step
      icp.setTransformationRotationEpsilon(std::cos(rotation_eps_rad));  // cos of the step angle
      icp.setEuclideanFitnessEpsilon(relative_rmse);                    // relative MSE change
      icp.align(aligned);
      transforms.push_back(row_major(icp.getFinalTransformation()));
      iterations.push_back(icp.iterations());
    }
    return json{{"transforms", transforms}, {"iterations", iterations}};
  };
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return locard_pcl::serve(argc, argv, "pcl " PCL_VERSION_PRETTY,
                             {{"ransac_feature_matching", prepare_ransac_feature_matching},
                              {"ransac_correspondences", prepare_ransac_correspondences},
                              {"icp_point_to_plane", prepare_icp}});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "locard_pcl_registration: %s\n", e.what());
    return 1;
  }
}
