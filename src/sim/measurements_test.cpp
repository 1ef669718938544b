// Ground-truth measurements: the bedroom's 12 equal the reference paper's Table I, every end
// point lies on a surface and is seen by the scan; derived ones for scenes that list none.
#include <locard/sim/measurements.hpp>

#include <locard/core/camera_intrinsics.hpp>
#include <locard/sim/scan_protocol.hpp>
#include <locard/sim/scene_mesh.hpp>
#include <locard/core/raycaster.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>

namespace locard::sim {
namespace {

// Distance from p to the nearest triangle (brute force; the oracle).
double distance_to_mesh(const TriangleMesh& mesh, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[tri[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[tri[2]].cast<double>();
    // Closest point on triangle (Ericson, Real-Time Collision Detection, 5.1.5).
    const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    Eigen::Vector3d q;
    if (d1 <= 0 && d2 <= 0) {
      q = a;
    } else {
      const Eigen::Vector3d bp = p - b;
      const double d3 = ab.dot(bp), d4 = ac.dot(bp);
      const Eigen::Vector3d cp = p - c;
      const double d5 = ab.dot(cp), d6 = ac.dot(cp);
      const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
      if (d3 >= 0 && d4 <= d3) q = b;
      else if (d6 >= 0 && d5 <= d6) q = c;
      else if (vc <= 0 && d1 >= 0 && d3 <= 0) q = a + d1 / (d1 - d3) * ab;
      else if (vb <= 0 && d2 >= 0 && d6 <= 0) q = a + d2 / (d2 - d6) * ac;
      else if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        q = b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
      else {
        const double denom = 1.0 / (va + vb + vc);
        q = a + ab * (vb * denom) + ac * (vc * denom);
      }
    }
    best = std::min(best, (p - q).norm());
  }
  return best;
}

TEST(Measurements, BedroomEqualsTableI) {
  // Table I of the reference paper, "Real" column, centimetres.
  const std::vector<std::pair<std::string, double>> table_i = {
      {"Room width", 384},   {"Nightstand", 46},   {"Radiator", 36},      {"Chair", 43},
      {"Cupboard door", 74.5}, {"Entrance door", 99}, {"Shelf", 80.5},     {"Table", 85},
      {"Window", 58},        {"Bed width", 97},    {"Bed length", 204},   {"Electric socket", 39}};
  const std::vector<Measurement> ms = scene_measurements(builtin_scene("bedroom"));
  ASSERT_EQ(ms.size(), table_i.size());
  for (std::size_t i = 0; i < ms.size(); ++i) {
    EXPECT_EQ(ms[i].name, table_i[i].first);
    EXPECT_NEAR(ms[i].distance(), table_i[i].second / 100.0, 1e-12) << ms[i].name;
    EXPECT_FALSE(ms[i].derived);
  }
}

TEST(Measurements, BedroomEndPointsLieOnSurfacesAndAreSeenByTheScan) {
  const Scene scene = builtin_scene("bedroom");
  const SceneMesh mesh = build_scene_mesh(scene);
  const Raycaster rc(mesh.mesh);
  const Trajectory views = tripod_scan_trajectory(scene.scanner);
  const CameraIntrinsics K = CameraIntrinsics::preset("kinect_v2");
  for (const Measurement& m : scene.measurements) {
    for (const Eigen::Vector3d& p : {m.a, m.b}) {
      // Float mesh vertices: on the surface to well under a micrometre.
      EXPECT_LT(distance_to_mesh(mesh.mesh, p), 1e-6) << m.name;
      // In the field of view and unoccluded (a point on an edge is hit within 2 mm of itself)
      // in at least one view, so a reconstruction can contain it.
      int seen = 0;
      for (const StampedPose& pose : views) {
        const Eigen::Vector3d q = pose.T_world_camera.inverse() * p;
        if (q.z() < 0.5 || q.z() > 4.5) continue;
        const double u = K.fx * q.x() / q.z() + K.cx, v = K.fy * q.y() / q.z() + K.cy;
        if (u < 0 || v < 0 || u > K.width - 1 || v > K.height - 1) continue;
        const Eigen::Vector3d o = pose.T_world_camera.translation();
        const RayHit hit = rc.intersect(o.cast<float>(), (p - o).cast<float>());
        if (hit.hit() && std::abs(hit.t - 1.0) * (p - o).norm() < 0.002) ++seen;
      }
      EXPECT_GE(seen, 1) << m.name << " end point (" << p.transpose() << ") never seen";
    }
  }
}

TEST(Measurements, DerivedWhenSceneListsNone) {
  Scene scene = builtin_scene("bedroom");
  scene.measurements.clear();
  const std::vector<Measurement> ms = scene_measurements(scene);
  ASSERT_EQ(ms.size(), scene.objects.size() + 2);
  EXPECT_EQ(ms[0].name, "Room width");
  EXPECT_NEAR(ms[0].distance(), 3.84, 1e-12);
  EXPECT_EQ(ms[1].name, "Room depth");
  EXPECT_NEAR(ms[1].distance(), 4.00, 1e-12);
  const SceneMesh mesh = build_scene_mesh(scene);
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& o = scene.objects[i];
    const Measurement& m = ms[i + 2];
    EXPECT_TRUE(m.derived);
    EXPECT_EQ(m.name, o.name + " (largest extent)");
    if (o.shape == ShapeKind::Box) {
      EXPECT_NEAR(m.distance(), o.size.maxCoeff(), 1e-9) << o.name;
    } else if (o.shape == ShapeKind::Cylinder) {
      EXPECT_NEAR(m.distance(), std::max(o.height, 2.0 * o.radius), 1e-9) << o.name;
    }
    EXPECT_LT(distance_to_mesh(mesh.mesh, m.a), 1e-6) << o.name;
    EXPECT_LT(distance_to_mesh(mesh.mesh, m.b), 1e-6) << o.name;
  }
  // The bed's longest edge is its length, on the corner that faces the tripod (x < centre).
  EXPECT_NEAR(ms[2].distance(), 2.04, 1e-12);
  EXPECT_NEAR(ms[2].a.x(), 0.95, 1e-12);
}

TEST(Measurements, CylinderDiameterAcrossCapFacingScanner) {
  Scene scene;
  scene.room.size = {4, 4, 3};
  SceneObject table;
  table.name = "round table";
  table.shape = ShapeKind::Cylinder;
  table.radius = 0.4;
  table.height = 0.05;
  table.segments = 48;
  table.center = {1.0, 0.0, 0.7};
  scene.objects.push_back(table);
  const auto ms = derive_measurements(scene);
  ASSERT_EQ(ms.size(), 3u);
  EXPECT_NEAR(ms[2].distance(), 0.8, 1e-9);
  EXPECT_NEAR(ms[2].a.z(), 0.725, 1e-12);  // top cap: the scanner at 1.2 m looks down on it
}

}  // namespace
}  // namespace locard::sim
