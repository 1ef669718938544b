#pragma once
// Robust kernels for iteratively reweighted least squares (IRLS).
//
// ICP minimises sum_i rho(r_i) over residuals r_i. Each Gauss-Newton step solves the weighted
// problem sum_i w(r_i) r_i^2 / 2 with w(r) = rho'(r) / r evaluated at the current residuals
// (Zhang 1997, "Parameter estimation techniques: a tutorial", section 3; Babin et al. 2019,
// "Analysis of robust functions for registration algorithms"). With scale k > 0:
//
//   None           rho = r^2 / 2                                  w = 1
//   Huber          rho = r^2 / 2             (|r| <= k)           w = 1
//                  rho = k (|r| - k / 2)     (|r| >  k)           w = k / |r|
//   Tukey          rho = k^2/6 (1 - (1 - (r/k)^2)^3)  (|r| <= k)  w = (1 - (r/k)^2)^2
//                  rho = k^2 / 6             (|r| >  k)           w = 0
//   GemanMcClure   rho = (k^2 r^2 / 2) / (k^2 + r^2)              w = k^4 / (k^2 + r^2)^2
//
// Every weight is 1 at r = 0 and falls off beyond about k, so k is "the residual above which
// a correspondence starts to count as an outlier", in the residual's units (metres for
// geometric residuals).

#include <cmath>
#include <optional>
#include <string>
#include <string_view>

namespace locard {

enum class RobustKernelType { None, Huber, Tukey, GemanMcClure };

struct RobustKernel {
  RobustKernelType type = RobustKernelType::None;
  double scale = 0.0;  // k, in the residual's units; must be > 0 unless type is None

  // IRLS weight w(r) (see the table above). Inline: it runs once per correspondence.
  double weight(double r) const {
    switch (type) {
      case RobustKernelType::None:
        return 1.0;
      case RobustKernelType::Huber: {
        const double a = std::abs(r);
        return a <= scale ? 1.0 : scale / a;
      }
      case RobustKernelType::Tukey: {
        const double u = r / scale;
        if (u * u >= 1.0) return 0.0;
        const double v = 1.0 - u * u;
        return v * v;
      }
      case RobustKernelType::GemanMcClure: {
        const double k2 = scale * scale;
        const double d = k2 + r * r;
        return (k2 * k2) / (d * d);
      }
    }
    return 1.0;
  }
};

// "none", "huber", "tukey", "geman-mcclure" (also "gm").
std::string_view to_string(RobustKernelType type);
std::optional<RobustKernelType> parse_robust_kernel(std::string_view name);

}  // namespace locard
