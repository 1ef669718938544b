#include <locard/preprocess/normals.hpp>

#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <optional>

namespace locard {

namespace {

struct LocalFrame {
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();
  float curvature = 0.f;
  bool degenerate = true;
};

// PCA of the neighbourhood (header: C = 1/k sum (p_j - pbar)(p_j - pbar)^T), centred in double.
LocalFrame fit_plane(const std::vector<Eigen::Vector3f>& points,
                     const std::vector<Neighbor>& neighbors) {
  LocalFrame frame;
  if (neighbors.size() < 3) return frame;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Neighbor& nb : neighbors) mean += points[nb.index].cast<double>();
  mean /= static_cast<double>(neighbors.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Neighbor& nb : neighbors) {
    const Eigen::Vector3d d = points[nb.index].cast<double>() - mean;
    covariance.noalias() += d * d.transpose();
  }
  covariance /= static_cast<double>(neighbors.size());

  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance);  // closed form; eigenvalues ascending
  const Eigen::Vector3d lambda = solver.eigenvalues();
  // Rank < 2 (all neighbours on one line or one spot): no plane to speak of. The closed-form
  // solver's eigenvalues carry a relative error near 1e-8, hence the margin.
  if (!(lambda(2) > 0.0) || !(lambda(1) > 1e-6 * lambda(2))) return frame;
  frame.normal = solver.eigenvectors().col(0).normalized().cast<float>();
  // Surface variation (Pauly et al. 2002, eq. 4).
  frame.curvature = static_cast<float>(lambda(0) / lambda.sum());
  frame.degenerate = false;
  return frame;
}

Eigen::Vector3f towards(const Eigen::Vector3f& from, const Eigen::Vector3f& to) {
  const Eigen::Vector3f d = to - from;
  const float norm = d.norm();
  return norm > 0.f ? Eigen::Vector3f(d / norm) : Eigen::Vector3f::UnitZ();
}

}  // namespace

NormalReport estimate_normals(PointCloud& cloud, const NormalOptions& options,
                              const KdTree* tree) {
  cloud.check_consistent();
  if (options.max_neighbors < 3) {
    throw InputError(fmt::format("normal estimation: max_neighbors must be at least 3, got {}",
                                 options.max_neighbors));
  }
  const std::size_t n = cloud.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (!cloud.positions[i].allFinite()) {
      throw InputError(fmt::format("normal estimation: point {} has a non-finite position "
                                   "(remove such points first: remove_non_finite)", i));
    }
  }
  std::optional<KdTree> own_tree;
  if (tree == nullptr) {
    own_tree.emplace(cloud.positions);
    tree = &*own_tree;
  } else if (tree->size() != n) {
    throw InputError(fmt::format("normal estimation: the kd-tree holds {} points but the cloud "
                                 "has {}", tree->size(), n));
  }

  const bool align_with_existing =
      options.orientation == NormalOrientation::AlongExisting && cloud.has_normals();
  const bool towards_viewpoint =
      options.orientation == NormalOrientation::TowardsViewpoint ||
      (options.orientation == NormalOrientation::AlongExisting && !cloud.has_normals());
  std::vector<Eigen::Vector3f> normals(n);
  std::vector<float> curvature(options.compute_curvature ? n : 0);
  tbb::combinable<std::size_t> degenerate_count(std::size_t{0});

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const auto& range) {
    std::vector<Neighbor> neighbors;
    std::size_t degenerate = 0;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Eigen::Vector3f& p = cloud.positions[i];
      if (options.radius > 0.f) {
        tree->hybrid(p, options.radius, options.max_neighbors, neighbors);
      } else {
        tree->knn(p, options.max_neighbors, neighbors);
      }
      LocalFrame frame = fit_plane(tree->points(), neighbors);
      Eigen::Vector3f normal = frame.normal;
      if (frame.degenerate) {
        ++degenerate;
        normal = towards(p, options.viewpoint);
      } else if (align_with_existing) {
        if (normal.dot(cloud.normals[i]) < 0.f) normal = -normal;
      } else if (towards_viewpoint) {
        if (normal.dot(options.viewpoint - p) < 0.f) normal = -normal;
      }
      normals[i] = normal;
      if (options.compute_curvature) curvature[i] = frame.curvature;
    }
    degenerate_count.local() += degenerate;
  });

  cloud.normals = std::move(normals);
  if (options.compute_curvature) {
    auto it = std::find_if(cloud.scalars.begin(), cloud.scalars.end(),
                           [](const ScalarField& f) { return f.name == "curvature"; });
    if (it == cloud.scalars.end()) {
      cloud.scalars.push_back(ScalarField{"curvature", std::move(curvature)});
    } else {
      it->values = std::move(curvature);
    }
  }
  NormalReport report;
  report.points = n;
  report.degenerate = degenerate_count.combine(std::plus<>());
  return report;
}

}  // namespace locard
