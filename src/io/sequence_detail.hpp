#pragma once
// Pieces shared by the TUM, 7-Scenes and Redwood readers. Internal to the library.

#include <locard/io/rgbd_sequence.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace locard::io_detail {

// Camera frame rate assumed for datasets without timestamps (Kinect v1 / PrimeSense).
constexpr double kAssumedFrameRate = 30.0;

// Applies SequenceOptions' intrinsics and depth-scale overrides, noting them in the sources.
void apply_overrides(RgbdSequence& sequence, const SequenceOptions& options);

// Files directly in `folder` whose lower-cased extension is one of `extensions`, sorted by name.
std::vector<std::filesystem::path> list_files(const std::filesystem::path& folder,
                                              const std::vector<std::string>& extensions);

// InputError unless `folder` is an existing directory.
void require_folder(const std::filesystem::path& folder);

// TUM: the association list (associate.py output) in `folder`, if any, and the names looked for.
std::optional<std::filesystem::path> tum_association_file(const std::filesystem::path& folder);
std::string tum_association_names();

// ---- Sequence traits (sequence_traits.cpp): what the data is, from the data itself.

// Median time between consecutive frames (s); nullopt with fewer than two frames.
std::optional<double> median_frame_interval(const std::vector<FrameEntry>& frames);
// A continuous stream has frames a fraction of a second apart.
constexpr double kMaxVideoFrameInterval = 0.2;  // s
// HandHeldVideo when the median interval is below kMaxVideoFrameInterval, else Unknown.
CaptureKind capture_from_timestamps(const std::vector<FrameEntry>& frames);

// Median camera motion between consecutive frames that both have a ground-truth pose.
struct MotionStep {
  double translation_m = 0.0;
  double rotation_deg = 0.0;
};
std::optional<MotionStep> median_ground_truth_step(const std::vector<FrameEntry>& frames);
// Video moves little between frames (hand-held: ~1-3 cm and ~1 degree at 30 Hz).
constexpr double kMaxVideoStepM = 0.10;
constexpr double kMaxVideoStepDeg = 10.0;

// `capture.json` in `folder` (written by `locard scan-sim`), validated strictly: InputError
// naming the file and key on a wrong type or value. nullopt when the file is absent.
std::optional<SequenceTraits> read_capture_json(const std::filesystem::path& folder);
// The older scan-sim provenance `simulation.json` ("generator": "locard scan-sim"): the sensor
// model and the views per pitch row. nullopt when absent or not written by scan-sim.
std::optional<SequenceTraits> traits_from_simulation_json(const std::filesystem::path& folder);

// Share of the pixels of a 16-bit depth image that hold a measurement (non-zero, and not
// `invalid_value`). No real depth camera gives a hole-free image (shadows, edges, range
// limits); rendered depth does.
double valid_depth_share(const std::filesystem::path& depth_png,
                         std::optional<std::uint16_t> invalid_value = std::nullopt);

// Intrinsics with a negative fy (ICL-NUIM's y-up image convention): back-projecting with it
// gives a mirror image of the scene. Turned into the same camera with y down: fy -> |fy|
// (cx, cy unchanged, since v = fy y / z + cy = |fy| (-y) / z + cy), and every ground-truth
// pose T conjugated by S = diag(1, -1, 1): T' = S T S, a proper rigid motion whose world frame
// is the original one with y flipped, so the model is not mirrored. Notes it in the sources.
void flip_negative_fy(RgbdSequence& sequence);

}  // namespace locard::io_detail
