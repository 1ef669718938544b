#include <locard/preprocess/point_selection.hpp>

#include "preprocess/point_status.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace locard {

namespace {

template <typename T>
std::vector<T> gather(const std::vector<T>& values, std::span<const std::uint32_t> indices) {
  std::vector<T> out(indices.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, indices.size(), 4096),
                    [&](const auto& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        out[i] = values[indices[i]];
                      }
                    });
  return out;
}

}  // namespace

PointCloud select_points(const PointCloud& cloud, std::span<const std::uint32_t> indices) {
  PointCloud out;
  out.positions = gather(cloud.positions, indices);
  if (cloud.has_normals()) out.normals = gather(cloud.normals, indices);
  if (cloud.has_colors()) out.colors = gather(cloud.colors, indices);
  out.scalars.reserve(cloud.scalars.size());
  for (const ScalarField& field : cloud.scalars) {
    out.scalars.push_back(ScalarField{field.name, gather(field.values, indices)});
  }
  return out;
}

namespace detail {

std::vector<PointStatus> finite_status(const PointCloud& cloud) {
  std::vector<PointStatus> status(cloud.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cloud.size(), 8192),
                    [&](const auto& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        status[i] = is_finite_point(cloud.positions[i]) ? PointStatus::Keep
                                                                        : PointStatus::NonFinite;
                      }
                    });
  return status;
}

FilterResult build_filter_result(const PointCloud& cloud, const std::vector<PointStatus>& status) {
  FilterResult result;
  result.report.input_points = cloud.size();
  std::size_t kept = 0;
  for (PointStatus s : status) {
    kept += s == PointStatus::Keep;
    result.report.non_finite += s == PointStatus::NonFinite;
    result.report.rejected += s == PointStatus::Rejected;
  }
  result.indices.reserve(kept);
  for (std::size_t i = 0; i < status.size(); ++i) {
    if (status[i] == PointStatus::Keep) result.indices.push_back(static_cast<std::uint32_t>(i));
  }
  result.cloud = select_points(cloud, result.indices);
  result.report.output_points = kept;
  return result;
}

}  // namespace detail

FilterResult remove_non_finite(const PointCloud& cloud) {
  cloud.check_consistent();
  return detail::build_filter_result(cloud, detail::finite_status(cloud));
}

}  // namespace locard
