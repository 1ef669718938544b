#pragma once
// Intrinsic Shape Signatures keypoints (Zhong 2009, "Intrinsic shape signatures: A shape
// descriptor for 3D object recognition", section 2.1), in the unweighted form Open3D and PCL
// use by default:
//  1. For every point p_i with at least `min_neighbors` points within salient_radius (p_i
//     itself counted, as in Open3D), the scatter matrix of those points about their mean has
//     eigenvalues l1 >= l2 >= l3.
//  2. p_i is salient when l2 / l1 < gamma21 and l3 / l2 < gamma32 (no two-fold ambiguity of
//     its local frame); its saliency is l3.
//  3. A salient point is a keypoint when its saliency is the largest among the salient points
//     within non_max_radius (non-maximum suppression; ties go to the smaller index), and that
//     neighbourhood also holds at least `min_neighbors` points (p_i counted).
// Parallel over points; the result does not depend on the thread count.

#include <locard/core/point_cloud.hpp>

#include <cstdint>
#include <vector>

namespace locard {

class KdTree;

struct IssOptions {
  // Metres, not squared. 0 = automatic: 6x and 4x the cloud resolution (mean distance to the
  // nearest other point), as Open3D does.
  double salient_radius = 0.0;
  double non_max_radius = 0.0;
  double gamma21 = 0.975;
  double gamma32 = 0.975;
  int min_neighbors = 5;
};

// Indices of the keypoints in `cloud`, increasing. `tree`, when given, must be built over
// exactly cloud.positions. Positions must be finite (InputError otherwise).
std::vector<std::uint32_t> iss_keypoints(const PointCloud& cloud, const IssOptions& options,
                                         const KdTree* tree = nullptr);

// Mean distance from each point to its nearest other point (0 for fewer than 2 points).
double cloud_resolution(const PointCloud& cloud, const KdTree* tree = nullptr);

}  // namespace locard
