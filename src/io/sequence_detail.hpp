#pragma once
// Pieces shared by the TUM, 7-Scenes and Redwood readers. Internal to the library.

#include <locard/io/rgbd_sequence.hpp>

#include <filesystem>
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

}  // namespace locard::io_detail
