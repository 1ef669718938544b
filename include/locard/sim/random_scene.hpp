#pragma once
// A family of rooms drawn from a seed, to develop and test alignment in rooms it has never
// seen. Same seed and options: the same scene, to the bit, on any platform (every draw is a
// counter-based hash of the seed, turned into numbers with Locard's own arithmetic, never a
// std:: distribution, whose output differs between standard libraries).
//
// What a room draws (docs/simulator.md, "Random rooms"; lengths rounded to the millimetre):
//   room       width and depth 2..8 m, height 2.3..3.2 m; wall, floor and ceiling colours
//   surfaces   plain (every surface untextured) or textured (room checker or noise, each
//              object plain, checker or noise), texture scales 2..30 cm
//   objects    0..12 drawn: boxes, cylinders, low-poly tables and icospheres (inline meshes),
//              standing on the floor, 2 cm or more from the walls, 10 cm or more apart and
//              0.6 m or more (horizontally) from the tripod; one that does not fit is left out
//   tripod     anywhere 0.6 m or more from the walls, head 1.0..1.6 m high; 24..72 views per
//              ring, 1..3 pitch rings (one looking down -25..-10 degrees, level 0, up 10..30);
//              yaw jitter sd 0.5..2 degrees, position jitter sd 0..8 mm; scanner.seed = seed
//   sensor     Kinect v2 (time of flight) or Kinect v1 (structured light)
//   measurements  derive_seen_measurements: room width / depth / height and one per object,
//              between points the scan sees
// The scene's source_text is the scene as scene-file JSON (scene_json), so the scan's
// scene.json reproduces it through read_scene.

#include <locard/sim/scene.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace locard::sim {

enum class SurfaceKind { Plain, Textured };

std::string_view to_string(SurfaceKind kind);  // "plain", "textured"
std::optional<SurfaceKind> parse_surface_kind(std::string_view name);

// Draws a caller can force, so that a benchmark covers both sensors and both kinds of surface;
// what is not forced is drawn with even odds.
struct RandomSceneOptions {
  std::optional<ScannerModel> sensor;
  std::optional<SurfaceKind> surfaces;
};

Scene random_scene(std::uint64_t seed, const RandomSceneOptions& options = {});

// Plain when the room and every object are untextured.
SurfaceKind surface_kind(const Scene& scene);

// One line of what was drawn: room size, objects, rings x views, sensor, scanner position.
std::string random_scene_summary(const Scene& scene);

}  // namespace locard::sim
