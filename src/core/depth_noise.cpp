// Axial depth noise models (see depth_noise.hpp for the sources).
#include <locard/core/depth_noise.hpp>

#include <algorithm>
#include <cmath>

namespace locard {
namespace {

// theta^2 / (pi/2 - theta)^2: both models' growth towards grazing incidence.
double grazing_term(double incidence_rad, double max_incidence_rad) {
  const double theta = std::clamp(incidence_rad, 0.0, max_incidence_rad);
  const double rest = 0.5 * std::numbers::pi - theta;
  return theta * theta / (rest * rest);
}

}  // namespace

double time_of_flight_axial_sigma_m(double z_m, double incidence_rad, double max_incidence_rad) {
  const double grazing = grazing_term(incidence_rad, max_incidence_rad);
  const double sigma_mm = 1.5 - 0.5 * z_m + 0.3 * z_m * z_m + 0.1 * z_m * std::sqrt(z_m) * grazing;
  return 1e-3 * sigma_mm;
}

double structured_light_axial_sigma_m(double z_m, double incidence_rad, double max_incidence_rad) {
  const double grazing = grazing_term(incidence_rad, max_incidence_rad);
  const double d = z_m - 0.4;
  return 0.0012 + 0.0019 * d * d + 0.0001 / std::sqrt(std::max(z_m, 1e-3)) * grazing;
}

}  // namespace locard
