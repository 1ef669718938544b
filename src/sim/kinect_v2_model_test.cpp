// The Kinect v2 error model: its published axial sigma, noise statistics over many pixels
// within 10 % of that sigma, dropouts, flying pixels, range limits, and determinism.
#include <locard/sim/kinect_v2_model.hpp>
#include <locard/sim/scene_mesh.hpp>
#include <locard/sim/view_renderer.hpp>

#include "sim/sensor_test_util.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <tbb/global_control.h>

#include <array>
#include <cmath>
#include <numbers>

namespace locard::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

IdealDepth constant_depth(double z, double incidence_rad, double luminance = 0.8) {
  IdealDepth ideal(512, 424);
  std::fill(ideal.z.begin(), ideal.z.end(), static_cast<float>(z));
  std::fill(ideal.incidence.begin(), ideal.incidence.end(), static_cast<float>(incidence_rad));
  std::fill(ideal.luminance.begin(), ideal.luminance.end(), static_cast<float>(luminance));
  return ideal;
}

using test::plane_through;

struct Stats {
  double mean = 0.0;
  double stddev = 0.0;
  std::size_t valid = 0;
};

// Statistics of (measured - reference) in millimetres over valid pixels.
Stats residual_stats(const DepthImage& depth, const IdealDepth& reference) {
  double sum = 0.0, sum2 = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < depth.data().size(); ++i) {
    if (depth.data()[i] == 0) continue;
    const double r = depth.data()[i] - 1000.0 * reference.z[i];
    sum += r;
    sum2 += r * r;
    ++n;
  }
  Stats s;
  s.valid = n;
  s.mean = sum / n;
  s.stddev = std::sqrt(sum2 / n - s.mean * s.mean);
  return s;
}

TEST(KinectV2Model, AxialSigmaFollowsFankhauser2015) {
  const KinectV2Model m;
  // sigma_z = 1.5 - 0.5 z + 0.3 z^2 (+ angle term) millimetres.
  EXPECT_NEAR(m.axial_sigma_m(1.0, 0.0), 1.3e-3, 1e-12);
  EXPECT_NEAR(m.axial_sigma_m(2.0, 0.0), 1.7e-3, 1e-12);
  EXPECT_NEAR(m.axial_sigma_m(4.0, 0.0), 4.3e-3, 1e-12);
  // 60 degrees: theta^2 / (pi/2 - theta)^2 = (pi/3)^2 / (pi/6)^2 = 4.
  EXPECT_NEAR(m.axial_sigma_m(1.0, 60 * kDeg), 1.3e-3 + 0.4e-3, 1e-12);
  EXPECT_NEAR(m.axial_sigma_m(4.0, 60 * kDeg), 4.3e-3 + 0.1e-3 * 8.0 * 4.0, 1e-12);
  // Grows with distance beyond 1 m and with incidence.
  EXPECT_LT(m.axial_sigma_m(1.5, 0.0), m.axial_sigma_m(3.0, 0.0));
  EXPECT_LT(m.axial_sigma_m(2.0, 30 * kDeg), m.axial_sigma_m(2.0, 70 * kDeg));
  // Clamped at the full-dropout angle instead of diverging at 90 degrees.
  EXPECT_TRUE(std::isfinite(m.axial_sigma_m(2.0, 90 * kDeg)));
  EXPECT_EQ(m.axial_sigma_m(2.0, 90 * kDeg), m.axial_sigma_m(2.0, 87 * kDeg));
}

TEST(KinectV2Model, NoiseStatisticsMatchModelSigmaWithinTenPercent) {
  const KinectV2Model m;
  struct Case {
    double z, theta_deg;
  };
  for (const Case c : {Case{0.8, 0}, Case{1.0, 0}, Case{2.0, 0}, Case{3.0, 0}, Case{4.2, 0},
                       Case{1.5, 45}, Case{2.0, 60}, Case{3.0, 70}}) {
    const IdealDepth ideal = constant_depth(c.z, c.theta_deg * kDeg);
    const DepthImage depth = m.measure(ideal, 42, 7);
    const Stats s = residual_stats(depth, ideal);
    ASSERT_EQ(s.valid, depth.pixel_count()) << "no dropouts expected below 75 degrees";
    const double sigma_mm = 1000.0 * m.axial_sigma_m(c.z, c.theta_deg * kDeg);
    // Rounding to whole millimetres adds a uniform error of variance 1/12 mm^2.
    const double expected = std::sqrt(sigma_mm * sigma_mm + 1.0 / 12.0);
    EXPECT_NEAR(s.stddev, expected, 0.10 * expected) << "z " << c.z << " theta " << c.theta_deg;
    // 217k samples: the actual agreement is far tighter than the 10 % the issue asks for.
    EXPECT_NEAR(s.stddev, expected, 0.02 * expected) << "z " << c.z << " theta " << c.theta_deg;
    EXPECT_NEAR(s.mean, 0.0, 0.05) << "unbiased at z " << c.z;
  }
}

TEST(KinectV2Model, RenderedPlaneNoiseMatchesPerPixelSigma) {
  // Through the renderer: a wall at 2.5 m seen head-on (incidence grows towards the image
  // corners) and a floor-like plane at 60 degrees, with every effect of the default model on.
  // The residual variance over all valid pixels must match the mean predicted variance.
  struct Case {
    double tilt_deg;
    double lateral_sigma_m;  // lateral noise moves hits along a slanted plane: off for it
  };
  for (const Case c : {Case{0.0, 0.0016}, Case{60.0, 0.0}}) {
    KinectV2Model m;
    m.lateral_sigma_m = c.lateral_sigma_m;
    const Eigen::Vector3d n =
        Eigen::AngleAxisd(c.tilt_deg * kDeg, Eigen::Vector3d::UnitX()) * Eigen::Vector3d(0, 0, -1);
    const ViewRenderer renderer(plane_through({0, 0, 2.5}, n));
    const IdealDepth exact = renderer.ideal_depth(m.without_noise(), Isometry3d::Identity(), 5, 0);
    const DepthImage depth = renderer.render(m, Isometry3d::Identity(), 5, 0).depth;
    double residual2 = 0.0, predicted2 = 0.0;
    std::size_t n_valid = 0;
    for (std::size_t i = 0; i < depth.data().size(); ++i) {
      if (depth.data()[i] == 0 || exact.z[i] < 0.6f || exact.z[i] > 4.4f) continue;
      const double r = depth.data()[i] - 1000.0 * exact.z[i];
      const double sigma = 1000.0 * m.axial_sigma_m(exact.z[i], exact.incidence[i]);
      residual2 += r * r;
      predicted2 += sigma * sigma + 1.0 / 12.0;
      ++n_valid;
    }
    ASSERT_GT(n_valid, 50000u) << "tilt " << c.tilt_deg;
    const double ratio = std::sqrt(residual2 / predicted2);
    EXPECT_NEAR(ratio, 1.0, 0.10) << "tilt " << c.tilt_deg;
  }
}

TEST(KinectV2Model, LateralNoiseMovesSamplesBySigmaLAtTheSurface) {
  // On a plane slanted 60 degrees about x, a vertical image offset dv changes z by
  // dz/dv; the lateral spread sigma_L f / z pixels must show up as dz spread.
  KinectV2Model m = KinectV2Model::exact();
  m.lateral_sigma_m = 0.0016;
  const double tilt = 60 * kDeg;
  const Eigen::Vector3d n = Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()) * Eigen::Vector3d(0, 0, -1);
  const ViewRenderer renderer(plane_through({0, 0, 2.0}, n));
  const IdealDepth exact = renderer.ideal_depth(KinectV2Model::exact(), Isometry3d::Identity(), 9, 0);
  const IdealDepth jittered = renderer.ideal_depth(m, Isometry3d::Identity(), 9, 0);
  const CameraIntrinsics& K = m.intrinsics;
  // Centre rows only: there z ~ 2 m and the slope is nearly constant.
  double ratio2 = 0.0;
  std::size_t count = 0;
  for (int v = 200; v < 224; ++v) {
    for (int u = 100; u < 412; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * K.width + u;
      const double dz_dv = (exact.z[i + K.width] - exact.z[i - K.width]) / 2.0;
      const double sigma_px = m.lateral_sigma_px(exact.z[i]);
      const double dz = jittered.z[i] - exact.z[i];
      ratio2 += (dz * dz) / (dz_dv * dz_dv * sigma_px * sigma_px);
      ++count;
    }
  }
  EXPECT_NEAR(std::sqrt(ratio2 / count), 1.0, 0.10);
}

TEST(KinectV2Model, DropoutsAtGrazingAnglesAndOnDarkSurfaces) {
  const KinectV2Model m;
  auto dropped_fraction = [&](double theta_deg, double luminance) {
    const DepthImage d = m.measure(constant_depth(2.0, theta_deg * kDeg, luminance), 3, 1);
    const auto zeros = std::count(d.data().begin(), d.data().end(), std::uint16_t{0});
    return static_cast<double>(zeros) / static_cast<double>(d.pixel_count());
  };
  EXPECT_EQ(dropped_fraction(70, 0.5), 0.0);
  EXPECT_NEAR(dropped_fraction(81, 0.5), 0.5, 0.01);  // halfway from 75 to 87 degrees
  EXPECT_EQ(dropped_fraction(88, 0.5), 1.0);
  EXPECT_EQ(dropped_fraction(0, 0.2), 0.0);
  EXPECT_NEAR(dropped_fraction(0, 0.05), 0.5, 0.01);  // halfway from 0.08 to 0.02
  EXPECT_EQ(dropped_fraction(0, 0.01), 1.0);
  EXPECT_NEAR(m.dropout_probability(81 * kDeg, 0.05), 0.75, 1e-9);  // independent causes
  EXPECT_EQ(KinectV2Model::exact().dropout_probability(89 * kDeg, 0.0), 0.0);
}

TEST(KinectV2Model, FlyingPixelsOnlyAtDepthDiscontinuities) {
  KinectV2Model m = KinectV2Model::exact();
  m.flying_pixel_probability = 0.5;
  // Left half at 1 m, right half at 3 m: the jump lies between columns 255 and 256.
  IdealDepth ideal = constant_depth(1.0, 0.0);
  for (int v = 0; v < 424; ++v)
    for (int u = 256; u < 512; ++u) ideal.z[static_cast<std::size_t>(v) * 512 + u] = 3.0f;
  const DepthImage d = m.measure(ideal, 11, 0);
  int flying = 0, edge = 0;
  for (int v = 0; v < 424; ++v) {
    for (int u = 0; u < 512; ++u) {
      const int mm = d.at(u, v);
      const bool between = mm > 1000 && mm < 3000;
      if (u == 255 || u == 256) {
        ++edge;
        flying += between;
      } else {
        ASSERT_EQ(mm, u < 256 ? 1000 : 3000) << "interior pixel " << u << "," << v;
      }
    }
  }
  // Each edge pixel flies with probability 0.5 (a blend weight of exactly 0 or 1 is rare).
  EXPECT_NEAR(static_cast<double>(flying) / edge, 0.5, 0.05);
}

TEST(KinectV2Model, RangeLimitsAndExactQuantisation) {
  const KinectV2Model exact = KinectV2Model::exact();
  auto first = [&](double z) { return exact.measure(constant_depth(z, 0.0), 1, 0).at(10, 10); };
  EXPECT_EQ(first(0.45), 0);
  EXPECT_EQ(first(0.5), 500);
  EXPECT_EQ(first(1.2344), 1234);
  EXPECT_EQ(first(1.2346), 1235);
  EXPECT_EQ(first(4.5), 4500);
  EXPECT_EQ(first(4.6), 0);
  IdealDepth nothing(512, 424);  // z = 0: no surface
  const DepthImage none = KinectV2Model{}.measure(nothing, 1, 0);
  EXPECT_EQ(std::count(none.data().begin(), none.data().end(), std::uint16_t{0}),
            static_cast<long>(none.pixel_count()));
}

TEST(KinectV2Model, NoiseIsSeededAndIndependentOfThreadCount) {
  const KinectV2Model m;
  const IdealDepth ideal = constant_depth(2.0, 30 * kDeg);
  const DepthImage a = m.measure(ideal, 5, 3);
  DepthImage single_thread;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    single_thread = m.measure(ideal, 5, 3);
  }
  EXPECT_EQ(a, single_thread);
  EXPECT_EQ(a, m.measure(ideal, 5, 3));
  EXPECT_NE(a, m.measure(ideal, 6, 3));  // another seed
  EXPECT_NE(a, m.measure(ideal, 5, 4));  // another view
}

}  // namespace
}  // namespace locard::sim
