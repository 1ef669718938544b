// The written scan: a TUM folder that Locard's own reader loads (50 frames, Kinect v2
// intrinsics, ground truth), byte-identical for a seed whatever the thread count, ground truth
// that puts every depth pixel on the scene's surface, HD colour, and mesh objects from PLY.
#include <locard/sim/scan_writer.hpp>

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/trajectory_io.hpp>
#include <locard/sim/scan_simulator.hpp>
#include <locard/sim/scene_mesh.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace locard::sim {
namespace {

namespace fs = std::filesystem;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Every regular file under `root`, relative path -> bytes.
std::map<std::string, std::string> snapshot(const fs::path& root) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) files[fs::relative(e.path(), root).string()] = read_bytes(e.path());
  return files;
}

// Distance from p to the plane of the nearest triangle it projects into (brute force).
double distance_to_mesh(const TriangleMesh& mesh, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[tri[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[tri[2]].cast<double>();
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    const double d = n.dot(p - a);
    const Eigen::Vector3d q = p - d * n;
    // Inside test with a 2 mm margin: pixels at edges are still on one of the faces.
    const double margin = 0.002;
    auto inside = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
      const Eigen::Vector3d e = (y - x).normalized();
      return n.cross(e).dot(q - x) >= -margin;
    };
    if (inside(a, b) && inside(b, c) && inside(c, a)) best = std::min(best, std::abs(d));
  }
  return best;
}

TEST(ScanWriter, BedroomScanLoadsAsTumSequenceWithGroundTruth) {
  const fs::path out = test::scratch_dir() / "scan";
  const Scene scene = builtin_scene("bedroom");
  const ScanWriteSummary summary = write_simulated_scan(scene, out);
  EXPECT_EQ(summary.views, 66u);  // 50 at -10 degrees, 16 at -50 (the floor round the tripod)
  EXPECT_EQ(summary.measurements, 12u);
  EXPECT_GT(summary.valid_depth_pixels, summary.depth_pixels * 9 / 10);

  EXPECT_EQ(detect_format(out), DatasetFormat::Tum);
  const RgbdSequence seq = read_tum_sequence(out);
  ASSERT_EQ(seq.frames.size(), 66u);
  const CameraIntrinsics kinect = CameraIntrinsics::preset("kinect_v2");
  EXPECT_EQ(seq.intrinsics.width, kinect.width);
  EXPECT_EQ(seq.intrinsics.height, kinect.height);
  EXPECT_DOUBLE_EQ(seq.intrinsics.fx, kinect.fx);
  EXPECT_DOUBLE_EQ(seq.intrinsics.fy, kinect.fy);
  EXPECT_DOUBLE_EQ(seq.intrinsics.cx, kinect.cx);
  EXPECT_DOUBLE_EQ(seq.intrinsics.cy, kinect.cy);
  EXPECT_EQ(seq.intrinsics.matching_preset(), std::optional<std::string>("kinect_v2"));
  EXPECT_DOUBLE_EQ(seq.depth_scale, 1000.0);
  ASSERT_TRUE(seq.has_ground_truth());
  ASSERT_EQ(seq.ground_truth.size(), 66u);
  // capture.json: the reader's traits come from it.
  EXPECT_EQ(seq.traits.sensor, DepthSensorKind::TimeOfFlight);
  EXPECT_EQ(seq.traits.capture, CaptureKind::TripodTurn);
  EXPECT_TRUE(seq.traits.color_registered_to_depth);
  EXPECT_EQ(seq.traits.ring_sizes, (std::vector<std::size_t>{50, 16}));
  EXPECT_EQ(seq.traits.source, "capture.json (kinect_v2)");

  // The written poses are the simulator's exact poses.
  const ScanSimulator sim(scene);
  for (std::size_t i = 0; i < 50; ++i) {
    ASSERT_TRUE(seq.frames[i].T_world_camera.has_value()) << "frame " << i;
    // Full-precision text: the matrices agree to round-off (acos-based angle differences
    // cannot resolve this; compare the matrices).
    EXPECT_LT((seq.frames[i].T_world_camera->matrix() - sim.trajectory()[i].T_world_camera.matrix()).norm(), 1e-12);
    EXPECT_NEAR(seq.frames[i].timestamp, i / 30.0, 1e-6);
  }

  const RgbdFrame frame = seq.load_frame(7);
  EXPECT_EQ(frame.depth.width(), 512);
  EXPECT_EQ(frame.depth.height(), 424);
  EXPECT_EQ(frame.color.width(), 512);
  EXPECT_EQ(frame.color.height(), 424);
  // The written images are exactly what the simulator renders for that view.
  const SensorFrame rendered = sim.render(7);
  EXPECT_EQ(frame.depth, rendered.depth);
  EXPECT_EQ(frame.color, rendered.color);

  const TriangleMesh mesh = read_ply_mesh(out / "scene.ply");
  EXPECT_EQ(mesh.triangle_count(), summary.triangles);
  EXPECT_EQ(mesh.vertex_colors.size(), mesh.vertex_count());

  const auto measurements = nlohmann::json::parse(read_bytes(out / "measurements.json"));
  EXPECT_EQ(measurements["scene"], "bedroom");
  ASSERT_EQ(measurements["measurements"].size(), 12u);
  EXPECT_EQ(measurements["measurements"][0]["name"], "Room width");
  EXPECT_NEAR(measurements["measurements"][0]["distance_m"].get<double>(), 3.84, 1e-12);
  EXPECT_NEAR(measurements["measurements"][10]["distance_m"].get<double>(), 2.04, 1e-12);
  const auto provenance = nlohmann::json::parse(read_bytes(out / "simulation.json"));
  EXPECT_EQ(provenance["seed"], 1);
  EXPECT_EQ(provenance["views"], 66);
  EXPECT_EQ(provenance["ring_views"], nlohmann::json::array({50, 16}));
  EXPECT_EQ(read_bytes(out / "scene.json"), std::string(builtin_scene_json("bedroom")));
}

TEST(ScanWriter, ExactScanPutsEveryDepthPixelOnTheSurfaceAtItsGroundTruthPose) {
  Scene scene = builtin_scene("bedroom");
  scene.scanner.noise = false;
  scene.scanner.set_rings(5, {-10.0});  // one ring, as the bedroom had before its downward ring
  const fs::path out = test::scratch_dir() / "scan";
  write_simulated_scan(scene, out);
  const RgbdSequence seq = read_tum_sequence(out);
  ASSERT_EQ(seq.frames.size(), 5u);
  const TriangleMesh mesh = read_ply_mesh(out / "scene.ply");
  for (std::size_t f = 0; f < seq.frames.size(); ++f) {
    const RgbdFrame frame = seq.load_frame(f);
    const Isometry3d& T = *seq.frames[f].T_world_camera;
    int checked = 0;
    for (int v = 3; v < 424; v += 13) {
      for (int u = 5; u < 512; u += 17) {
        const double z = frame.depth_m(u, v);
        if (z == 0.0) continue;
        const Eigen::Vector3d p_camera((u - frame.intrinsics.cx) / frame.intrinsics.fx * z,
                                       (v - frame.intrinsics.cy) / frame.intrinsics.fy * z, z);
        // Half a millimetre of z rounding moves the point along its ray by up to 0.5 mm times
        // the ray's length per unit z.
        const double tolerance = 0.0005 * (p_camera / z).norm() + 1e-5;
        ASSERT_LT(distance_to_mesh(mesh, T * p_camera), tolerance) << "frame " << f << " pixel " << u << "," << v;
        ++checked;
      }
    }
    EXPECT_GT(checked, 800);
  }
}

TEST(ScanWriter, SameSeedGivesByteIdenticalFilesWhateverTheThreadCount) {
  Scene scene = builtin_scene("bedroom");
  scene.scanner.set_rings(4, {-10.0});  // one ring, as the bedroom had before its downward ring
  const fs::path root = test::scratch_dir();
  ScanWriteOptions options;
  options.color_hd = true;
  write_simulated_scan(scene, root / "a", options);
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    write_simulated_scan(scene, root / "b", options);
  }
  const auto a = snapshot(root / "a");
  const auto b = snapshot(root / "b");
  EXPECT_EQ(a.size(), 4u * 3 + 11);  // 4 views x (rgb, depth, rgb_hd) + 11 other files
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [name, bytes] : a) {
    ASSERT_TRUE(b.count(name)) << name;
    EXPECT_TRUE(bytes == b.at(name)) << name << " differs between runs";
  }
  // Another seed: other noise and other poses.
  scene.scanner.seed = 2;
  write_simulated_scan(scene, root / "c");
  const auto c = snapshot(root / "c");
  EXPECT_NE(a.at("depth/000000.png"), c.at("depth/000000.png"));
  EXPECT_NE(a.at("groundtruth.txt"), c.at("groundtruth.txt"));
  EXPECT_EQ(a.at("scene.ply"), c.at("scene.ply"));  // the scene itself does not change
}

TEST(ScanWriter, HdColourWritesItsOwnIndexAndIntrinsics) {
  Scene scene = builtin_scene("bedroom");
  scene.scanner.set_rings(2, {-10.0});  // one ring, as the bedroom had before its downward ring
  const fs::path out = test::scratch_dir() / "scan";
  ScanWriteOptions options;
  options.color_hd = true;
  write_simulated_scan(scene, out, options);
  const CameraIntrinsics hd = read_intrinsics_json(out / "intrinsics_rgb_hd.json");
  EXPECT_EQ(hd.width, 1920);
  EXPECT_EQ(hd.height, 1080);
  const ColorImage image = read_color_image(out / "rgb_hd" / "000001.png");
  EXPECT_EQ(image.width(), 1920);
  EXPECT_EQ(image.height(), 1080);
  EXPECT_NE(read_bytes(out / "rgb_hd.txt").find("rgb_hd/000001.png"), std::string::npos);
  // The TUM reader still sees the registered 512x424 colour.
  EXPECT_EQ(read_tum_sequence(out).load_frame(1).color.width(), 512);
}

TEST(ScanWriter, RefusesNonEmptyFolderUnlessForced) {
  const fs::path out = test::scratch_dir();
  std::ofstream(out / "notes.txt") << "evidence";
  Scene scene = builtin_scene("bedroom");
  scene.scanner.set_rings(1, {-10.0});  // one ring, as the bedroom had before its downward ring
  EXPECT_THROW(write_simulated_scan(scene, out), InputError);
  EXPECT_EQ(test::list_folder(out), "notes.txt\n");
  ScanWriteOptions force;
  force.force = true;
  EXPECT_EQ(write_simulated_scan(scene, out, force).views, 1u);
  EXPECT_EQ(read_bytes(out / "notes.txt"), "evidence");
  EXPECT_THROW(check_output_folder(out / "notes.txt", true), InputError);  // a file
}

TEST(ScanWriter, MeshObjectFromPlyIsScaledTurnedAndCentred) {
  const fs::path dir = test::scratch_dir();
  // A 0.2 x 0.1 x 0.4 box as a PLY in its own frame, off-centre on purpose.
  write_ply(dir / "statue.ply", box_mesh({5, 5, 5}, {0.2, 0.1, 0.4}, 0.0, {10, 200, 30}));
  std::ofstream(dir / "scene.json") << R"({"name": "gallery", "room": {"size": [4, 4, 3]},
      "objects": [{"name": "statue", "shape": "mesh", "file": "statue.ply", "scale": 2.0,
                   "yaw_deg": 90, "center": [1.0, 0.5, 0.4]}],
      "scanner": {"views": 8}})";
  const Scene scene = read_scene(dir / "scene.json");
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_EQ(scene.objects[0].mesh.triangle_count(), 12u);
  const TriangleMesh world = object_mesh(scene.objects[0]);
  Eigen::Vector3f lo = world.vertices[0], hi = lo;
  for (const auto& v : world.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  // Scaled by 2 and turned 90 degrees: x and y extents swap.
  EXPECT_TRUE(((hi - lo) - Eigen::Vector3f(0.2f, 0.4f, 0.8f)).norm() < 1e-5f);
  EXPECT_TRUE((0.5f * (hi + lo) - Eigen::Vector3f(1.0f, 0.5f, 0.4f)).norm() < 1e-5f);
  EXPECT_EQ(world.vertex_colors[0], (Rgb8{10, 200, 30}));  // the PLY's own colours kept
  // No measurements listed: the room plus the statue's largest extent (its height).
  const fs::path out = dir / "scan";
  EXPECT_EQ(write_simulated_scan(scene, out).measurements, 3u);
  const auto m = nlohmann::json::parse(read_bytes(out / "measurements.json"));
  EXPECT_EQ(m["measurements"][2]["name"], "statue (largest extent)");
  EXPECT_EQ(m["measurements"][2]["source"], "derived");
  EXPECT_NEAR(m["measurements"][2]["distance_m"].get<double>(), 0.8, 1e-5);
}

}  // namespace
}  // namespace locard::sim
