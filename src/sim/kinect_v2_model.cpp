#include <locard/sim/kinect_v2_model.hpp>

#include <locard/core/error.hpp>
#include <locard/sim/counter_rng.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace locard::sim {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

double ramp(double x, double start, double full) {
  if (full == start) return x >= full ? 1.0 : 0.0;
  return std::clamp((x - start) / (full - start), 0.0, 1.0);
}

}  // namespace

KinectV2Model KinectV2Model::exact() { return KinectV2Model{}.without_noise(); }

KinectV2Model KinectV2Model::without_noise() const {
  KinectV2Model model = *this;
  model.axial_noise = false;
  model.lateral_sigma_m = 0.0;
  model.flying_pixel_probability = 0.0;
  model.dropouts = false;
  model.color_noise_sigma = 0.0;
  return model;
}

bool KinectV2Model::noisy() const {
  return axial_noise || lateral_sigma_m > 0.0 || flying_pixel_probability > 0.0 || dropouts ||
         color_noise_sigma > 0.0;
}

double KinectV2Model::axial_sigma_m(double z_m, double incidence_rad) const {
  // Fankhauser et al. 2015, eq. for sigma_z (indoor): millimetres for z in metres.
  const double theta = std::clamp(incidence_rad, 0.0, grazing_dropout_full_deg * kDegToRad);
  const double rest = 0.5 * std::numbers::pi - theta;
  const double grazing = theta * theta / (rest * rest);
  const double sigma_mm = 1.5 - 0.5 * z_m + 0.3 * z_m * z_m + 0.1 * z_m * std::sqrt(z_m) * grazing;
  return 1e-3 * sigma_mm;
}

double KinectV2Model::lateral_sigma_px(double z_m) const {
  // A metric spread at the surface covers fewer pixels the farther away it is.
  return z_m > 0.0 ? lateral_sigma_m * intrinsics.fx / z_m : 0.0;
}

double KinectV2Model::dropout_probability(double incidence_rad, double luminance) const {
  if (!dropouts) return 0.0;
  const double grazing = ramp(incidence_rad / kDegToRad, grazing_dropout_start_deg,
                              grazing_dropout_full_deg);
  // Falling luminance raises the probability: ramp on the negated value.
  const double dark =
      ramp(-luminance, -dark_dropout_start_luminance, -dark_dropout_full_luminance);
  return 1.0 - (1.0 - grazing) * (1.0 - dark);
}

DepthImage KinectV2Model::measure(const IdealDepth& ideal, std::uint64_t seed,
                                  std::uint64_t view) const {
  const int w = ideal.width;
  const int h = ideal.height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  if (ideal.z.size() != n || ideal.incidence.size() != n || ideal.luminance.size() != n)
    throw Error("KinectV2Model::measure: ideal depth arrays do not match its size");
  DepthImage depth(w, h, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v) {
      for (int u = 0; u < w; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * w + u;
        double z = ideal.z[i];
        if (z <= 0.0) continue;
        CounterRng rng(seed, RngStream::DepthNoise, view, i);
        // Always draw the same numbers in the same order: a pixel's noise must not depend on
        // which effects are switched on before it.
        const double u_drop = rng.uniform();
        const double u_fly = rng.uniform();
        const double w_fly = rng.uniform();
        const double gauss = rng.normal();

        if (u_drop < dropout_probability(ideal.incidence[i], ideal.luminance[i])) continue;

        if (flying_pixel_probability > 0.0 && u_fly < flying_pixel_probability) {
          // The neighbour across the largest jump: a time-of-flight pixel straddling an edge
          // integrates light from both surfaces and reports a depth in between.
          double partner = z;
          double largest = flying_pixel_min_jump_m;
          const int du[4] = {-1, 1, 0, 0};
          const int dv[4] = {0, 0, -1, 1};
          for (int k = 0; k < 4; ++k) {
            const int uu = u + du[k], vv = v + dv[k];
            if (uu < 0 || vv < 0 || uu >= w || vv >= h) continue;
            const double zn = ideal.z[static_cast<std::size_t>(vv) * w + uu];
            if (zn > 0.0 && std::abs(zn - z) > largest) {
              largest = std::abs(zn - z);
              partner = zn;
            }
          }
          z += w_fly * (partner - z);
        }

        if (axial_noise) z += gauss * axial_sigma_m(z, ideal.incidence[i]);
        if (z < min_range_m || z > max_range_m) continue;
        // z > 0 here: adding 0.5 and truncating rounds to nearest.
        depth.at(u, v) = static_cast<std::uint16_t>(std::min(z * depth_scale + 0.5, 65535.0));
      }
    }
  });
  return depth;
}

}  // namespace locard::sim
