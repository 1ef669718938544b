#pragma once
// Library-internal: the common tail of every subset filter. A filter marks each input point
// with a PointStatus (in parallel), and build_filter_result() gathers the kept points and
// counts the rest.

#include <locard/preprocess/point_selection.hpp>

#include <cstdint>
#include <vector>

namespace locard::detail {

enum class PointStatus : std::uint8_t { Keep = 0, Rejected = 1, NonFinite = 2 };

FilterResult build_filter_result(const PointCloud& cloud, const std::vector<PointStatus>& status);

// Keep for finite points, NonFinite for the others (parallel).
std::vector<PointStatus> finite_status(const PointCloud& cloud);

}  // namespace locard::detail
