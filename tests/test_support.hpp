#pragma once
// Helpers shared by the tests: where the shared data lives, scratch folders, running the CLI.

#include <filesystem>
#include <string>

namespace locard::test {

// ../shared/data beside the checkout (LOCARD_SHARED_DATA at configure time).
std::filesystem::path shared_data();
// A fresh empty folder under the build tree's temp area, unique per test.
std::filesystem::path scratch_dir();

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};
// Runs the built `locard` CLI with the given arguments (a shell-quoted string).
CommandResult run_cli(const std::string& arguments);

// Names of the files in `folder` (sorted), to check no partial output was left behind.
std::string list_folder(const std::filesystem::path& folder);

}  // namespace locard::test
