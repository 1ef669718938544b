#include "io/json_file.hpp"

#include <locard/core/error.hpp>

#include <fmt/format.h>

#include <fstream>

namespace locard::io_detail {

nlohmann::json read_json_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw_input_error(path, "cannot be read");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw_input_error(path, fmt::format("not valid JSON: {}", e.what()));
  }
}

}  // namespace locard::io_detail
