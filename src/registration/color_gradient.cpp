#include <locard/registration/color_gradient.hpp>

#include <Eigen/Cholesky>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

namespace locard {

float intensity_of(const Rgb8& c) {
  return (static_cast<float>(c.r) + static_cast<float>(c.g) + static_cast<float>(c.b)) /
         (3.f * 255.f);
}

std::vector<float> intensities_of(std::span<const Rgb8> colors) {
  std::vector<float> out;
  out.reserve(colors.size());
  for (const Rgb8& c : colors) out.push_back(intensity_of(c));
  return out;
}

std::vector<Eigen::Vector3f> color_gradients(const KdTree& tree,
                                             std::span<const Eigen::Vector3f> normals,
                                             std::span<const float> intensity, double radius,
                                             int max_neighbors, std::vector<float>* standard_error) {
  const auto& pts = tree.points();
  std::vector<Eigen::Vector3f> gradient(pts.size(), Eigen::Vector3f::Zero());
  if (standard_error) standard_error->assign(pts.size(), std::numeric_limits<float>::infinity());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pts.size(), 256), [&](const auto& r) {
    std::vector<Neighbor> nbrs;
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      tree.hybrid(pts[i], static_cast<float>(radius), max_neighbors, nbrs);
      if (nbrs.size() < 4) continue;
      const Eigen::Vector3d p = pts[i].cast<double>();
      const Eigen::Vector3d n = normals[i].cast<double>();
      const double ci = intensity[i];
      Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
      Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
      for (const Neighbor& nb : nbrs) {
        const Eigen::Vector3d pj = pts[nb.index].cast<double>();
        const Eigen::Vector3d a = pj - n * n.dot(pj - p) - p;  // p'_j - t
        const double b = intensity[nb.index] - ci;
        AtA.noalias() += a * a.transpose();
        Atb += a * b;
      }
      const Eigen::Vector3d c = static_cast<double>(nbrs.size() - 1) * n;  // constraint row
      AtA.noalias() += c * c.transpose();
      const Eigen::LDLT<Eigen::Matrix3d> ldlt(AtA);
      if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) continue;
      const Eigen::Vector3d d = ldlt.solve(Atb);
      if (!d.allFinite()) continue;
      gradient[i] = d.cast<float>();
      if (!standard_error || nbrs.size() < 5) continue;
      double rss = 0.0;
      for (const Neighbor& nb : nbrs) {
        const Eigen::Vector3d pj = pts[nb.index].cast<double>();
        const double e = d.dot(pj - n * n.dot(pj - p) - p) - (intensity[nb.index] - ci);
        rss += e * e;
      }
      const double variance = rss / static_cast<double>(nbrs.size() - 3);
      const double trace = ldlt.solve(Eigen::Matrix3d::Identity()).trace();
      (*standard_error)[i] = static_cast<float>(std::sqrt(variance * trace));
    }
  });
  return gradient;
}

}  // namespace locard
