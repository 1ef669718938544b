#pragma once
// A whole JSON file read and parsed, with errors that name the file (not public API).

#include <nlohmann/json.hpp>

#include <filesystem>

namespace locard::io_detail {

// Throws InputError "<path>: cannot be read" or "<path>: not valid JSON: ...".
nlohmann::json read_json_file(const std::filesystem::path& path);

}  // namespace locard::io_detail
