#pragma once
// Ground-truth measurements of a simulated scene: the tape-measure distances a reconstruction
// is checked against (the reference paper's Table I for the built-in bedroom).

#include <locard/sim/kinect_model.hpp>
#include <locard/sim/scene.hpp>

#include <filesystem>
#include <vector>

namespace locard::sim {

// The scene's own measurements, or when it lists none, derived ones: the room's width and
// depth (wall to wall at mid-height) and each object's largest extent, measured between two
// points on its surface on the side facing the scanner.
std::vector<Measurement> scene_measurements(const Scene& scene);
std::vector<Measurement> derive_measurements(const Scene& scene);

// Measurements whose two end points are both seen by the scan the scene describes with sensor
// `model` (each in at least one view: inside the image, within range, unoccluded, at an
// incidence under 65 degrees), for scenes laid out by a program (random_scene) where the fixed
// lines of derive_measurements may be hidden or out of range:
//   "Room width", "Room depth": wall to wall along x / y, on the first line through or near the
//     tripod, at a height one of the pitch rings looks at, whose ends are seen;
//   "Room height": floor to ceiling at the first spot around the tripod where both are seen;
//   one line per object that an investigator lays a tape along, with ends found by touch:
//     "<name> (longest edge)" a box's longest edge nearest the tripod, else "<name> (longest
//     seen edge)" its longest seen edge; "<name> (height)" a cylinder's side, floor to top, the
//     line facing the tripod first; "<name> (longest seen edge)" a mesh's longest seen feature
//     edge (its surface folds there by 45 degrees or more, or ends). A smooth mesh (a ball) and
//     a cylinder's diameter (its ends on the rim, which nothing holds) give none.
// A measurement with no seen candidate is left out.
std::vector<Measurement> derive_seen_measurements(const Scene& scene, const KinectModel& model);

// measurements.json: {"scene", "units": "m", "measurements": [{"name", "a", "b", "distance_m",
// "source": "scene" | "derived"}]}. Atomic write.
void write_measurements_json(const std::filesystem::path& path, const std::string& scene_name,
                             const std::vector<Measurement>& measurements);

}  // namespace locard::sim
