// `locard scan-sim` end to end: bad scenes and bad options exit 2 and leave no output, a full
// folder is refused without --force, and two runs with one seed write identical bytes.
#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace locard::test {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

TEST(ScanSimCli, MalformedScenesExitTwoAndLeaveNoOutput) {
  const fs::path dir = scratch_dir();
  const std::map<std::string, std::pair<std::string, std::string>> cases = {
      {"unknown_key.json", {R"({"room": {"size": [3, 4, 2]}, "objets": []})", "unknown key 'objets'"}},
      {"missing_key.json", {R"({"room": {"wall_color": [1, 2, 3]}})", "missing required key 'size'"}},
      {"wrong_type.json", {R"({"room": {"size": [3, 4, 2]}, "scanner": {"views": "fifty"}})", "scanner.views"}},
      {"bad_json.json", {"{\"room\": {\"size\": [3, 4, 2]}\n,,}", "not valid JSON"}},
  };
  for (const auto& [file, content] : cases) {
    std::ofstream(dir / file) << content.first;
    const fs::path out = dir / ("out-" + file);
    const CommandResult r = run_cli("scan-sim " + quoted(dir / file) + " -o " + quoted(out));
    EXPECT_EQ(r.exit_code, 2) << file << ": " << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr(file), HasSubstr(content.second))) << file;
    EXPECT_FALSE(fs::exists(out)) << file << ": output folder created";
  }
  const CommandResult missing = run_cli("scan-sim " + quoted(dir / "nope.json") + " -o " + quoted(dir / "o"));
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_THAT(missing.output, AllOf(HasSubstr("nope.json"), HasSubstr("bedroom")));
  EXPECT_FALSE(fs::exists(dir / "o"));
}

TEST(ScanSimCli, BadOptionsExitTwo) {
  const fs::path dir = scratch_dir();
  EXPECT_EQ(run_cli("scan-sim -o " + quoted(dir / "a") + " --views 0").exit_code, 2);
  EXPECT_EQ(run_cli("scan-sim -o " + quoted(dir / "b") + " --seed -3").exit_code, 2);
  EXPECT_EQ(run_cli("scan-sim").exit_code, 2);  // -o is required
  EXPECT_FALSE(fs::exists(dir / "a"));
  EXPECT_FALSE(fs::exists(dir / "b"));
}

TEST(ScanSimCli, RefusesNonEmptyFolderWithoutForce) {
  const fs::path out = scratch_dir();
  std::ofstream(out / "notes.txt") << "keep";
  const CommandResult refused = run_cli("scan-sim -o " + quoted(out) + " --views 1");
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_THAT(refused.output, HasSubstr("--force"));
  EXPECT_EQ(list_folder(out), "notes.txt\n");
  const CommandResult forced = run_cli("-q scan-sim -o " + quoted(out) + " --views 1 --force");
  EXPECT_EQ(forced.exit_code, 0) << forced.output;
  EXPECT_EQ(forced.output, "");  // --quiet: no chatter, no progress bar
  EXPECT_TRUE(fs::exists(out / "rgb.txt"));
  EXPECT_EQ(read_bytes(out / "notes.txt"), "keep");
}

TEST(ScanSimCli, SameSeedSameBytesAndOptionsReachTheOutput) {
  const fs::path dir = scratch_dir();
  const std::string options = " --views 3 --seed 7 --no-noise";
  for (const char* name : {"a", "b"}) {
    const CommandResult r = run_cli("scan-sim bedroom -o " + quoted(dir / name) + options);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("3 views"));
  }
  std::size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir / "a")) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), dir / "a");
    EXPECT_EQ(read_bytes(e.path()), read_bytes(dir / "b" / rel)) << rel;
    ++files;
  }
  EXPECT_EQ(files, 3u * 2 + 8);  // rgb and depth per view, 3 index files, 5 others
  const auto provenance = nlohmann::json::parse(read_bytes(dir / "a" / "simulation.json"));
  EXPECT_EQ(provenance["seed"], 7);
  EXPECT_EQ(provenance["views"], 3);
  EXPECT_EQ(provenance["noise"], false);
}

}  // namespace
}  // namespace locard::test
