#include <locard/features/fpfh.hpp>

#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>

#include "features/fast_atan2.hpp"

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

namespace locard {

namespace {

constexpr int kBins = 11;
constexpr std::uint32_t kNoRow = std::numeric_limits<std::uint32_t>::max();

// Pair features of Rusu 2009, eq. 1-3, in Open3D's convention (see the header): returns
// (theta, alpha, phi); all zero when the points coincide or the frame is degenerate.
Eigen::Vector3f pair_features(const Eigen::Vector3f& p1, const Eigen::Vector3f& n1,
                              const Eigen::Vector3f& p2, const Eigen::Vector3f& n2) {
  Eigen::Vector3f dp = p2 - p1;
  const float d = dp.norm();
  if (d == 0.f) return Eigen::Vector3f::Zero();
  const float angle1 = n1.dot(dp) / d;
  const float angle2 = n2.dot(dp) / d;
  // The source is the point whose normal makes the smaller angle with the line:
  // acos|a1| > acos|a2|  <=>  |a1| < |a2|.
  const Eigen::Vector3f* u = &n1;
  const Eigen::Vector3f* target_normal = &n2;
  float phi = angle1;
  if (std::abs(angle1) < std::abs(angle2)) {
    u = &n2;
    target_normal = &n1;
    dp = -dp;
    phi = -angle2;
  }
  Eigen::Vector3f v = dp.cross(*u);
  const float v_norm = v.norm();
  if (v_norm == 0.f) return Eigen::Vector3f::Zero();
  v /= v_norm;
  const Eigen::Vector3f w = u->cross(v);
  const float alpha = v.dot(*target_normal);
  const float theta = detail::fast_atan2(w.dot(*target_normal), u->dot(*target_normal));
  return {theta, alpha, phi};
}

int bin_of(float value_0_to_1) {
  const int bin = static_cast<int>(std::floor(kBins * value_0_to_1));
  return bin < 0 ? 0 : (bin >= kBins ? kBins - 1 : bin);
}

// SPFH of every row point: 11 bins each of theta in [-pi, pi], alpha and phi in [-1, 1], each
// pair adding 100 / (number of neighbours other than the point itself).
std::vector<Fpfh> compute_spfh(const PointCloud& cloud, std::span<const std::uint32_t> rows,
                               const NeighborLists& neighbors) {
  std::vector<Fpfh> spfh(rows.size(), Fpfh::Zero());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rows.size(), 128), [&](const auto& range) {
    for (std::size_t r = range.begin(); r != range.end(); ++r) {
      const std::uint32_t i = rows[r];
      const auto list = neighbors[r];
      std::size_t others = 0;
      for (const Neighbor& nb : list) others += nb.index != i;
      if (others == 0) continue;
      const float increment = 100.f / static_cast<float>(others);
      Fpfh& histogram = spfh[r];
      const Eigen::Vector3f& p = cloud.positions[i];
      const Eigen::Vector3f& n = cloud.normals[i];
      for (const Neighbor& nb : list) {
        if (nb.index == i) continue;
        const Eigen::Vector3f f =
            pair_features(p, n, cloud.positions[nb.index], cloud.normals[nb.index]);
        histogram[bin_of((f[0] + std::numbers::pi_v<float>) / (2.f * std::numbers::pi_v<float>))] +=
            increment;
        histogram[kBins + bin_of((f[1] + 1.f) * 0.5f)] += increment;
        histogram[2 * kBins + bin_of((f[2] + 1.f) * 0.5f)] += increment;
      }
    }
  });
  return spfh;
}

// FPFH(p) = SPFH(p) + normalise_100(sum_k SPFH(p_k) / d_k^2), Rusu 2009 eq. 4 with Open3D's
// weights (header).
Fpfh combine(std::uint32_t i, std::span<const Neighbor> list, const std::vector<Fpfh>& spfh,
             const std::vector<std::uint32_t>& row_of) {
  Fpfh weighted = Fpfh::Zero();
  bool any_other = false;
  for (const Neighbor& nb : list) {
    if (nb.index == i) continue;
    any_other = true;
    if (nb.squared_distance == 0.f) continue;
    weighted += spfh[row_of[nb.index]] * (1.f / nb.squared_distance);
  }
  if (!any_other) return Fpfh::Zero();
  for (int block = 0; block < 3; ++block) {
    const float sum = weighted.segment<kBins>(block * kBins).sum();
    if (sum != 0.f) weighted.segment<kBins>(block * kBins) *= 100.f / sum;
  }
  return weighted + spfh[row_of[i]];
}

void check_input(const PointCloud& cloud, const FpfhOptions& options, const KdTree* tree) {
  if (!(options.radius > 0.f) || !std::isfinite(options.radius) || options.max_neighbors < 2) {
    throw InputError(fmt::format("FPFH: expected radius > 0 and max_neighbors >= 2, got radius "
                                 "{}, max_neighbors {}", options.radius, options.max_neighbors));
  }
  if (cloud.normals.size() != cloud.size()) {
    throw InputError(fmt::format("FPFH: the cloud has {} points but {} normals (estimate normals "
                                 "first: estimate_normals)", cloud.size(), cloud.normals.size()));
  }
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.positions[i].allFinite() || !cloud.normals[i].allFinite()) {
      throw InputError(fmt::format("FPFH: point {} has a non-finite position or normal", i));
    }
  }
  if (tree != nullptr && tree->size() != cloud.size()) {
    throw InputError(fmt::format("FPFH: the kd-tree holds {} points but the cloud has {}",
                                 tree->size(), cloud.size()));
  }
}

std::vector<Eigen::Vector3f> positions_of(const PointCloud& cloud,
                                          std::span<const std::uint32_t> indices) {
  std::vector<Eigen::Vector3f> out(indices.size());
  for (std::size_t k = 0; k < indices.size(); ++k) out[k] = cloud.positions[indices[k]];
  return out;
}

}  // namespace

std::vector<Fpfh> compute_fpfh(const PointCloud& cloud, const FpfhOptions& options,
                               const KdTree* tree) {
  std::vector<std::uint32_t> all(cloud.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<std::uint32_t>(i);
  return compute_fpfh(cloud, all, options, tree);
}

std::vector<Fpfh> compute_fpfh(const PointCloud& cloud, std::span<const std::uint32_t> indices,
                               const FpfhOptions& options, const KdTree* tree) {
  check_input(cloud, options, tree);
  for (std::uint32_t i : indices) {
    if (i >= cloud.size()) {
      throw InputError(fmt::format("FPFH: point index {} is out of range (the cloud has {} "
                                   "points)", i, cloud.size()));
    }
  }
  if (indices.empty()) return {};
  std::optional<KdTree> own;
  if (tree == nullptr) tree = &own.emplace(cloud.positions);

  // Rows: every point whose SPFH is needed (the queries and their neighbours), increasing.
  // One hybrid search per row serves both the SPFH and the FPFH pass. (Like Open3D's hybrid
  // search, max_neighbors counts the point itself.)
  std::vector<std::uint32_t> rows;
  NeighborLists neighbors;
  bool all_points = indices.size() == cloud.size();
  for (std::size_t q = 0; all_points && q < indices.size(); ++q) all_points = indices[q] == q;
  if (all_points) {
    rows.assign(indices.begin(), indices.end());
    neighbors = tree->hybrid_batch(cloud.positions, options.radius, options.max_neighbors);
  } else {
    const NeighborLists query_neighbors =
        tree->hybrid_batch(positions_of(cloud, indices), options.radius, options.max_neighbors);
    std::vector<std::uint8_t> needed(cloud.size(), 0);
    for (std::uint32_t i : indices) needed[i] = 1;
    for (const Neighbor& nb : query_neighbors.neighbors) needed[nb.index] = 1;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (needed[i]) rows.push_back(static_cast<std::uint32_t>(i));
    }
    neighbors =
        tree->hybrid_batch(positions_of(cloud, rows), options.radius, options.max_neighbors);
  }
  std::vector<std::uint32_t> row_of(cloud.size(), kNoRow);
  for (std::size_t r = 0; r < rows.size(); ++r) row_of[rows[r]] = static_cast<std::uint32_t>(r);
  const std::vector<Fpfh> spfh = compute_spfh(cloud, rows, neighbors);

  std::vector<Fpfh> descriptors(indices.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, indices.size(), 128),
                    [&](const auto& range) {
                      for (std::size_t q = range.begin(); q != range.end(); ++q) {
                        const std::uint32_t i = indices[q];
                        descriptors[q] = combine(i, neighbors[row_of[i]], spfh, row_of);
                      }
                    });
  return descriptors;
}

}  // namespace locard
