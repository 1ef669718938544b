#pragma once
// Points on the command line of the case commands: "x,y,z" (world frame, metres) or an
// evidence marker by number ("3", "marker:3") or label.
#include <locard/core/error.hpp>
#include <locard/forensics/evidence_markers.hpp>

#include <Eigen/Core>
#include <fmt/format.h>

#include <sstream>
#include <string>

namespace locard::cli {

inline Eigen::Vector3d parse_case_point(const std::string& text,
                                        const forensics::MarkerSet& markers) {
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
    return p;
  }
  if (const forensics::EvidenceMarker* m = markers.find(text)) return m->world;
  throw InputError(fmt::format("point '{}': neither x,y,z nor a marker of this case (see "
                               "`locard marker list`)",
                               text));
}

}  // namespace locard::cli
