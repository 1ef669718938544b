#pragma once
// Runs a physics scenario (physics_scenario.hpp) against a scene mesh with Bullet (double
// precision): the mesh is one static btBvhTriangleMeshShape; objects are rigid boxes, spheres
// or convex hulls of imported meshes; a ragdoll is 11 capsules (pelvis, torso, head, upper and
// lower arms and legs) joined by cone-twist joints (neck, lower back, shoulders, hips) and
// hinges (elbows, knees); an avatar is a kinematic capsule keyframed along its path (linear
// between path points, turned to face where it walks). Projectiles are point masses integrated
// by physics_ballistics.hpp at the same fixed step; each step's chord is ray-tested against the
// mesh and every body, so a 400 m/s bullet cannot pass through a wall between two steps. A hit
// on a movable body pushes it with the bullet's momentum; the bullet stops at its first hit.
//
// Determinism: one fixed step (Scenario::time_step), Bullet's solver without randomised order,
// bodies created in scenario order, and seeded randomness only (projectile spread, a ragdoll's
// small initial limb wobble). The same scenario, mesh and seed give identical results.
//
// Inferred support: a scanned mesh has holes - the floor around a tripod is never seen - and a
// body that falls through one would fall for ever. The floor is inferred from the mesh (the
// lowest height, along -gravity, holding at least a quarter as much level, up-facing surface
// as the most covered height: 2 cm bins, triangles within 20 degrees of level, the area-weighted
// height of that bin and its neighbours) and patched at that height wherever the scan left it
// open: a 10 cm grid over the mesh's extent, a square patch on every cell whose centre no
// floor triangle (level, within 5 cm of the floor) covers. Bodies over a hole rest on a patch;
// a contact with one names "inferred floor" as the other body, and the result says the floor
// was inferred. A body whose centre leaves the model (0.5 m beyond the mesh's bounds) is a
// "left_model" event and a warning.
//
// Before the first step every body is checked against the mesh: a body penetrating a surface
// by more than 5 mm, or whose centre lies behind the mesh's surfaces (most rays from it hit
// back faces first), or a muzzle behind the surfaces, throws InputError naming the body.

#include <locard/core/point_cloud.hpp>
#include <locard/core/triangle_mesh.hpp>
#include <locard/sim/physics_scenario.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace locard::sim {

// One thing that happened. Fields that do not apply to a type stay at their defaults and are
// left out of events.json.
struct SimEvent {
  double time = 0.0;
  // "launch" (projectile fired), "impact" (projectile hit), "no_impact" (projectile still in
  // flight at the end), "contact" (two bodies start touching), "rest" (a body settles),
  // "left_model" (a body's centre left the model's bounds).
  std::string type;
  std::string body;   // scenario name of the body
  std::string part;   // ragdoll part, when a ragdoll is involved ("head", ...)
  std::string other;  // the other body: a scenario name, or "mesh" for the scene
  std::string other_part;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  bool has_normal = false;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit, facing the incoming body
  bool has_velocity = false;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  double speed = -1.0;          // impact speed, or contact approach speed (m/s); <0: none
  double incidence_deg = -1.0;  // impact: angle between the path and the surface normal
  double energy_j = -1.0;       // impact: kinetic energy
  double distance_m = -1.0;     // impact/no_impact: path length flown
  long triangle = -1;           // impact on the mesh: triangle index
  bool has_rotation = false;    // rest: orientation
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
};

enum class TrackGeometry { Box, Sphere, Capsule, Mesh };

// One animated node: a rigid body (or ragdoll part) sampled over time.
struct BodyTrack {
  std::string name;   // node name: "box", "victim/head", "shot 1"
  std::string owner;  // the scenario entry it belongs to
  std::string kind;   // "object", "ragdoll", "avatar", "projectile"
  TrackGeometry geometry = TrackGeometry::Box;
  Eigen::Vector3d size = Eigen::Vector3d::Zero();  // Box: full extents
  double radius = 0.0;                             // Sphere, Capsule
  double length = 0.0;  // Capsule: distance between the end spheres' centres (along local z)
  TriangleMesh mesh;    // Mesh (body frame)
  Rgb8 color{180, 180, 180};
  std::vector<double> times;  // increasing
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Quaterniond> rotations;
  double visible_from = 0.0;             // projectiles: hidden before they are fired
  std::vector<Eigen::Vector3d> trail;    // projectiles: the flown path, muzzle to last point
};

struct FinalState {
  std::string body;
  std::string kind;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // centre (ragdoll: pelvis)
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  bool at_rest = false;  // objects and ragdolls; projectiles: stopped by an impact
};

struct SimulationResult {
  std::vector<SimEvent> events;  // ordered by time, then type, then body
  std::vector<BodyTrack> tracks;
  std::vector<FinalState> final_states;
  std::vector<double> frame_times;  // shared sample times of the non-projectile tracks
  std::size_t steps = 0;
  std::size_t mesh_triangles = 0;   // triangles in the collision mesh (degenerate ones dropped)
  // The inferred floor (see the header comment): true when patches were needed; its height
  // along -gravity.
  bool floor_inferred = false;
  double floor_height_m = 0.0;
  std::vector<std::string> warnings;  // bodies that left the model, ...
};

// The floor height along `up` (unit) found in the mesh as above; nullopt without level,
// up-facing triangles.
std::optional<double> infer_floor_height(const TriangleMesh& scene, const Eigen::Vector3d& up);
// The patches over the floor's holes at `floor_height` along `up` (empty: no hole).
TriangleMesh inferred_floor_patches(const TriangleMesh& scene, const Eigen::Vector3d& up,
                                    double floor_height);

// Runs the scenario. `scene` may have no triangles (free space). Throws InputError (naming the
// scenario file and the body) when a body starts inside the mesh or two bodies overlap.
SimulationResult simulate(const Scenario& scenario, const TriangleMesh& scene);

}  // namespace locard::sim
