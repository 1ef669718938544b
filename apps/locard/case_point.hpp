#pragma once
// Points on the command line of the case commands: "x,y,z" in metres, or an evidence marker by
// number ("3", "marker:3") or label. Coordinates are read in the case frame (`marker frame`:
// what `marker list` and the report print; the world frame until one is chosen) unless
// `--frame world` says they are world coordinates. Withdrawn markers are refused.
#include <locard/core/error.hpp>
#include <locard/forensics/evidence_markers.hpp>

#include <Eigen/Core>
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <map>

#include <sstream>
#include <string>

namespace locard::cli {

enum class PointFrame { Case, World };

// Adds `--frame case|world` to a case command.
inline void add_point_frame_option(CLI::App* cmd, PointFrame& frame) {
  cmd->add_option("--frame", frame,
                  "Frame of x,y,z points given: case (as `marker list` prints them; the world "
                  "frame until `marker frame` chooses one; the default) or world")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, PointFrame>{{"case", PointFrame::Case}, {"world", PointFrame::World}},
          CLI::ignore_case));
}

// The world coordinates of a point given on the command line.
inline Eigen::Vector3d parse_case_point(const std::string& text,
                                        const forensics::MarkerSet& markers,
                                        PointFrame frame = PointFrame::Case) {
  if (text.find(',') != std::string::npos) {
    std::stringstream ss(text);
    Eigen::Vector3d p;
    std::string part;
    int i = 0;
    while (std::getline(ss, part, ',')) {
      if (i == 3) break;
      try {
        std::size_t used = 0;
        p[i] = std::stod(part, &used);
        if (used != part.size()) throw std::invalid_argument(part);
      } catch (const std::exception&) {
        throw InputError(fmt::format("point '{}': '{}' is not a number", text, part));
      }
      ++i;
    }
    if (i != 3 || std::getline(ss, part))
      throw InputError(fmt::format("point '{}': expected x,y,z", text));
    return frame == PointFrame::Case ? markers.frame.to_world(p) : p;
  }
  if (const forensics::EvidenceMarker* m = markers.find_usable(text)) return m->world;
  throw InputError(fmt::format("point '{}': neither x,y,z nor a marker of this case (see "
                               "`locard marker list`)",
                               text));
}

}  // namespace locard::cli
