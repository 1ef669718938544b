// Colour as a registration term (Park, Zhou, Koltun, "Colored Point Cloud Registration
// Revisited", ICCV 2017): a point's intensity, and its gradient over the surface's tangent plane
// so that a colour residual has a direction to push along. Used by coloured ICP (icp.hpp) and
// by the joint refinement of a tripod turn (alignment).
#pragma once

#include <locard/core/kdtree.hpp>
#include <locard/core/point_cloud.hpp>

#include <Eigen/Core>

#include <span>
#include <vector>

namespace locard {

// A colour residual's weight against a point-to-plane one, squared residuals summed: Park et
// al.'s lambda_geometric = 0.968 (Open3D's default), intensity in [0, 1] and distances in metres.
inline constexpr double kColorTermWeight = (1.0 - 0.968) / 0.968;

// Intensity in [0, 1]: (r + g + b) / (3 * 255).
float intensity_of(const Rgb8& c);
// Every colour's intensity, in order.
std::vector<float> intensities_of(std::span<const Rgb8> colors);

// Colour gradient d_t of every point t of `tree` (Park et al. eq. 10, as Open3D's
// ComputeColorGradient): least squares over t's neighbours p_j (the at most max_neighbors
// within radius), projected onto t's tangent plane, p'_j = p_j - n (n . (p_j - t)):
//   minimise sum_j (d . (p'_j - t) - (C(p_j) - C(t)))^2 + ((k - 1) n . d)^2,
// the last term enforcing d . n = 0. Fewer than 4 neighbours or a singular system give d = 0
// (the point then constrains only geometry). normals and intensity are per tree point.
// standard_error, when given, receives each gradient's standard error (per metre, the root of
// the trace of its covariance sigma^2 (A^T A)^-1, sigma^2 the fit's residual variance; infinite
// where d = 0): how much of |d| the colour's noise alone could make.
std::vector<Eigen::Vector3f> color_gradients(const KdTree& tree,
                                             std::span<const Eigen::Vector3f> normals,
                                             std::span<const float> intensity, double radius,
                                             int max_neighbors,
                                             std::vector<float>* standard_error = nullptr);

}  // namespace locard
