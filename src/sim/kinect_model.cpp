#include <locard/sim/kinect_model.hpp>

#include <locard/core/depth_noise.hpp>
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

// The Gaussian drawn before disparity quantisation: what is left of sigma_z once the uniform
// rounding error of the levels (variance dz^2 / 12) is taken out, so that the depth written has
// sigma_z. Without quantisation this is sigma_z itself.
double noise_before_quantisation_m(const KinectModel& m, double z_m, double incidence_rad) {
  const double sigma = m.axial_sigma_m(z_m, incidence_rad);
  if (m.disparity_step_px <= 0.0) return sigma;
  const double step = m.depth_step_m(z_m);
  return std::sqrt(std::max(sigma * sigma - step * step / 12.0, 0.0));
}

}  // namespace

KinectModel KinectModel::kinect_v2() { return KinectModel{}; }

KinectModel KinectModel::kinect_v1() {
  KinectModel m;
  m.sensor = ScannerModel::KinectV1;
  m.intrinsics = CameraIntrinsics::preset("kinect_v1");  // 640x480, fx = fy = 525
  // The 1280x960 colour mode, 62 x 48.6 degrees.
  m.color_hd_intrinsics = CameraIntrinsics::from_fov(1280, 960, 62.0, 48.6, "kinect_v1_color");
  m.min_range_m = 0.5;
  m.max_range_m = 4.0;
  // Nguyen et al. 2012, lateral fit in pixels.
  m.lateral_sigma_m = 0.0;
  m.lateral_base_px = 0.8;
  m.lateral_grazing_px = 0.035;
  // A projected pattern does not mix two depths at an edge: the pixel matches one or neither.
  m.flying_pixel_probability = 0.0;
  // The pattern's dots smear on steep surfaces and the correlation window fails earlier than
  // a time-of-flight echo (noise already triples by 70 degrees in Nguyen et al.).
  m.grazing_dropout_start_deg = 70.0;
  m.grazing_dropout_full_deg = 85.0;
  m.disparity_step_px = 0.125;
  m.disparity_focal_px = 580.0;
  m.baseline_m = 0.075;
  return m;
}

DepthSensorKind depth_sensor_kind(ScannerModel sensor) {
  switch (sensor) {
    case ScannerModel::KinectV2: return DepthSensorKind::TimeOfFlight;
    case ScannerModel::KinectV1: return DepthSensorKind::StructuredLight;
  }
  return DepthSensorKind::Unknown;
}

KinectModel KinectModel::of(ScannerModel sensor) {
  switch (sensor) {
    case ScannerModel::KinectV2: return kinect_v2();
    case ScannerModel::KinectV1: return kinect_v1();
  }
  return kinect_v2();
}

KinectModel KinectModel::exact() { return KinectModel{}.without_noise(); }

KinectModel KinectModel::without_noise() const {
  KinectModel model = *this;
  model.axial_noise = false;
  model.lateral_sigma_m = 0.0;
  model.lateral_base_px = 0.0;
  model.lateral_grazing_px = 0.0;
  model.flying_pixel_probability = 0.0;
  model.dropouts = false;
  model.color_noise_sigma = 0.0;
  return model;
}

bool KinectModel::noisy() const {
  return axial_noise || lateral_noise() || flying_pixel_probability > 0.0 || dropouts ||
         color_noise_sigma > 0.0;
}

bool KinectModel::lateral_noise() const {
  return lateral_sigma_m > 0.0 || lateral_base_px > 0.0 || lateral_grazing_px > 0.0;
}

double KinectModel::axial_sigma_m(double z_m, double incidence_rad) const {
  const double max_incidence = grazing_dropout_full_deg * kDegToRad;
  switch (sensor) {
    case ScannerModel::KinectV2: return time_of_flight_axial_sigma_m(z_m, incidence_rad, max_incidence);
    case ScannerModel::KinectV1: return structured_light_axial_sigma_m(z_m, incidence_rad, max_incidence);
  }
  return 0.0;
}

double KinectModel::lateral_sigma_px(double z_m, double incidence_rad) const {
  // Time of flight: a metric spread at the surface covers fewer pixels the farther away it is.
  double sigma = z_m > 0.0 ? lateral_sigma_m * intrinsics.fx / z_m : 0.0;
  if (lateral_base_px > 0.0 || lateral_grazing_px > 0.0) {
    // Structured light (Nguyen et al. 2012): pixels, growing towards grazing incidence.
    const double theta = std::clamp(incidence_rad, 0.0, grazing_dropout_full_deg * kDegToRad);
    sigma += lateral_base_px + lateral_grazing_px * theta / (0.5 * std::numbers::pi - theta);
  }
  return sigma;
}

double KinectModel::dropout_probability(double incidence_rad, double luminance) const {
  if (!dropouts) return 0.0;
  const double grazing = ramp(incidence_rad / kDegToRad, grazing_dropout_start_deg,
                              grazing_dropout_full_deg);
  // Falling luminance raises the probability: ramp on the negated value.
  const double dark =
      ramp(-luminance, -dark_dropout_start_luminance, -dark_dropout_full_luminance);
  return 1.0 - (1.0 - grazing) * (1.0 - dark);
}

double KinectModel::quantised_depth_m(double z_m) const {
  if (disparity_step_px <= 0.0 || z_m <= 0.0) return z_m;
  // d = f b / z in pixels, rounded to the nearest step, back to depth.
  const double fb = disparity_focal_px * baseline_m;
  const double steps = std::round(fb / z_m / disparity_step_px);
  return steps > 0.0 ? fb / (steps * disparity_step_px) : 0.0;
}

double KinectModel::depth_step_m(double z_m) const {
  if (disparity_step_px <= 0.0) return 0.0;
  return z_m * z_m * disparity_step_px / (disparity_focal_px * baseline_m);
}

DepthImage KinectModel::measure(const IdealDepth& ideal, std::uint64_t seed,
                                  std::uint64_t view) const {
  const int w = ideal.width;
  const int h = ideal.height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  if (ideal.z.size() != n || ideal.incidence.size() != n || ideal.luminance.size() != n)
    throw Error("KinectModel::measure: ideal depth arrays do not match its size");
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

        if (axial_noise) z += gauss * noise_before_quantisation_m(*this, z, ideal.incidence[i]);
        z = quantised_depth_m(z);
        if (z < min_range_m || z > max_range_m) continue;
        // z > 0 here: adding 0.5 and truncating rounds to nearest.
        depth.at(u, v) = static_cast<std::uint16_t>(std::min(z * depth_scale + 0.5, 65535.0));
      }
    }
  });
  return depth;
}

}  // namespace locard::sim
