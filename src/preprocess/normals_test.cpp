// Normals by local PCA: analytic planes and spheres, orientation, degenerate neighbourhoods.

#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/preprocess/normals.hpp>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <limits>
#include <random>

namespace locard {
namespace {

// Points on the plane z = 0.1 x + 0.2 y + 1.
PointCloud tilted_plane(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    const float x = u(rng), y = u(rng);
    cloud.positions.emplace_back(x, y, 0.1f * x + 0.2f * y + 1.f);
  }
  return cloud;
}

PointCloud sphere(std::size_t n, const Eigen::Vector3f& centre, float radius, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.f, 1.f);
  PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    cloud.positions.push_back(centre + radius * Eigen::Vector3f(g(rng), g(rng), g(rng)).normalized());
  }
  return cloud;
}

TEST(Normals, TiltedPlaneFacesTheViewpoint) {
  PointCloud cloud = tilted_plane(5000, 1);
  NormalOptions options;
  options.radius = 0.1f;
  options.max_neighbors = 30;
  options.compute_curvature = true;
  const NormalReport report = estimate_normals(cloud, options);
  EXPECT_EQ(report.points, 5000u);
  EXPECT_EQ(report.degenerate, 0u);
  // The plane's normal facing the origin (which lies below the plane): -(−0.1, −0.2, 1)/|.|.
  const Eigen::Vector3f expected = -Eigen::Vector3f(-0.1f, -0.2f, 1.f).normalized();
  const ScalarField* curvature = cloud.find_scalar("curvature");
  ASSERT_NE(curvature, nullptr);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_GT(cloud.normals[i].dot(expected), 0.99999f) << i;
    ASSERT_NEAR(cloud.normals[i].norm(), 1.f, 1e-5f);
    ASSERT_LT(curvature->values[i], 1e-6f);
  }
  // Re-estimation with a viewpoint above the plane flips them all.
  options.viewpoint = Eigen::Vector3f(0.f, 0.f, 10.f);
  estimate_normals(cloud, options);
  for (const auto& n : cloud.normals) ASSERT_GT(n.dot(-expected), 0.99999f);
  EXPECT_EQ(cloud.scalars.size(), 1u);  // "curvature" replaced, not duplicated
}

TEST(Normals, SphereNormalsAreRadialAndOriented) {
  const Eigen::Vector3f centre(0.f, 0.f, 3.f);
  PointCloud cloud = sphere(20000, centre, 0.5f, 2);
  NormalOptions options;
  options.radius = 0.05f;
  options.max_neighbors = 40;
  options.compute_curvature = true;
  estimate_normals(cloud, options);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f p = cloud.positions[i];
    const Eigen::Vector3f radial = (p - centre).normalized();
    ASSERT_GT(std::abs(cloud.normals[i].dot(radial)), 0.995f) << i;
    ASSERT_GE(cloud.normals[i].dot(options.viewpoint - p), 0.f) << i;
  }
  // Curvature of a sphere sampled at radius r over a neighbourhood of radius rho: small but
  // clearly above a plane's.
  const ScalarField* curvature = cloud.find_scalar("curvature");
  double mean = 0.0;
  for (float c : curvature->values) mean += c;
  mean /= static_cast<double>(cloud.size());
  EXPECT_GT(mean, 1e-4);
  EXPECT_LT(mean, 0.05);

  // AlongExisting: start from outward normals, keep them outward.
  for (std::size_t i = 0; i < cloud.size(); ++i) cloud.normals[i] = (cloud.positions[i] - centre).normalized();
  options.orientation = NormalOrientation::AlongExisting;
  estimate_normals(cloud, options);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_GT(cloud.normals[i].dot((cloud.positions[i] - centre).normalized()), 0.995f);
  }
}

TEST(Normals, KnnOnlyAndAGivenTree) {
  PointCloud cloud = tilted_plane(2000, 3);
  const KdTree tree(cloud.positions);
  NormalOptions options;
  options.radius = 0.f;  // pure k-NN
  options.max_neighbors = 10;
  options.orientation = NormalOrientation::None;
  estimate_normals(cloud, options, &tree);
  const Eigen::Vector3f plane = Eigen::Vector3f(-0.1f, -0.2f, 1.f).normalized();
  for (const auto& n : cloud.normals) ASSERT_GT(std::abs(n.dot(plane)), 0.99999f);
  const KdTree wrong(std::vector<Eigen::Vector3f>(5, Eigen::Vector3f::Zero()));
  EXPECT_THROW(estimate_normals(cloud, options, &wrong), InputError);
}

TEST(Normals, DegenerateNeighbourhoodsAreCountedAndFaceTheViewpoint) {
  PointCloud cloud;
  for (int i = 0; i < 20; ++i) cloud.positions.emplace_back(0.01f * i, 0.f, 2.f);  // a line
  cloud.positions.emplace_back(5.f, 5.f, 5.f);                                     // isolated
  NormalOptions options;
  options.radius = 0.05f;
  const NormalReport report = estimate_normals(cloud, options);
  EXPECT_EQ(report.degenerate, 21u);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f towards = (-cloud.positions[i]).normalized();
    EXPECT_GT(cloud.normals[i].dot(towards), 0.99999f);
  }
  PointCloud empty;
  EXPECT_EQ(estimate_normals(empty, options).points, 0u);
}

TEST(Normals, RejectsNonFinitePointsAndBadOptions) {
  PointCloud cloud = tilted_plane(100, 4);
  NormalOptions options;
  options.max_neighbors = 2;
  EXPECT_THROW(estimate_normals(cloud, options), InputError);
  cloud.positions[7].y() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(estimate_normals(cloud, NormalOptions{}), InputError);
}

TEST(Normals, SameBitsWithOneThread) {
  PointCloud a = sphere(20000, Eigen::Vector3f(1.f, 0.f, 2.f), 0.4f, 5);
  PointCloud b = a;
  NormalOptions options;
  options.compute_curvature = true;
  estimate_normals(a, options);
  tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
  estimate_normals(b, options);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.scalars, b.scalars);
}

}  // namespace
}  // namespace locard
