#pragma once
// Errors Locard reports. Every message names the file (and frame or line where known), what
// was expected and what was found, so an investigator can act on it without a debugger.

#include <filesystem>
#include <stdexcept>
#include <string>

namespace locard {

// Base of every error Locard throws on purpose.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The input (a file, a folder, a parameter) is not what it must be. The CLI exits with 2.
class InputError : public Error {
 public:
  using Error::Error;
};

// "<path>: <what>"; "<path>:<line>: <what>" when line > 0.
[[noreturn]] void throw_input_error(const std::filesystem::path& path, const std::string& what,
                                    long line = 0);

}  // namespace locard
