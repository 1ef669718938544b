#pragma once
// The Microsoft Kinect v2 (Kinect for Windows v2 / Xbox One) time-of-flight sensor as a
// simulator sees it: intrinsics, range, and the errors of a real depth image. docs/simulator.md
// gives the sources of every number.
//
// Axial noise (Fankhauser et al., "Kinect v2 for Mobile Robot Navigation: Evaluation and
// Modeling", ICAR 2015, indoor fit, z in metres, theta the incidence angle in radians):
//   sigma_z(z, theta) = 1.5 - 0.5 z + 0.3 z^2 + 0.1 z^1.5 theta^2 / (pi/2 - theta)^2   [mm]
// Lateral noise: about 1.6 mm at the surface in the same study, applied by jittering each
// pixel's ray by N(0, sigma_L f / z) pixels.

#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/image.hpp>

#include <cstdint>
#include <vector>

namespace locard::sim {

// What a perfect sensor would measure at every depth pixel, row-major.
struct IdealDepth {
  int width = 0;
  int height = 0;
  std::vector<float> z;          // z-depth in metres along the optical axis; 0 = no surface
  std::vector<float> incidence;  // angle between the ray and the surface normal (radians)
  std::vector<float> luminance;  // albedo of the surface, 0..1 (dark surfaces return no echo)

  IdealDepth() = default;
  IdealDepth(int w, int h)
      : width(w), height(h), z(static_cast<std::size_t>(w) * h, 0.0f),
        incidence(z.size(), 0.0f), luminance(z.size(), 1.0f) {}
};

struct KinectV2Model {
  // 512x424, 70.6 x 60 degrees.
  CameraIntrinsics intrinsics = CameraIntrinsics::preset("kinect_v2");
  // The 1920x1080 colour camera (84.1 x 53.8 degrees), taken as co-located with the depth
  // camera: the real 5 cm baseline is what registration removes anyway.
  CameraIntrinsics color_hd_intrinsics =
      CameraIntrinsics::from_fov(1920, 1080, 84.1, 53.8, "kinect_v2_color");
  double depth_scale = 1000.0;  // millimetres in the 16-bit PNGs
  double min_range_m = 0.5;
  double max_range_m = 4.5;

  bool axial_noise = true;
  double lateral_sigma_m = 0.0016;
  // Mixed pixels: at a depth jump larger than flying_pixel_min_jump_m between 4-neighbours, a
  // pixel reports a blend of the two depths with this probability.
  double flying_pixel_probability = 0.5;
  double flying_pixel_min_jump_m = 0.05;
  // No echo: probability rises linearly from 0 to 1 between the start and full angles, and as
  // the albedo's luminance falls from the start to the full value.
  bool dropouts = true;
  double grazing_dropout_start_deg = 75.0;
  double grazing_dropout_full_deg = 87.0;
  double dark_dropout_start_luminance = 0.08;
  double dark_dropout_full_luminance = 0.02;
  double color_noise_sigma = 1.5;  // 8-bit levels

  // The same sensor with every random effect off: exact depth (to the millimetre step) and
  // exact colour. Range limits still apply.
  static KinectV2Model exact();
  // This model (intrinsics, range) with every random effect off.
  KinectV2Model without_noise() const;
  bool noisy() const;

  // Axial standard deviation in metres for a surface at z metres seen at `incidence` radians
  // (clamped to the full-dropout angle, beyond which nothing is returned anyway).
  double axial_sigma_m(double z_m, double incidence_rad) const;
  double lateral_sigma_px(double z_m) const;
  double dropout_probability(double incidence_rad, double luminance) const;

  // The sensor's 16-bit depth image for an ideal depth map: flying pixels, dropouts, axial
  // noise, range limits and quantisation, drawn from (seed, view) so the result does not
  // depend on threads.
  DepthImage measure(const IdealDepth& ideal, std::uint64_t seed, std::uint64_t view) const;
};

}  // namespace locard::sim
