#include <locard/io/gravity.hpp>

#include "io/text_lines.hpp"

#include <locard/core/error.hpp>

#include <fmt/format.h>

#include <cmath>
#include <vector>

namespace locard {

std::optional<GravityDirection> read_gravity_direction(const RgbdSequence& sequence) {
  if (sequence.format != DatasetFormat::SevenScenes) return std::nullopt;
  const std::filesystem::path file = sequence.root / "gravity-direction.txt";
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) return std::nullopt;
  io_detail::DataLines lines(file);
  std::vector<double> values;
  for (std::vector<std::string_view> tokens; lines.next(tokens);)
    for (std::string_view t : tokens) {
      const std::optional<double> v = io_detail::parse_number(t);
      if (!v || !std::isfinite(*v)) lines.fail(fmt::format("'{}' is not a finite number", t));
      values.push_back(*v);
    }
  if (values.size() != 3)
    throw_input_error(file, fmt::format("expected the three components of gravity's direction, "
                                        "found {} numbers", values.size()));
  const Eigen::Vector3d g(values[0], values[1], values[2]);
  if (!(g.norm() >= 0.5 && g.norm() <= 1.5))
    throw_input_error(file, fmt::format("gravity's direction has length {:.3f}; expected a unit "
                                        "vector (0.5-1.5 accepted)", g.norm()));
  return GravityDirection{g.normalized(), file.filename().string()};
}

}  // namespace locard
