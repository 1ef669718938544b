// PCL peer for bench/registration_bench: the same registrations with PCL 1.13 on the clouds the
// benchmark wrote (binary little-endian PLY with float x y z nx ny nz, as locard::write_ply
// writes them; read here directly so that no pcl_io/VTK is needed). Prints one JSON object.
//
//   locard_pcl_registration icp PAIRS MAX_DISTANCE MAX_ITERATIONS REPEATS
//       pcl::IterativeClosestPointWithNormals (point-to-plane, linear least squares) from the
//       identity; stops as Locard does: rotation step below 1e-3 degrees and translation step
//       below 1e-5 m, or MAX_ITERATIONS. Total seconds, best of REPEATS.
//   locard_pcl_registration ransac PAIRS FPFH_RADIUS MAX_DISTANCE SEEDS
//       pcl::FPFHEstimationOMP with the file's normals (radius search; not timed), then for
//       every seed pcl::SampleConsensusPrerejective (3 samples, nearest feature, edge-length
//       similarity 0.9, inlier distance MAX_DISTANCE, 20000 iterations: PCL has no
//       confidence-based early exit), timed.
// PAIRS: one "SOURCE.ply TARGET.ply" per line.

#include <pcl/features/fpfh_omp.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/sample_consensus_prerejective.h>
#include <pcl/search/kdtree.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

using Cloud = pcl::PointCloud<pcl::PointNormal>;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int type_size(const std::string& type) {
  if (type == "float" || type == "float32" || type == "int" || type == "uint" ||
      type == "int32" || type == "uint32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  if (type == "uchar" || type == "char" || type == "uint8" || type == "int8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  throw std::runtime_error("unsupported PLY property type " + type);
}

// Binary little-endian PLY vertices with float x y z and float nx ny nz.
Cloud::Ptr read_ply(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::string line;
  std::size_t count = 0;
  bool in_vertex = false, binary_le = false;
  int stride = 0;
  int offset[6] = {-1, -1, -1, -1, -1, -1};
  const char* names[6] = {"x", "y", "z", "nx", "ny", "nz"};
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "format") {
      std::string format;
      words >> format;
      binary_le = format == "binary_little_endian";
    } else if (word == "element") {
      std::string name;
      words >> name;
      in_vertex = name == "vertex";
      if (in_vertex) words >> count;
    } else if (word == "property" && in_vertex) {
      std::string type, name;
      words >> type >> name;
      for (int k = 0; k < 6; ++k)
        if (name == names[k] && (type == "float" || type == "float32")) offset[k] = stride;
      stride += type_size(type);
    } else if (word == "end_header") {
      break;
    }
  }
  if (!binary_le) throw std::runtime_error(path + ": only binary_little_endian PLY is read");
  for (int k = 0; k < 6; ++k)
    if (offset[k] < 0) throw std::runtime_error(path + ": no float " + names[k]);
  std::vector<char> data(count * static_cast<std::size_t>(stride));
  in.read(data.data(), static_cast<std::streamsize>(data.size()));
  if (!in) throw std::runtime_error(path + ": truncated");
  Cloud::Ptr cloud(new Cloud);
  cloud->resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    const char* v = data.data() + i * static_cast<std::size_t>(stride);
    pcl::PointNormal& p = (*cloud)[i];
    std::memcpy(&p.x, v + offset[0], 4);
    std::memcpy(&p.y, v + offset[1], 4);
    std::memcpy(&p.z, v + offset[2], 4);
    std::memcpy(&p.normal_x, v + offset[3], 4);
    std::memcpy(&p.normal_y, v + offset[4], 4);
    std::memcpy(&p.normal_z, v + offset[5], 4);
  }
  cloud->width = static_cast<std::uint32_t>(count);
  cloud->height = 1;
  cloud->is_dense = true;
  return cloud;
}

std::vector<std::pair<std::string, std::string>> read_pairs(const char* path) {
  std::ifstream in(path);
  std::vector<std::pair<std::string, std::string>> pairs;
  std::string s, t;
  while (in >> s >> t) pairs.emplace_back(s, t);
  return pairs;
}

std::string run_json(const Eigen::Matrix4f& T, double fitness) {
  std::string out = "{\"T\": [";
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%s%.9g", r + c ? ", " : "", static_cast<double>(T(r, c)));
      out += buf;
    }
  char buf[64];
  std::snprintf(buf, sizeof buf, "], \"fitness\": %.9g}", fitness);
  return out + buf;
}

int icp(const char* list, double max_distance, int max_iterations, int repeats) {
  std::vector<std::pair<Cloud::Ptr, Cloud::Ptr>> pairs;
  for (const auto& [s, t] : read_pairs(list)) pairs.emplace_back(read_ply(s), read_ply(t));
  double best = std::numeric_limits<double>::infinity();
  std::vector<std::string> runs;
  for (int r = 0; r < repeats; ++r) {
    double total = 0.0;
    runs.clear();
    for (const auto& [source, target] : pairs) {
      Cloud aligned;
      const auto start = std::chrono::steady_clock::now();
      pcl::IterativeClosestPointWithNormals<pcl::PointNormal, pcl::PointNormal> icp;
      icp.setInputSource(source);
      icp.setInputTarget(target);
      icp.setMaxCorrespondenceDistance(max_distance);
      icp.setMaximumIterations(max_iterations);
      icp.setTransformationEpsilon(1e-5 * 1e-5);  // squared translation step
      icp.setTransformationRotationEpsilon(std::cos(1e-3 * M_PI / 180.0));
      icp.align(aligned);
      total += seconds_since(start);
      runs.push_back(run_json(icp.getFinalTransformation(), icp.getFitnessScore(max_distance)));
    }
    best = std::min(best, total);
  }
  std::printf("{\"peer\": \"pcl %s\", \"pairs\": %zu, \"seconds\": %.9f, \"runs\": [",
              PCL_VERSION_PRETTY, pairs.size(), best);
  for (std::size_t i = 0; i < runs.size(); ++i) std::printf("%s%s", i ? ", " : "", runs[i].c_str());
  std::printf("]}\n");
  return 0;
}

int ransac(const char* list, float fpfh_radius, float max_distance, int seeds) {
  double total = 0.0;
  std::vector<std::string> runs;
  for (const auto& [s, t] : read_pairs(list)) {
    const Cloud::Ptr source = read_ply(s), target = read_ply(t);
    const auto features = [&](const Cloud::Ptr& cloud) {
      pcl::PointCloud<pcl::FPFHSignature33>::Ptr out(new pcl::PointCloud<pcl::FPFHSignature33>);
      pcl::FPFHEstimationOMP<pcl::PointNormal, pcl::PointNormal, pcl::FPFHSignature33> fpfh;
      fpfh.setInputCloud(cloud);
      fpfh.setInputNormals(cloud);
      fpfh.setSearchMethod(pcl::search::KdTree<pcl::PointNormal>::Ptr(
          new pcl::search::KdTree<pcl::PointNormal>));
      fpfh.setRadiusSearch(fpfh_radius);
      fpfh.compute(*out);
      return out;
    };
    const auto fs = features(source), ft = features(target);
    for (int seed = 0; seed < seeds; ++seed) {
      std::srand(static_cast<unsigned>(seed));  // PCL's samplers draw from rand()
      Cloud aligned;
      const auto start = std::chrono::steady_clock::now();
      pcl::SampleConsensusPrerejective<pcl::PointNormal, pcl::PointNormal, pcl::FPFHSignature33>
          align;
      align.setInputSource(source);
      align.setSourceFeatures(fs);
      align.setInputTarget(target);
      align.setTargetFeatures(ft);
      align.setMaximumIterations(20000);
      align.setNumberOfSamples(3);
      align.setCorrespondenceRandomness(1);
      align.setSimilarityThreshold(0.9f);
      align.setMaxCorrespondenceDistance(max_distance);
      align.setInlierFraction(0.25f);
      align.align(aligned);
      total += seconds_since(start);
      runs.push_back(run_json(align.getFinalTransformation(),
                              align.hasConverged() ? align.getFitnessScore(max_distance) : 0.0));
    }
  }
  std::printf("{\"peer\": \"pcl %s\", \"seconds\": %.9f, \"runs\": [", PCL_VERSION_PRETTY, total);
  for (std::size_t i = 0; i < runs.size(); ++i) std::printf("%s%s", i ? ", " : "", runs[i].c_str());
  std::printf("]}\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  try {
    if (mode == "icp" && argc == 6)
      return icp(argv[2], std::strtod(argv[3], nullptr), std::atoi(argv[4]), std::atoi(argv[5]));
    if (mode == "ransac" && argc == 6)
      return ransac(argv[2], std::strtof(argv[3], nullptr), std::strtof(argv[4], nullptr),
                    std::atoi(argv[5]));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "locard_pcl_registration: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr,
               "usage: %s icp PAIRS MAX_DISTANCE MAX_ITERATIONS REPEATS | ransac PAIRS "
               "FPFH_RADIUS MAX_DISTANCE SEEDS\n",
               argv[0]);
  return 2;
}
