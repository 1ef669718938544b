// Random rooms: one seed gives one scene (JSON and rendered depth, to the byte), seeds differ,
// the scene JSON reads back to the same scene, and over 200 seeds every draw lies in its range
// with objects inside the room, apart, and clear of the tripod (checked on a grid with each
// shape's own inside test, not the generator's footprints).
#include <locard/sim/random_scene.hpp>

#include <locard/sim/kinect_model.hpp>
#include <locard/sim/measurements.hpp>
#include <locard/sim/scan_simulator.hpp>
#include <locard/sim/scene_mesh.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <set>

namespace locard::sim {
namespace {

std::string depth_bytes(const Scene& scene, std::size_t view) {
  Scene few = scene;
  few.scanner.views = 2;  // rendering one view is what is compared; keep the plan small
  const ScanSimulator sim(few);
  const SensorFrame frame = sim.render(view);
  const auto& d = frame.depth.data();
  return std::string(reinterpret_cast<const char*>(d.data()), d.size() * sizeof(d[0]));
}

TEST(RandomScene, SameSeedSameSceneAndDepthBytes) {
  const Scene a = random_scene(42);
  const Scene b = random_scene(42);
  EXPECT_EQ(a.source_text, b.source_text);
  EXPECT_EQ(scene_json(a), scene_json(b));
  EXPECT_EQ(depth_bytes(a, 1), depth_bytes(b, 1));
  const std::string depth = depth_bytes(a, 1);
  EXPECT_GT(std::count_if(depth.begin(), depth.end(), [](char c) { return c != 0; }), 1000);
}

TEST(RandomScene, DifferentSeedsDiffer) {
  std::set<std::string> texts;
  for (std::uint64_t seed = 0; seed < 20; ++seed) texts.insert(random_scene(seed).source_text);
  EXPECT_EQ(texts.size(), 20u);
  EXPECT_NE(depth_bytes(random_scene(1), 0), depth_bytes(random_scene(2), 0));
}

TEST(RandomScene, SceneJsonReadsBackToTheSameScene) {
  for (const std::uint64_t seed : {3u, 7u, 11u}) {
    const Scene scene = random_scene(seed);
    EXPECT_EQ(scene.source_text, scene_json(scene));
    const std::filesystem::path file = test::scratch_dir() / "scene.json";
    std::ofstream(file, std::ios::binary) << scene.source_text;
    const Scene read = read_scene(file);
    EXPECT_EQ(scene_json(read), scene.source_text) << "seed " << seed;
    ASSERT_EQ(read.objects.size(), scene.objects.size());
    for (std::size_t i = 0; i < read.objects.size(); ++i) {
      EXPECT_EQ(read.objects[i].mesh.vertices, scene.objects[i].mesh.vertices);
      EXPECT_EQ(read.objects[i].mesh.triangles, scene.objects[i].mesh.triangles);
    }
    EXPECT_EQ(depth_bytes(read, 0), depth_bytes(scene, 0)) << "seed " << seed;
  }
}

// Inside tests per shape, in the horizontal plane (the oracle).
bool inside_footprint(const SceneObject& o, const Eigen::Vector2d& p) {
  const Eigen::Vector2d d = p - o.center.head<2>();
  const double yaw = o.yaw_deg * std::numbers::pi / 180.0;
  const Eigen::Vector2d local = Eigen::Rotation2Dd(-yaw) * d;
  switch (o.shape) {
    case ShapeKind::Box:
      return std::abs(local.x()) <= 0.5 * o.size.x() && std::abs(local.y()) <= 0.5 * o.size.y();
    case ShapeKind::Cylinder: return d.norm() <= o.radius;  // the true circle holds the facets
    case ShapeKind::Mesh: {
      Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
      double radius = 0.0;
      for (const auto& v : o.mesh.vertices) {
        lo = lo.cwiseMin(v.head<2>().cast<double>());
        hi = hi.cwiseMax(v.head<2>().cast<double>());
        radius = std::max(radius, static_cast<double>(v.head<2>().norm()));
      }
      if (o.name.rfind("ball", 0) == 0) return d.norm() <= radius;
      const Eigen::Vector2d c = 0.5 * (lo + hi);  // the mesh is centred on its box
      return std::abs(local.x()) <= 0.5 * (hi.x() - lo.x()) + 1e-9 &&
             std::abs(local.y()) <= 0.5 * (hi.y() - lo.y()) + 1e-9 && c.norm() < 1e-5;
    }
  }
  return false;
}

TEST(RandomScene, TwoHundredSeedsStayInTheirRanges) {
  std::set<ScannerModel> sensors;
  std::set<SurfaceKind> surfaces;
  std::set<std::size_t> rings;
  std::set<ShapeKind> shapes;
  std::set<Texture> textures;
  std::size_t most_objects = 0, fewest_objects = 100, with_height = 0, with_width = 0;
  std::size_t cornered = 0, cornered_measured = 0, cylinders = 0, cylinders_measured = 0;
  const std::set<double> level{0.0};
  for (std::uint64_t seed = 1000; seed < 1200; ++seed) {
    const Scene s = random_scene(seed);
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Eigen::Vector3d room = s.room.size;
    EXPECT_GE(room.x(), 2.0);
    EXPECT_LE(room.x(), 8.0);
    EXPECT_GE(room.y(), 2.0);
    EXPECT_LE(room.y(), 8.0);
    EXPECT_GE(room.z(), 2.3);
    EXPECT_LE(room.z(), 3.2);
    const ScannerSpec& sc = s.scanner;
    EXPECT_GE(sc.views, 24);
    EXPECT_LE(sc.views, 72);
    ASSERT_GE(sc.pitch_deg.size(), 1u);
    ASSERT_LE(sc.pitch_deg.size(), 3u);
    const double first = sc.pitch_deg.front();
    EXPECT_TRUE((sc.pitch_deg.size() == 1 && first == 0.0) || (first >= -25.0 && first <= -10.0))
        << first;
    // Neighbouring rings share 40-70 % of the depth camera's vertical field of view.
    const double vfov = KinectModel::of(sc.model).intrinsics.vertical_fov_deg();
    for (std::size_t r = 1; r < sc.pitch_deg.size(); ++r) {
      const double spacing = sc.pitch_deg[r] - sc.pitch_deg[r - 1];
      EXPECT_GE(spacing, 0.3 * vfov - 0.5);
      EXPECT_LE(spacing, 0.6 * vfov + 0.5);
    }
    EXPECT_GE(sc.yaw_jitter_deg, 0.5);
    EXPECT_LE(sc.yaw_jitter_deg, 2.0);
    EXPECT_GE(sc.position_jitter_m, 0.0);
    EXPECT_LE(sc.position_jitter_m, 0.008);
    EXPECT_GE(sc.position.z(), 1.0);
    EXPECT_LE(sc.position.z(), 1.6);
    EXPECT_GE(0.5 * room.x() - std::abs(sc.position.x()), 0.6 - 1e-9);
    EXPECT_GE(0.5 * room.y() - std::abs(sc.position.y()), 0.6 - 1e-9);
    // Every wall within 85 % of the range alignment uses for the sensor (3.0 / 4.5 m).
    const double wall_reach = 0.85 * (sc.model == ScannerModel::KinectV1 ? 3.0 : 4.5);
    EXPECT_LE(0.5 * room.x() + std::abs(sc.position.x()), wall_reach + 1e-3);
    EXPECT_LE(0.5 * room.y() + std::abs(sc.position.y()), wall_reach + 1e-3);
    EXPECT_EQ(sc.seed, seed);
    EXPECT_LE(s.objects.size(), 12u);
    most_objects = std::max(most_objects, s.objects.size());
    fewest_objects = std::min(fewest_objects, s.objects.size());
    sensors.insert(sc.model);
    surfaces.insert(surface_kind(s));
    rings.insert(sc.pitch_deg.size());
    textures.insert(s.room.texture);

    // Every vertex of every object inside the room, standing on the floor.
    for (const SceneObject& o : s.objects) {
      shapes.insert(o.shape);
      const TriangleMesh mesh = object_mesh(o);
      float lowest = 1e9f;
      for (const auto& v : mesh.vertices) {
        EXPECT_LE(std::abs(v.x()), 0.5 * room.x()) << o.name;
        EXPECT_LE(std::abs(v.y()), 0.5 * room.y()) << o.name;
        EXPECT_LE(v.z(), room.z()) << o.name;
        lowest = std::min(lowest, v.z());
      }
      EXPECT_NEAR(lowest, 0.0, 1e-5) << o.name;
    }
    // No 2 cm cell in two objects; every cell of an object 0.6 m or more from the tripod.
    const Eigen::Vector2d tripod = sc.position.head<2>();
    for (std::size_t i = 0; i < s.objects.size(); ++i) {
      const SceneObject& o = s.objects[i];
      const double reach = o.shape == ShapeKind::Box ? 0.5 * o.size.head<2>().norm()
                           : o.shape == ShapeKind::Cylinder ? o.radius
                                                            : 1.0;
      for (double x = o.center.x() - reach; x <= o.center.x() + reach; x += 0.02) {
        for (double y = o.center.y() - reach; y <= o.center.y() + reach; y += 0.02) {
          const Eigen::Vector2d p(x, y);
          if (!inside_footprint(o, p)) continue;
          // The circles a cylinder's or ball's facets are inscribed in bulge by at most 2.5 cm.
          const double slack = o.shape == ShapeKind::Box ? 0.0 : 0.025;
          EXPECT_GE((p - tripod).norm(), 0.6 - slack) << o.name;
          for (std::size_t j = i + 1; j < s.objects.size(); ++j)
            EXPECT_FALSE(inside_footprint(s.objects[j], p)) << o.name << " overlaps "
                                                             << s.objects[j].name;
        }
      }
    }
    // Measurements: listed, wall to wall where named so.
    for (const Measurement& m : s.measurements) {
      if (m.name == "Room width") {
        ++with_width;
        EXPECT_NEAR(m.distance(), room.x(), 1e-9);
      }
      if (m.name == "Room height") {
        ++with_height;
        EXPECT_NEAR(m.distance(), room.z(), 1e-9);
      }
    }
    // Room width, depth, height (when seen) come first, then one per object seen, a line a
    // tape is laid along: a box's edge, a cylinder's height, a table's edge. A ball has no
    // such line (its facets fold by about 20 degrees) and gets none.
    for (const SceneObject& o : s.objects) {
      const bool ball = o.name.rfind("ball_", 0) == 0;
      const auto named_for = [&](const Measurement& m) { return m.name.rfind(o.name + " (", 0) == 0; };
      const auto m = std::find_if(s.measurements.begin(), s.measurements.end(), named_for);
      const bool measured = m != s.measurements.end();
      if (o.shape == ShapeKind::Cylinder) {
        ++cylinders;
        cylinders_measured += measured;
      } else if (!ball) {
        ++cornered;
        cornered_measured += measured;
      }
      if (ball) {
        EXPECT_EQ(m, s.measurements.end()) << o.name;
      } else if (m != s.measurements.end() && o.shape == ShapeKind::Box) {
        EXPECT_LT((o.size.array() - m->distance()).abs().minCoeff(), 1e-9) << m->name;
      } else if (m != s.measurements.end() && o.shape == ShapeKind::Cylinder) {
        EXPECT_NEAR(m->distance(), o.height, 1e-9) << m->name;
        EXPECT_NEAR(std::abs(m->b.z() - m->a.z()), o.height, 1e-9) << m->name;
      }
    }
  }
  EXPECT_EQ(sensors.size(), 2u);
  EXPECT_EQ(surfaces.size(), 2u);
  EXPECT_EQ(rings.size(), 3u);
  EXPECT_EQ(shapes.size(), 3u);
  EXPECT_EQ(textures.size(), 3u);
  EXPECT_EQ(fewest_objects, 0u);
  EXPECT_GE(most_objects, 10u);
  EXPECT_GE(with_width, 100u);
  EXPECT_GE(with_height, 50u);
  // Objects hidden behind others or out of every ring's view get none; most boxes and tables
  // show a whole edge. A cylinder's height needs its foot in view, which a ring looking a
  // little down from 1-1.8 m misses within a metre or so of the tripod.
  EXPECT_GE(cornered_measured, cornered * 3 / 4);
  EXPECT_GE(cylinders_measured, cylinders / 3);
  std::printf("200 rooms: boxes and tables %zu of %zu measured, cylinders %zu of %zu; room width "
              "in %zu, height in %zu\n",
              cornered_measured, cornered, cylinders_measured, cylinders, with_width, with_height);
}

TEST(RandomScene, ForcedSensorAndSurfacesKeepTheOtherDraws) {
  for (std::uint64_t seed = 0; seed < 10; ++seed) {
    const Scene drawn = random_scene(seed);
    for (const ScannerModel sensor : {ScannerModel::KinectV1, ScannerModel::KinectV2}) {
      for (const SurfaceKind kind : {SurfaceKind::Plain, SurfaceKind::Textured}) {
        const Scene s = random_scene(seed, {.sensor = sensor, .surfaces = kind});
        EXPECT_EQ(s.scanner.model, sensor);
        EXPECT_EQ(surface_kind(s), kind);
        if (kind == SurfaceKind::Textured) {
          EXPECT_NE(s.room.texture, Texture::Plain);
        }
        // The room fits the sensor's reach and its rings its field of view; the rest of the
        // draws are the same.
        const Scene same_sensor = random_scene(seed, {.sensor = sensor, .surfaces = std::nullopt});
        EXPECT_EQ(s.room.size, same_sensor.room.size);
        EXPECT_EQ(s.scanner.position, same_sensor.scanner.position);
        EXPECT_EQ(s.scanner.pitch_deg, same_sensor.scanner.pitch_deg);
        ASSERT_EQ(s.objects.size(), same_sensor.objects.size());
        for (std::size_t i = 0; i < s.objects.size(); ++i)
          EXPECT_EQ(s.objects[i].center, same_sensor.objects[i].center);
        EXPECT_EQ(s.room.size.z(), drawn.room.size.z());
        EXPECT_EQ(s.scanner.position.z(), drawn.scanner.position.z());
        EXPECT_EQ(s.scanner.views, drawn.scanner.views);
        EXPECT_EQ(s.scanner.pitch_deg.size(), drawn.scanner.pitch_deg.size());
        EXPECT_EQ(s.scanner.pitch_deg.front(), drawn.scanner.pitch_deg.front());
      }
    }
  }
}

TEST(RandomScene, MeasurementEndPointsLieOnTheMesh) {
  for (const std::uint64_t seed : {5u, 6u, 8u}) {
    const Scene s = random_scene(seed);
    const SceneMesh mesh = build_scene_mesh(s);
    for (const Measurement& m : s.measurements) {
      for (const Eigen::Vector3d& p : {m.a, m.b}) {
        // On some triangle's plane, inside it (with a hair of margin for float vertices).
        bool on = false;
        for (const auto& t : mesh.mesh.triangles) {
          const Eigen::Vector3d a = mesh.mesh.vertices[t[0]].cast<double>();
          const Eigen::Vector3d b = mesh.mesh.vertices[t[1]].cast<double>();
          const Eigen::Vector3d c = mesh.mesh.vertices[t[2]].cast<double>();
          const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
          if (std::abs(n.dot(p - a)) > 1e-5) continue;
          const double margin = 1e-5;
          auto side = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
            return n.cross((y - x).normalized()).dot(p - x) >= -margin;
          };
          if (side(a, b) && side(b, c) && side(c, a)) {
            on = true;
            break;
          }
        }
        EXPECT_TRUE(on) << "seed " << seed << ": " << m.name << " end (" << p.transpose() << ")";
      }
    }
  }
}

TEST(RandomScene, SummaryNamesWhatWasDrawn) {
  RandomSceneOptions options;
  options.sensor = ScannerModel::KinectV1;
  const Scene s = random_scene(7, options);
  const std::string line = random_scene_summary(s);
  EXPECT_NE(line.find("kinect_v1"), std::string::npos) << line;
  EXPECT_NE(line.find(std::to_string(s.scanner.views) + " views"), std::string::npos) << line;
  EXPECT_NE(line.find(std::to_string(s.objects.size()) + " objects"), std::string::npos) << line;
  EXPECT_EQ(line.find('\n'), std::string::npos);
}

}  // namespace
}  // namespace locard::sim
