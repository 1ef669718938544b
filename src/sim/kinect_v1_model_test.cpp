// The Kinect v1 (structured light) model: its published axial sigma (Khoshelham & Elberink
// 2012, Nguyen et al. 2012), measured on rendered walls at 1 m and 3 m within 20 %; depth only on
// the disparity levels, spaced z^2 (1/8) / (f b) apart; range, grazing dropouts, lateral noise
// and determinism. The Kinect v2 is untouched by it.
#include <locard/sim/kinect_model.hpp>
#include <locard/sim/scene_mesh.hpp>
#include <locard/sim/view_renderer.hpp>

#include "sim/sensor_test_util.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

namespace locard::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

using test::plane_through;

IdealDepth constant_depth(double z, double incidence_rad) {
  IdealDepth ideal(640, 480);
  std::fill(ideal.z.begin(), ideal.z.end(), static_cast<float>(z));
  std::fill(ideal.incidence.begin(), ideal.incidence.end(), static_cast<float>(incidence_rad));
  std::fill(ideal.luminance.begin(), ideal.luminance.end(), 0.8f);
  return ideal;
}

TEST(KinectV1Model, SensorAndPublishedSigma) {
  const KinectModel m = KinectModel::kinect_v1();
  EXPECT_EQ(m.sensor, ScannerModel::KinectV1);
  EXPECT_EQ(m.intrinsics.width, 640);
  EXPECT_EQ(m.intrinsics.height, 480);
  EXPECT_DOUBLE_EQ(m.intrinsics.fx, 525.0);
  EXPECT_DOUBLE_EQ(m.intrinsics.fy, 525.0);
  EXPECT_EQ(m.intrinsics.name, "kinect_v1");
  EXPECT_DOUBLE_EQ(m.min_range_m, 0.5);
  EXPECT_DOUBLE_EQ(m.max_range_m, 4.0);
  // sigma_z = 0.0012 + 0.0019 (z - 0.4)^2 m: 1.88 mm at 1 m, 14.0 mm at 3 m, 25.8 mm at 4 m.
  EXPECT_NEAR(m.axial_sigma_m(1.0, 0.0), 0.0012 + 0.0019 * 0.36, 1e-12);
  EXPECT_NEAR(m.axial_sigma_m(3.0, 0.0), 0.0012 + 0.0019 * 6.76, 1e-12);
  // Nguyen et al.'s angle term: + 0.0001 / sqrt(z) theta^2 / (pi/2 - theta)^2, 4 at 60 degrees.
  EXPECT_NEAR(m.axial_sigma_m(1.0, 60 * kDeg), 0.0012 + 0.0019 * 0.36 + 0.0004, 1e-12);
  EXPECT_NEAR(m.lateral_sigma_px(2.0, 0.0), 0.8, 1e-12);
  EXPECT_NEAR(m.lateral_sigma_px(2.0, 60 * kDeg), 0.8 + 0.035 * 2.0, 1e-12);
  // Disparity levels: dz = z^2 (1/8) / (580 * 0.075) = 2.87 mm at 1 m, 25.9 mm at 3 m.
  EXPECT_NEAR(m.depth_step_m(1.0), 1.0 / (8 * 580 * 0.075), 1e-15);
  EXPECT_NEAR(m.depth_step_m(3.0), 9.0 / (8 * 580 * 0.075), 1e-15);
  // The sensor's name for a depth is a level: f b / (k / 8) for an integer k.
  const double fb = 580 * 0.075;
  for (const double z : {0.7, 1.0, 2.345, 3.9}) {
    const double q = m.quantised_depth_m(z);
    const double k = fb / q * 8.0;
    EXPECT_NEAR(k, std::round(k), 1e-9) << z;
    EXPECT_LE(std::abs(q - z), 0.5 * m.depth_step_m(z) * 1.01) << z;
  }
  // The Kinect v2 has no disparity: its depth is its own.
  EXPECT_EQ(KinectModel{}.quantised_depth_m(2.345), 2.345);
  EXPECT_EQ(KinectModel::of(ScannerModel::KinectV2).sensor, ScannerModel::KinectV2);
}

// The rendered wall's depth error over every pixel: standard deviation (mm) and the set of
// values written.
struct WallStats {
  double stddev_mm = 0.0;
  double mean_mm = 0.0;
  std::size_t valid = 0;
  std::set<std::uint16_t> values;
};

WallStats rendered_wall(const KinectModel& m, double z) {
  const ViewRenderer renderer(plane_through({0, 0, z}, {0, 0, -1}));
  const DepthImage depth = renderer.render(m, Isometry3d::Identity(), 11, 3).depth;
  WallStats s;
  double sum = 0.0, sum2 = 0.0;
  for (const std::uint16_t d : depth.data()) {
    if (d == 0) continue;
    const double r = d - 1000.0 * z;
    sum += r;
    sum2 += r * r;
    ++s.valid;
    s.values.insert(d);
  }
  s.mean_mm = sum / s.valid;
  s.stddev_mm = std::sqrt(sum2 / s.valid - s.mean_mm * s.mean_mm);
  return s;
}

TEST(KinectV1Model, RenderedWallNoiseMatchesPublishedSigmaWithinTwentyPercent) {
  const KinectModel m = KinectModel::kinect_v1();
  for (const double z : {1.0, 3.0}) {
    const WallStats s = rendered_wall(m, z);
    ASSERT_EQ(s.valid, 640u * 480u) << "a head-on wall at " << z << " m has no dropouts";
    const double sigma_mm = 1000.0 * m.axial_sigma_m(z, 0.0);
    EXPECT_NEAR(s.stddev_mm, sigma_mm, 0.20 * sigma_mm) << "z " << z;
    // 307k samples: the agreement is much tighter (the levels' rounding is taken out of the
    // Gaussian drawn, so the total is sigma_z).
    EXPECT_NEAR(s.stddev_mm, sigma_mm, 0.05 * sigma_mm) << "z " << z;
    EXPECT_NEAR(s.mean_mm, 0.0, 0.05 * sigma_mm) << "unbiased at z " << z;
    std::printf("Kinect v1 wall at %.1f m: measured sigma %.3f mm, model %.3f mm (%+.1f %%)\n", z,
                s.stddev_mm, sigma_mm, 100.0 * (s.stddev_mm / sigma_mm - 1.0));
  }
}

TEST(KinectV1Model, DepthTakesOnlyDisparityLevels) {
  const KinectModel m = KinectModel::kinect_v1();
  const double fb = m.disparity_focal_px * m.baseline_m;
  const WallStats noisy = rendered_wall(m, 3.0);
  // Every value written is a level f b / (k / 8), rounded to the millimetre.
  for (const std::uint16_t d : noisy.values) {
    const double k = std::round(fb / (d * 1e-3) / m.disparity_step_px);
    EXPECT_EQ(d, static_cast<std::uint16_t>(1000.0 * fb / (k * m.disparity_step_px) + 0.5)) << d;
  }
  // +- 3 sigma of 14 mm holds only a handful of levels 26 mm apart; the Kinect v2 writes every
  // millimetre there.
  EXPECT_GE(noisy.values.size(), 3u);
  EXPECT_LE(noisy.values.size(), 9u);
  std::vector<std::uint16_t> levels(noisy.values.begin(), noisy.values.end());
  for (std::size_t i = 1; i < levels.size(); ++i) {
    const double mid = 0.5e-3 * (levels[i] + levels[i - 1]);
    EXPECT_NEAR(1e-3 * (levels[i] - levels[i - 1]), m.depth_step_m(mid), 0.002) << levels[i];
  }
  EXPECT_GT(rendered_wall(KinectModel{}, 3.0).values.size(), 15u);
  // Without noise the wall reads one level: the nearest to 2.5 m (disparity 17.4 px = 139.2
  // steps: 139 steps, 2.5036 m).
  const WallStats exact = rendered_wall(m.without_noise(), 2.5);
  ASSERT_EQ(exact.values.size(), 1u);
  EXPECT_EQ(*exact.values.begin(),
            static_cast<std::uint16_t>(1000.0 * m.quantised_depth_m(2.5) + 0.5));
  EXPECT_EQ(*exact.values.begin(), 2504);
}

TEST(KinectV1Model, RangeGrazingDropoutsAndDeterminism) {
  const KinectModel m = KinectModel::kinect_v1();
  auto valid = [](const DepthImage& d) {
    return static_cast<double>(std::count_if(d.data().begin(), d.data().end(),
                                             [](std::uint16_t x) { return x != 0; })) /
           d.pixel_count();
  };
  EXPECT_EQ(valid(m.measure(constant_depth(4.3, 0.0), 1, 0)), 0.0);  // beyond 4.0 m
  EXPECT_EQ(valid(m.measure(constant_depth(0.3, 0.0), 1, 0)), 0.0);  // nearer than 0.5 m
  EXPECT_EQ(valid(m.measure(constant_depth(2.0, 60 * kDeg), 1, 0)), 1.0);
  // Dropouts rise from 70 to 85 degrees: at 80, two thirds are lost.
  EXPECT_NEAR(valid(m.measure(constant_depth(2.0, 80 * kDeg), 1, 0)), 1.0 / 3.0, 0.01);
  EXPECT_EQ(valid(m.measure(constant_depth(2.0, 86 * kDeg), 1, 0)), 0.0);
  // No flying pixels: a projected pattern matches one surface or none.
  IdealDepth edge = constant_depth(1.0, 0.0);
  for (std::size_t i = 0; i < edge.z.size(); ++i)
    if (i % 640 >= 320) edge.z[i] = 2.0f;
  const DepthImage e = m.without_noise().measure(edge, 1, 0);
  for (const std::uint16_t d : e.data())
    EXPECT_TRUE(d == static_cast<std::uint16_t>(1000.0 * m.quantised_depth_m(1.0) + 0.5) ||
                d == static_cast<std::uint16_t>(1000.0 * m.quantised_depth_m(2.0) + 0.5))
        << d;
  // Same seed and view, same bytes; another view, other noise.
  const IdealDepth wall = constant_depth(2.0, 0.0);
  EXPECT_EQ(m.measure(wall, 9, 4).data(), m.measure(wall, 9, 4).data());
  EXPECT_NE(m.measure(wall, 9, 4).data(), m.measure(wall, 9, 5).data());
}

TEST(KinectV1Model, LateralNoiseBlursASilhouetteBySigmaPixels) {
  // A wall at 1.5 m covering the left half of the image in front of one at 3 m: lateral noise
  // moves each pixel's ray by N(0, 0.8^2) px, so the edge's column flips with probability
  // P(|N| > 0.5 px) ~ 0.53 at the pixels beside it and never 3 px away.
  TriangleMesh near;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(-10, -10, 1.5), Eigen::Vector3d(0, -10, 1.5),
                                   Eigen::Vector3d(0, 10, 1.5), Eigen::Vector3d(-10, 10, 1.5)}) {
    near.vertices.push_back(p.cast<float>());
    near.vertex_colors.push_back({200, 200, 200});
  }
  near.triangles = {{0, 2, 1}, {0, 3, 2}};
  SceneMesh mesh = plane_through({0, 0, 3.0}, {0, 0, -1});
  mesh.add_part(near, {}, "near");
  const ViewRenderer renderer(std::move(mesh));
  KinectModel m = KinectModel::kinect_v1().without_noise();
  m.lateral_base_px = 0.8;
  const DepthImage depth = renderer.render(m, Isometry3d::Identity(), 2, 0).depth;
  // x = 0 projects to u = cx = 319.5: between columns 319 and 320.
  std::map<int, int> far_share;
  for (int v = 0; v < 480; ++v)
    for (int u = 316; u <= 323; ++u) far_share[u] += depth.at(u, v) > 2000;
  EXPECT_EQ(far_share[316], 0);
  EXPECT_EQ(far_share[323], 480);
  // Column 319 is 0.5 px left of the edge: far with P(N > 0.5 / 0.8) = 0.27.
  EXPECT_NEAR(far_share[319] / 480.0, 0.266, 0.06);
  EXPECT_NEAR(far_share[320] / 480.0, 1.0 - 0.266, 0.06);
}

}  // namespace
}  // namespace locard::sim
