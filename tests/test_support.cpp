#include "test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace locard::test {

std::filesystem::path shared_data() { return LOCARD_SHARED_DATA; }

std::filesystem::path scratch_dir() {
  // ctest runs the tests of one executable in parallel processes, and SetUpTestSuite has no
  // current test: the suite name plus the process id keeps every caller's folder its own.
  const auto* unit = ::testing::UnitTest::GetInstance();
  const auto* info = unit->current_test_info();
  const auto* suite = unit->current_test_suite();
  std::string name = info    ? std::string(info->test_suite_name()) + "." + info->name()
                     : suite ? std::string(suite->name()) + ".suite"
                             : std::string("scratch");
  name += "." + std::to_string(::getpid());
  std::replace(name.begin(), name.end(), '/', '_');
  const auto dir = std::filesystem::temp_directory_path() / "locard-tests" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

CommandResult run_cli(const std::string& arguments) {
  const std::string command = std::string("'") + LOCARD_CLI_PATH + "' " + arguments + " 2>&1";
  CommandResult result;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  std::size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

std::string list_folder(const std::filesystem::path& folder) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(folder)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  std::string out;
  for (const auto& n : names) out += n + "\n";
  return out;
}

}  // namespace locard::test
