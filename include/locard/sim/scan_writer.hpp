#pragma once
// Writes a simulated scan as a TUM RGB-D folder that every Locard reader (and the TUM tools)
// loads like a recorded sequence:
//   rgb/NNNNNN.png  depth/NNNNNN.png (16-bit, mm)  rgb.txt  depth.txt
//   groundtruth.txt  exact T_world_camera, "timestamp tx ty tz qx qy qz qw"
//   intrinsics.json  depth intrinsics + depth_scale (the colour is registered to depth)
//   scene.ply        coloured ground-truth mesh
//   measurements.json ground-truth distances (docs/scene-format.md)
//   scene.json       the scene description as given; simulation.json: seed and sensor settings
//   capture.json     what the data is, for the readers' sequence traits: {"sensor",
//                    "depth_sensor", "capture": "tripod_turn", "color_registered_to_depth": true,
//                    "ring_sizes": [views per pitch ring, in the order written]}
//   rgb_hd/, rgb_hd.txt, intrinsics_rgb_hd.json  with color_hd: 1920x1080 colour, same poses
// The index files (rgb.txt, depth.txt, groundtruth.txt) are written last, so an interrupted run
// never looks like a complete sequence. Same scene, options and seed: byte-identical files.

#include <locard/core/progress.hpp>
#include <locard/sim/kinect_model.hpp>
#include <locard/sim/scene.hpp>

#include <cstddef>
#include <filesystem>

namespace locard::sim {

struct ScanWriteOptions {
  bool force = false;      // write into a folder that is not empty
  bool color_hd = false;   // also write 1920x1080 colour
  ProgressCallback progress;  // (views done, views in all)
};

struct ScanWriteSummary {
  std::size_t views = 0;
  std::size_t depth_pixels = 0;  // in all views
  std::size_t valid_depth_pixels = 0;
  std::size_t triangles = 0;     // of the ground-truth mesh
  std::size_t measurements = 0;
};

// Throws InputError if `folder` is a file, or holds anything and options.force is false. The
// sensor is the scene's (scene.scanner.model), or `model` when given (it must be the same kind).
ScanWriteSummary write_simulated_scan(const Scene& scene, const std::filesystem::path& folder,
                                      const ScanWriteOptions& options = {});
ScanWriteSummary write_simulated_scan(const Scene& scene, const std::filesystem::path& folder,
                                      const ScanWriteOptions& options, const KinectModel& model);

// The check above on its own, so a caller can refuse before any work.
void check_output_folder(const std::filesystem::path& folder, bool force);

}  // namespace locard::sim
