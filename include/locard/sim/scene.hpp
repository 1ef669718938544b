#pragma once
// A simulated crime scene as described by a scene file (docs/scene-format.md): a room, the
// objects in it, the measurements an investigator would take with a tape, and the tripod scan
// that captures it.
//
// World frame: z up, floor at z = 0, room centred on x = y = 0, metres. Boxes are given by
// their centre, full size (x, y, z extents before yaw) and a yaw about +z (counter-clockwise
// seen from above). Cylinders stand on their axis (+z), centred on `center`. Meshes are
// scaled, turned by yaw and moved so that their bounding-box centre lies on `center`.

#include <locard/core/point_cloud.hpp>
#include <locard/core/triangle_mesh.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard::sim {

// Procedural surface detail, evaluated at the hit point so colour carries keypoints.
enum class Texture { Plain, Checker, Noise };

std::string_view to_string(Texture texture);

enum class ShapeKind { Box, Cylinder, Mesh };

std::string_view to_string(ShapeKind shape);

// The depth camera of the scan (scene key scanner.model): the Kinect v2 (time of flight) or the
// Kinect v1 (PrimeSense structured light). KinectModel (kinect_model.hpp) holds their errors.
enum class ScannerModel { KinectV2, KinectV1 };

std::string_view to_string(ScannerModel model);  // "kinect_v2", "kinect_v1"
std::optional<ScannerModel> parse_scanner_model(std::string_view name);

struct RoomSpec {
  Eigen::Vector3d size{4.0, 4.0, 2.6};  // width (x), depth (y), height (z)
  Rgb8 wall_color{205, 195, 175};
  Rgb8 floor_color{120, 90, 60};
  Rgb8 ceiling_color{235, 235, 235};
  Texture texture = Texture::Plain;
  double texture_scale = 0.05;  // metres: checker cell or noise feature size
};

struct SceneObject {
  std::string name;
  ShapeKind shape = ShapeKind::Box;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double yaw_deg = 0.0;
  Eigen::Vector3d size = Eigen::Vector3d::Zero();  // Box: full extents before yaw
  double radius = 0.0;                             // Cylinder
  double height = 0.0;                             // Cylinder
  int segments = 48;                               // Cylinder facets around the axis
  std::filesystem::path file;                      // Mesh: PLY, resolved against the scene file;
                                                   // empty when the mesh is given inline
  double scale = 1.0;                              // Mesh
  TriangleMesh mesh;                               // Mesh: from `file` or inline (object frame)
  Rgb8 color{180, 180, 180};
  bool has_color = false;  // Mesh: false keeps the PLY's own vertex colours when it has them
  Texture texture = Texture::Plain;
  double texture_scale = 0.05;
};

// Two points on surfaces and the distance between them: the ground truth a later stage has to
// reproduce from the reconstruction.
struct Measurement {
  std::string name;
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  bool derived = false;  // made up by Locard because the scene listed none

  double distance() const { return (b - a).norm(); }
};

// Tripod scan: `views` poses evenly spaced over 360 degrees of yaw for every pitch row, each
// disturbed by seeded jitter as a hand turning a tripod head would.
struct ScannerSpec {
  ScannerModel model = ScannerModel::KinectV2;
  Eigen::Vector3d position{0.0, 0.0, 1.2};
  int views = 50;                         // per pitch row, unless ring_views says otherwise
  // Views of each pitch row, in pitch_deg's order (empty: `views` for every row). A downward
  // ring needs fewer views than the level one: its footprint on the floor turns less per step.
  std::vector<int> ring_views;
  int views_in_ring(std::size_t ring) const {
    return ring < ring_views.size() ? ring_views[ring] : views;
  }
  // One row of `views` at each pitch (ring_views cleared).
  void set_rings(int views_per_ring, std::vector<double> pitches) {
    views = views_per_ring;
    ring_views.clear();
    pitch_deg = std::move(pitches);
  }
  std::size_t total_views() const {
    std::size_t n = 0;
    for (std::size_t r = 0; r < pitch_deg.size(); ++r) n += static_cast<std::size_t>(views_in_ring(r));
    return n;
  }
  std::vector<double> pitch_deg{0.0};     // one row per entry; positive looks up
  double yaw_jitter_deg = 1.0;            // standard deviation
  double position_jitter_m = 0.005;      // standard deviation, per axis
  std::uint64_t seed = 1;
  bool noise = true;                      // false: exact depth and colour
};

struct Scene {
  std::string name;
  std::filesystem::path source;  // file it came from, or "built-in:<name>"
  std::string source_text;       // the scene JSON as read, kept for provenance
  RoomSpec room;
  std::vector<SceneObject> objects;
  std::vector<Measurement> measurements;  // as listed in the file (may be empty)
  ScannerSpec scanner;
};

// Reads and validates a scene file; mesh objects' PLY files are read too, relative to the
// scene file's folder. Throws InputError naming the file and the offending key.
Scene read_scene(const std::filesystem::path& path);

// Same from text; `source` names it in errors, `base_dir` resolves mesh files.
Scene parse_scene(std::string_view json_text, const std::filesystem::path& source,
                  const std::filesystem::path& base_dir = {});

// The scene as scene-file JSON that parse_scene reads back into the same scene: every key
// written out (defaults too), one object or measurement per line. A mesh object is written as
// its `file` when it has one, otherwise inline ("vertices", "triangles"; its own vertex colours
// and normals are not written, so give it a `color`).
std::string scene_json(const Scene& scene);

// Scenes compiled into Locard, so `locard scan-sim` works with no data at all.
std::vector<std::string> builtin_scene_names();
// The JSON text of a built-in scene; throws InputError listing the known names.
std::string_view builtin_scene_json(std::string_view name);
Scene builtin_scene(std::string_view name);

}  // namespace locard::sim
