#include "io/json_file.hpp"
#include "io/text_lines.hpp"

#include <locard/core/error.hpp>

#include <fmt/format.h>

#include <fstream>

namespace locard::io_detail {

nlohmann::json read_json_file(const std::filesystem::path& path) {
  const std::string text = read_whole_file(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    // Syntax errors and numbers out of range (1e400) alike.
    throw_input_error(path, fmt::format("not valid JSON: {}", e.what()));
  }
}

}  // namespace locard::io_detail
