#pragma once
// A physics scenario (docs/scenarios.md): what `locard simulate` drops, throws, fires or walks
// through a reconstructed scene. Everything is illustrative - a what-if played out against the
// measured mesh, never a measurement itself.
//
// World frame: the case's frame (z up for the simulated bedroom), metres, seconds, kilograms,
// angles in degrees. Rotations are given as "rotation_deg": [roll, pitch, yaw], applied as
// R = Rz(yaw) * Ry(pitch) * Rx(roll) (extrinsic x, then y, then z).
//
// Parsing is strict: an unknown key, a missing required key, a value of the wrong type or a
// non-finite number throws InputError naming the file and the key ("objects[1] \"box\".mass").

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

// A projectile: a point mass with gravity and quadratic air drag (physics_ballistics.hpp).
struct ProjectileSpec {
  std::string name;
  Eigen::Vector3d muzzle = Eigen::Vector3d::Zero();     // launch point
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX(); // unit length after parsing
  double speed = 0.0;                                   // m/s at the muzzle
  double mass = 0.008;                                  // kg (a 9 mm bullet: 8 g)
  double diameter = 0.009;                              // m, for the drag reference area
  double drag_coefficient = 0.3;                        // C_d; 0 turns drag off
  double fire_time = 0.0;                               // s after the start
  double spread_deg = 0.0;  // seeded random deviation of the direction, uniform in this cone
  // Where the line came from: "muzzle", "from_points" or "trajectory:<name>" (for the record).
  std::string source = "muzzle";
  bool starts_on_surface = false;  // from points / analyses: the first point may lie on a surface
};

enum class ObjectShape { Box, Sphere, Mesh };
std::string_view to_string(ObjectShape shape);

// A rigid body dropped or thrown into the scene.
struct ObjectSpec {
  std::string name;
  ObjectShape shape = ObjectShape::Box;
  Eigen::Vector3d size = Eigen::Vector3d::Zero();  // Box: full extents
  double radius = 0.0;                             // Sphere
  std::filesystem::path file;                      // Mesh: PLY, resolved against the scenario
  double scale = 1.0;                              // Mesh
  TriangleMesh mesh;  // Mesh: read from `file`, scaled, centred on its bounding-box centre
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // centre
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity_deg = Eigen::Vector3d::Zero();  // deg/s, world axes
  double mass = 1.0;
  double friction = 0.6;
  double restitution = 0.2;
  Rgb8 color{200, 120, 40};
};

// A person as an articulated capsule ragdoll (11 capsules joined by cone-twist and hinge
// joints) that collapses or is pushed, or as a keyframed avatar (a kinematic capsule walking a
// path, pushing what it meets).
enum class PersonKind { Ragdoll, Avatar };
std::string_view to_string(PersonKind kind);

struct PathPoint {
  double time = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // on the floor, under the feet
};

struct PersonSpec {
  std::string name;
  PersonKind kind = PersonKind::Ragdoll;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // on the floor, under the feet
  double yaw_deg = 0.0;                                // facing direction, from +x
  double height = 1.75;
  double mass = 75.0;                                  // Ragdoll
  double friction = 0.8;                               // Ragdoll
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  // Ragdoll: initial push of the trunk
  double radius = 0.2;                                 // Avatar capsule radius
  std::vector<PathPoint> path;                         // Avatar, times increasing
  Rgb8 color{70, 110, 170};
};

struct Scenario {
  std::string name;  // becomes the folder simulations/<name>/
  std::string description;
  std::filesystem::path source;  // the file it came from
  std::string source_text;       // the JSON as read (copied verbatim into the case)
  std::uint64_t seed = 1;
  double duration = 5.0;          // s
  double fps = 30.0;              // animation samples per second
  double time_step = 1.0 / 240.0; // s, fixed
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};
  double air_density = 1.225;     // kg/m^3 (sea level, 15 C)
  std::filesystem::path mesh = "mesh/mesh.ply";  // relative to the case folder
  std::vector<ProjectileSpec> projectiles;
  std::vector<ObjectSpec> objects;
  std::vector<PersonSpec> people;
};

// A named bullet-trajectory line from a case's trajectories/analyses.json.
struct TrajectoryLine {
  std::string name;
  Eigen::Vector3d a = Eigen::Vector3d::Zero();  // first point on the path
  Eigen::Vector3d b = Eigen::Vector3d::Zero();  // second point, further along
  bool withdrawn = false;  // withdrawn in the case (`locard evidence withdraw`): not to be used
};

// Reads CASE_DIR/trajectories/analyses.json: an array of analyses, or an object holding one
// under "analyses"; each has a "name" (or "id") and "points" (at least two [x, y, z] or
// {"position": [x, y, z]}); the line starts at the first point and runs along "direction" when
// the analysis has one (a fitted rod), else towards the second point. Throws InputError naming
// the file and the analysis.
std::vector<TrajectoryLine> read_trajectory_analyses(const std::filesystem::path& path);

// Reads and validates a scenario file. Mesh objects' PLY files are resolved against the
// scenario's folder; "trajectory" projectiles against `case_dir`/trajectories/analyses.json.
Scenario read_scenario(const std::filesystem::path& path,
                       const std::filesystem::path& case_dir = {});
// Same from text; `source` names it in errors, `base_dir` resolves mesh files.
Scenario parse_scenario(std::string_view json_text, const std::filesystem::path& source,
                        const std::filesystem::path& base_dir = {},
                        const std::filesystem::path& case_dir = {});

// The label every simulation output carries.
inline constexpr std::string_view kIllustrativeLabel = "illustrative simulation, not measured data";

}  // namespace locard::sim
