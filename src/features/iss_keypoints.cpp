#include <locard/features/iss_keypoints.hpp>

#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <fmt/format.h>

#include <cmath>
#include <functional>
#include <optional>

namespace locard {

namespace {

// Builds a tree over the cloud unless a matching one was given.
const KdTree& tree_for(const PointCloud& cloud, const KdTree* tree, std::optional<KdTree>& own,
                       const char* what) {
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.positions[i].allFinite()) {
      throw InputError(fmt::format("{}: point {} has a non-finite position (remove such points "
                                   "first: remove_non_finite)", what, i));
    }
  }
  if (tree == nullptr) return own.emplace(cloud.positions);
  if (tree->size() != cloud.size()) {
    throw InputError(fmt::format("{}: the kd-tree holds {} points but the cloud has {}", what,
                                 tree->size(), cloud.size()));
  }
  return *tree;
}

// Saliency of one point (header, steps 1-2): l3 of the neighbourhood's scatter matrix when the
// eigenvalue ratios pass, or a negative value when the point is not salient.
double saliency(const std::vector<Eigen::Vector3f>& points, const std::vector<Neighbor>& neighbors,
                const IssOptions& options) {
  if (neighbors.size() < static_cast<std::size_t>(options.min_neighbors)) return -1.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Neighbor& nb : neighbors) mean += points[nb.index].cast<double>();
  mean /= static_cast<double>(neighbors.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Neighbor& nb : neighbors) {
    const Eigen::Vector3d d = points[nb.index].cast<double>() - mean;
    scatter.noalias() += d * d.transpose();
  }
  scatter /= static_cast<double>(neighbors.size());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(scatter, Eigen::EigenvaluesOnly);
  const double l3 = solver.eigenvalues()(0), l2 = solver.eigenvalues()(1),
               l1 = solver.eigenvalues()(2);
  if (!(l1 > 0.0) || !(l2 > 0.0)) return -1.0;
  if (l2 / l1 < options.gamma21 && l3 / l2 < options.gamma32) return l3;
  return -1.0;
}

}  // namespace

double cloud_resolution(const PointCloud& cloud, const KdTree* tree) {
  if (cloud.size() < 2) return 0.0;
  std::optional<KdTree> own;
  const KdTree& index = tree_for(cloud, tree, own, "cloud resolution");
  const double sum = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, cloud.size(), 1024), 0.0,
      [&](const auto& range, double partial) {
        std::vector<Neighbor> neighbors;
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          index.knn(cloud.positions[i], 2, neighbors);
          // The nearest other point: skip the point itself wherever it ranks among duplicates.
          const Neighbor& other = neighbors[0].index == i ? neighbors[1] : neighbors[0];
          partial += std::sqrt(static_cast<double>(other.squared_distance));
        }
        return partial;
      },
      std::plus<>());
  return sum / static_cast<double>(cloud.size());
}

std::vector<std::uint32_t> iss_keypoints(const PointCloud& cloud, const IssOptions& options,
                                         const KdTree* tree) {
  if (options.salient_radius < 0.0 || options.non_max_radius < 0.0 || options.min_neighbors < 1 ||
      !(options.gamma21 > 0.0) || !(options.gamma32 > 0.0)) {
    throw InputError(fmt::format(
        "ISS keypoints: expected radii >= 0, gammas > 0 and min_neighbors >= 1, got salient "
        "radius {}, non-max radius {}, gamma21 {}, gamma32 {}, min_neighbors {}",
        options.salient_radius, options.non_max_radius, options.gamma21, options.gamma32,
        options.min_neighbors));
  }
  const std::size_t n = cloud.size();
  if (n == 0) return {};
  std::optional<KdTree> own;
  const KdTree& index = tree_for(cloud, tree, own, "ISS keypoints");
  double salient_radius = options.salient_radius, non_max_radius = options.non_max_radius;
  if (salient_radius == 0.0 || non_max_radius == 0.0) {
    const double resolution = cloud_resolution(cloud, &index);
    if (salient_radius == 0.0) salient_radius = 6.0 * resolution;
    if (non_max_radius == 0.0) non_max_radius = 4.0 * resolution;
  }

  std::vector<double> salience(n, -1.0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const auto& range) {
    std::vector<Neighbor> neighbors;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      index.radius(cloud.positions[i], static_cast<float>(salient_radius), neighbors);
      salience[i] = saliency(index.points(), neighbors, options);
    }
  });

  // Step 3: non-maximum suppression over the salient points.
  std::vector<std::uint8_t> is_keypoint(n, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const auto& range) {
    std::vector<Neighbor> neighbors;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      if (salience[i] < 0.0) continue;
      index.radius(cloud.positions[i], static_cast<float>(non_max_radius), neighbors);
      if (neighbors.size() < static_cast<std::size_t>(options.min_neighbors)) continue;
      bool maximum = true;
      for (const Neighbor& nb : neighbors) {
        const double other = salience[nb.index];
        if (other > salience[i] || (other == salience[i] && nb.index < i)) {
          maximum = false;
          break;
        }
      }
      is_keypoint[i] = maximum;
    }
  });
  std::vector<std::uint32_t> keypoints;
  for (std::size_t i = 0; i < n; ++i) {
    if (is_keypoint[i]) keypoints.push_back(static_cast<std::uint32_t>(i));
  }
  return keypoints;
}

}  // namespace locard
