#pragma once
// Ground-truth measurements of a simulated scene: the tape-measure distances a reconstruction
// is checked against (the reference paper's Table I for the built-in bedroom).

#include <locard/sim/scene.hpp>

#include <filesystem>
#include <vector>

namespace locard::sim {

// The scene's own measurements, or when it lists none, derived ones: the room's width and
// depth (wall to wall at mid-height) and each object's largest extent, measured between two
// points on its surface on the side facing the scanner.
std::vector<Measurement> scene_measurements(const Scene& scene);
std::vector<Measurement> derive_measurements(const Scene& scene);

// measurements.json: {"scene", "units": "m", "measurements": [{"name", "a", "b", "distance_m",
// "source": "scene" | "derived"}]}. Atomic write.
void write_measurements_json(const std::filesystem::path& path, const std::string& scene_name,
                             const std::vector<Measurement>& measurements);

}  // namespace locard::sim
