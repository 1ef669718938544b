#include <locard/core/error.hpp>

namespace locard {

void throw_input_error(const std::filesystem::path& path, const std::string& what, long line) {
  std::string message = path.string();
  if (line > 0) message += ":" + std::to_string(line);
  throw InputError(message + ": " + what);
}

}  // namespace locard
