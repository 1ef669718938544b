#pragma once
// The Microsoft Kinect depth cameras as a simulator sees them: intrinsics, range, and the errors
// of a real depth image. docs/simulator.md gives the sources of every number.
//
// Kinect v2 (Kinect for Windows v2 / Xbox One), time of flight, the default:
//   axial  (Fankhauser et al., "Kinect v2 for Mobile Robot Navigation: Evaluation and
//          Modeling", ICAR 2015, indoor fit, z in metres, theta the incidence angle in radians)
//            sigma_z(z, theta) = 1.5 - 0.5 z + 0.3 z^2 + 0.1 z^1.5 theta^2 / (pi/2 - theta)^2 [mm]
//   lateral about 1.6 mm at the surface in the same study: each pixel's ray is jittered by
//          N(0, sigma_L f / z) pixels; flying pixels at depth edges; depth rounded to the mm.
//
// Kinect v1 (PrimeSense structured light):
//   axial  (Khoshelham & Elberink, Sensors 12(2) 2012; Nguyen, Izadi & Lovell, 3DIMPVT 2012)
//            sigma_z(z, theta) = 0.0012 + 0.0019 (z - 0.4)^2 + 0.0001 / sqrt(z) theta^2 / (pi/2 - theta)^2  [m]
//   lateral (Nguyen et al. 2012) sigma_L(theta) = 0.8 + 0.035 theta / (pi/2 - theta)  [px]
//   depth  from a disparity d = f b / z quantised to 1/8 px (f = 580 px, b = 7.5 cm), so
//          consecutive depth levels are dz = z^2 (1/8) / (f b) apart (2.9 mm at 1 m, 26 mm at 3 m).
//          The published sigma_z is the total random error of real depth images, quantisation
//          included: the model draws N(0, sigma_z^2 - dz^2 / 12) before quantising, so the
//          depth it writes has sigma_z (Sheppard's correction for the uniform rounding error).

#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/image.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/sim/scene.hpp>

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

// Default-constructed: the Kinect v2. KinectModel::kinect_v1() is the structured-light sensor;
// the fields that only one of them uses say so.
// What kind of depth camera the model is, as the readers' sequence traits name it (capture.json).
DepthSensorKind depth_sensor_kind(ScannerModel sensor);

struct KinectModel {
  ScannerModel sensor = ScannerModel::KinectV2;
  // Kinect v2: 512x424, 70.6 x 60 degrees. Kinect v1: 640x480, f = 525 px.
  CameraIntrinsics intrinsics = CameraIntrinsics::preset("kinect_v2");
  // The colour camera, taken as co-located with the depth camera (the real few-centimetre
  // baseline is what registration removes anyway). Kinect v2: 1920x1080, 84.1 x 53.8 degrees.
  CameraIntrinsics color_hd_intrinsics =
      CameraIntrinsics::from_fov(1920, 1080, 84.1, 53.8, "kinect_v2_color");
  double depth_scale = 1000.0;  // millimetres in the 16-bit PNGs
  double min_range_m = 0.5;
  double max_range_m = 4.5;

  bool axial_noise = true;
  // Lateral noise. Time of flight: a metric spread at the surface, lateral_sigma_m f / z pixels.
  // Structured light: lateral_base_px + lateral_grazing_px theta / (pi/2 - theta) pixels.
  double lateral_sigma_m = 0.0016;
  double lateral_base_px = 0.0;
  double lateral_grazing_px = 0.0;
  // Mixed pixels (time of flight): at a depth jump larger than flying_pixel_min_jump_m between
  // 4-neighbours, a pixel reports a blend of the two depths with this probability.
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
  // Structured light: depth from disparity f b / z, quantised to steps of disparity_step_px
  // (0: no disparity quantisation, as time of flight; depth is still rounded to 1/depth_scale).
  double disparity_step_px = 0.0;
  double disparity_focal_px = 580.0;
  double baseline_m = 0.075;

  static KinectModel kinect_v2();
  static KinectModel kinect_v1();
  static KinectModel of(ScannerModel sensor);
  // The Kinect v2 with every random effect off: exact depth (to the millimetre step) and exact
  // colour. Range limits still apply.
  static KinectModel exact();
  // This model (intrinsics, range, depth quantisation) with every random effect off.
  KinectModel without_noise() const;
  bool noisy() const;
  bool lateral_noise() const;

  // Axial standard deviation in metres of the depth written, for a surface at z metres seen at
  // `incidence` radians (clamped to the full-dropout angle, beyond which nothing is returned).
  double axial_sigma_m(double z_m, double incidence_rad) const;
  // Lateral standard deviation in pixels of a pixel's ray (per image axis).
  double lateral_sigma_px(double z_m, double incidence_rad = 0.0) const;
  double dropout_probability(double incidence_rad, double luminance) const;
  // Structured light: the depth level nearest z (disparity rounded to its step) and the spacing
  // of the levels there, z^2 step / (f b). Time of flight: z itself and 0.
  double quantised_depth_m(double z_m) const;
  double depth_step_m(double z_m) const;

  // The sensor's 16-bit depth image for an ideal depth map: flying pixels, dropouts, axial
  // noise, disparity quantisation, range limits and rounding, drawn from (seed, view) so the
  // result does not depend on threads.
  DepthImage measure(const IdealDepth& ideal, std::uint64_t seed, std::uint64_t view) const;
};

// The model's first name, from when it was the Kinect v2 only (its default still is).
using KinectV2Model = KinectModel;

}  // namespace locard::sim
