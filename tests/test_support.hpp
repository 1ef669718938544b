#pragma once
// Helpers shared by the tests: where the shared data lives, scratch folders, running the CLI.

#include <Eigen/Geometry>

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace locard::test {

// True in the ASan+UBSan build (gcc's macro or clang's feature test): whole reconstructions
// there take many times their release time, so a few tests keep to release builds.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

// ../shared/data beside the checkout (LOCARD_SHARED_DATA at configure time).
std::filesystem::path shared_data();
// A fresh empty folder under the temp area, unique per test (per suite in SetUpTestSuite), removed
// when that test (suite) passed and kept, named on stderr, when it failed.
std::filesystem::path scratch_dir();
// A fresh empty folder shared by the tests of this process (a scene built once and cached),
// removed when the process ends with every test passed.
std::filesystem::path process_scratch_dir(const std::string& name);

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};
// Runs the built `locard` CLI with the given arguments (a shell-quoted string).
CommandResult run_cli(const std::string& arguments);

// Names of the files in `folder` (sorted), to check no partial output was left behind.
std::string list_folder(const std::filesystem::path& folder);

// The rotation (degrees) and centre (metres) error of each estimated camera pose after the best
// rigid fit of them all to the truth (rotation by chordal mean, then translation), as
// bench/room_robustness.py judges the verified views of a room.
std::vector<std::pair<double, double>> errors_after_fit(const std::vector<Eigen::Isometry3d>& estimate,
                                                        const std::vector<Eigen::Isometry3d>& truth);

struct Reply {
  int status = 0;
  std::map<std::string, std::string> headers;  // names lower-case
  std::string body;
};

// One request over a fresh connection to 127.0.0.1:port (HTTP/1.0: the server closes the
// connection after answering); a malformed or missing reply is a test failure.
Reply http_request(std::uint16_t port, const std::string& method, const std::string& target,
                   const std::map<std::string, std::string>& headers = {},
                   const std::string& body = "");

}  // namespace locard::test
