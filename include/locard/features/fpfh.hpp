#pragma once
// Fast Point Feature Histograms (Rusu, Blodow, Beetz 2009, "Fast Point Feature Histograms
// (FPFH) for 3D registration", ICRA), 33 bins, defined exactly as Open3D's
// compute_fpfh_feature so that descriptors are interchangeable with it:
//  - Neighbours: hybrid search, the at most `max_neighbors` nearest points within `radius`;
//    the point itself is excluded.
//  - Pair features (paper eq. 1-3, Darboux frame u = n_s, v = (p_t - p_s) x u, w = u x v, with
//    source s chosen as the point whose normal makes the smaller angle with the line):
//      alpha = v . n_t,  phi = u . (p_t - p_s) / d,  theta = atan2(w . n_t, u . n_t).
//  - SPFH(p): theta, alpha, phi each binned into 11 equal bins over [-pi, pi], [-1, 1], [-1, 1]
//    (bins 0-10, 11-21, 22-32), each pair adding 100 / (number of neighbours).
//  - FPFH(p) = SPFH(p) + normalise_100( sum_k SPFH(p_k) / d_k^2 )   (paper eq. 4, with
//    Open3D's weight 1/d^2 instead of 1/d, and each 11-bin block of the weighted sum scaled to
//    total 100); neighbours at distance 0 are skipped. A point without neighbours gets zeros.
// Parallel over points (oneTBB); results do not depend on the thread count.

#include <locard/core/point_cloud.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <span>
#include <vector>

namespace locard {

class KdTree;

using Fpfh = Eigen::Matrix<float, 33, 1>;  // 132 bytes, no alignment requirement

struct FpfhOptions {
  float radius = 0.25f;  // metres, not squared (typically 5x the voxel size)
  int max_neighbors = 100;
};

// One descriptor per point of `cloud`, which must have unit normals (InputError otherwise).
// `tree`, when given, must be built over exactly cloud.positions.
std::vector<Fpfh> compute_fpfh(const PointCloud& cloud, const FpfhOptions& options,
                               const KdTree* tree = nullptr);

// Descriptors of the points at `indices` only (e.g. ISS keypoints), in that order; SPFH is
// computed only where needed (the points and their neighbours), so this is much cheaper than
// compute_fpfh on the whole cloud. Values are identical to compute_fpfh's for those points.
std::vector<Fpfh> compute_fpfh(const PointCloud& cloud, std::span<const std::uint32_t> indices,
                               const FpfhOptions& options, const KdTree* tree = nullptr);

}  // namespace locard
