// color_gradients against the analytic gradient: a tilted plane painted with a linear
// intensity ramp, whose gradient over the plane is known exactly; and the constraint d . n = 0
// when the ramp also runs along the normal (it must be projected away, not followed).
#include <locard/registration/color_gradient.hpp>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace locard {
namespace {

struct Painted {
  std::vector<Eigen::Vector3f> points, normals;
  std::vector<float> intensity;
};

// A 1 m square of the plane through the origin with normal n, sampled every 1 cm, intensity
// 0.5 + slope . p.
Painted painted_plane(const Eigen::Vector3d& n, const Eigen::Vector3d& slope) {
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  Painted out;
  for (int i = -50; i <= 50; ++i)
    for (int j = -50; j <= 50; ++j) {
      const Eigen::Vector3d p = 0.01 * i * u + 0.01 * j * v;
      out.points.push_back(p.cast<float>());
      out.normals.push_back(n.cast<float>());
      out.intensity.push_back(static_cast<float>(0.5 + slope.dot(p)));
    }
  return out;
}

TEST(ColorGradient, IsTheRampsSlopeAlongThePlane) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
  // A slope with a component along the normal: only its tangent part is seen on the plane.
  const Eigen::Vector3d slope(0.4, 0.1, 0.3);
  const Eigen::Vector3d tangent = slope - n * n.dot(slope);
  const Painted plane = painted_plane(n, slope);
  const KdTree tree(plane.points);
  const std::vector<Eigen::Vector3f> d =
      color_gradients(tree, plane.normals, plane.intensity, 0.04, 30);
  ASSERT_EQ(d.size(), plane.points.size());
  double worst = 0.0, worst_normal = 0.0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    worst = std::max(worst, (d[i].cast<double>() - tangent).norm());
    worst_normal = std::max(worst_normal, std::abs(n.dot(d[i].cast<double>())));
  }
  EXPECT_LT(worst, 1e-3 * tangent.norm());
  EXPECT_LT(worst_normal, 1e-4);
}

// The standard error tells a texture from noise: a plain plane whose intensity is only noise
// (sigma 0.01) gives gradients of a few per metre, most within 3 standard errors; the same
// noise on a ramp of 3 per metre (a texture's edge over a few centimetres) stands far above it.
TEST(ColorGradient, StandardErrorTellsTextureFromNoise) {
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.f, 0.01f);
  for (const double slope : {0.0, 3.0}) {
    Painted plane = painted_plane(n, Eigen::Vector3d(slope, 0.0, 0.0));
    for (float& c : plane.intensity) c += noise(rng);
    const KdTree tree(plane.points);
    std::vector<float> error;
    const std::vector<Eigen::Vector3f> d =
        color_gradients(tree, plane.normals, plane.intensity, 0.04, 30, &error);
    std::size_t significant = 0;
    for (std::size_t i = 0; i < d.size(); ++i) significant += d[i].norm() > 3.f * error[i];
    const double share = static_cast<double>(significant) / static_cast<double>(d.size());
    if (slope == 0.0) EXPECT_LT(share, 0.05) << "noise read as texture";
    else EXPECT_GT(share, 0.95) << "texture read as noise";
  }
}

TEST(ColorGradient, IsZeroWithTooFewNeighbours) {
  const std::vector<Eigen::Vector3f> points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<Eigen::Vector3f> normals(3, Eigen::Vector3f::UnitZ());
  const std::vector<float> intensity = {0.1f, 0.5f, 0.9f};
  const KdTree tree(points);
  for (const Eigen::Vector3f& d : color_gradients(tree, normals, intensity, 2.0, 30))
    EXPECT_EQ(d, Eigen::Vector3f::Zero());
}

TEST(ColorGradient, IntensityIsTheMeanOfTheChannels) {
  EXPECT_FLOAT_EQ(intensity_of({255, 255, 255}), 1.f);
  EXPECT_FLOAT_EQ(intensity_of({0, 0, 0}), 0.f);
  EXPECT_NEAR(intensity_of({30, 60, 90}), 60.f / 255.f, 1e-6);
}

}  // namespace
}  // namespace locard
