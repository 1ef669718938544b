// `locard scan-sim` end to end: bad scenes and bad options exit 2 and leave no output, a full
// folder is refused without --force, and two runs with one seed write identical bytes.
#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
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
    EXPECT_THAT(r.output, HasSubstr("6 views"));  // 3 in each of the bedroom's two rings
  }
  std::size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir / "a")) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), dir / "a");
    EXPECT_EQ(read_bytes(e.path()), read_bytes(dir / "b" / rel)) << rel;
    ++files;
  }
  EXPECT_EQ(files, 6u * 2 + 9);  // rgb and depth per view, 3 index files, 6 others
  const auto provenance = nlohmann::json::parse(read_bytes(dir / "a" / "simulation.json"));
  EXPECT_EQ(provenance["seed"], 7);
  EXPECT_EQ(provenance["views"], 6);
  EXPECT_EQ(provenance["views_per_pitch_row"], 3);  // --views: every row
  // --pitch replaces the rows: the level ring alone.
  const CommandResult one = run_cli("scan-sim bedroom -o " + quoted(dir / "c") + " --views 3 --pitch -10");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  EXPECT_THAT(one.output, HasSubstr("3 views"));
  EXPECT_EQ(run_cli("scan-sim bedroom -o " + quoted(dir / "d") + " --pitch -91").exit_code, 2);
  EXPECT_EQ(provenance["noise"], false);
}

TEST(ScanSimCli, RandomRoomWritesAScanThatReadsBackWithItsTraits) {
  const fs::path dir = scratch_dir();
  const fs::path out = dir / "random7";
  const CommandResult r = run_cli("scan-sim --random 7 --views 5 -o " + quoted(out));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // One line of what was drawn, then the usual summary.
  EXPECT_THAT(r.output, AllOf(HasSubstr("scan-sim: random_7: room "), HasSubstr(" objects ("),
                              HasSubstr(" x 5 views"), HasSubstr("scanner at (")));
  const auto scene = nlohmann::json::parse(read_bytes(out / "scene.json"));
  const std::size_t rings = scene["scanner"]["pitch_deg"].size();
  ASSERT_GE(rings, 1u);
  EXPECT_EQ(scene["scanner"]["views"], 5);  // the override is in the scene written
  const std::string model = scene["scanner"]["model"];
  for (std::size_t i = 0; i < 5 * rings; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.png", i);
    EXPECT_TRUE(fs::is_regular_file(out / "depth" / name)) << name;
    EXPECT_TRUE(fs::is_regular_file(out / "rgb" / name)) << name;
  }
  EXPECT_FALSE(fs::exists(out / "depth" / "999999.png"));
  std::ifstream gt(out / "groundtruth.txt");
  std::size_t poses = 0;
  for (std::string line; std::getline(gt, line);) poses += !line.empty() && line[0] != '#';
  EXPECT_EQ(poses, 5 * rings);
  const auto measurements = nlohmann::json::parse(read_bytes(out / "measurements.json"));
  EXPECT_EQ(measurements["scene"], "random_7");
  EXPECT_EQ(measurements["measurements"].size(), scene["measurements"].size());
  const auto capture = nlohmann::json::parse(read_bytes(out / "capture.json"));
  EXPECT_EQ(capture.size(), 5u);
  EXPECT_EQ(capture["sensor"], model);
  EXPECT_EQ(capture["depth_sensor"], model == "kinect_v1" ? "structured_light" : "time_of_flight");
  EXPECT_EQ(capture["capture"], "tripod_turn");
  EXPECT_EQ(capture["color_registered_to_depth"], true);
  EXPECT_EQ(capture["ring_sizes"], nlohmann::json(std::vector<int>(rings, 5)));

  // `locard info` takes the traits from capture.json.
  const CommandResult info = run_cli("info " + quoted(out) + " --json");
  ASSERT_EQ(info.exit_code, 0) << info.output;
  const auto traits = nlohmann::json::parse(info.output)["traits"];
  EXPECT_EQ(traits["source"], "capture.json (" + model + ")");
  EXPECT_EQ(traits["capture"], "tripod_turn");
  EXPECT_EQ(traits["ring_sizes"], capture["ring_sizes"]);

  // The same room from scene.json: the same bytes.
  const CommandResult again = run_cli("-q scan-sim " + quoted(out / "scene.json") + " -o " + quoted(dir / "again"));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(read_bytes(dir / "again" / "depth" / "000003.png"), read_bytes(out / "depth" / "000003.png"));
}

TEST(ScanSimCli, RandomRoomSensorAndSurfacesCanBeForced) {
  const fs::path dir = scratch_dir();
  for (const char* sensor : {"kinect_v1", "kinect_v2"}) {
    const fs::path out = dir / sensor;
    const CommandResult r = run_cli("-q scan-sim --random 3 --views 1 --sensor " + std::string(sensor) +
                                    " --surfaces plain -o " + quoted(out));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto capture = nlohmann::json::parse(read_bytes(out / "capture.json"));
    EXPECT_EQ(capture["sensor"], sensor);
    const auto scene = nlohmann::json::parse(read_bytes(out / "scene.json"));
    EXPECT_EQ(scene["room"]["texture"], "plain");
    for (const auto& o : scene["objects"]) EXPECT_EQ(o["texture"], "plain");
    const auto intrinsics = nlohmann::json::parse(read_bytes(out / "intrinsics.json"));
    EXPECT_EQ(intrinsics["width"], std::string(sensor) == "kinect_v1" ? 640 : 512) << intrinsics.dump();
  }
  // Bad combinations exit 2 and write nothing.
  EXPECT_EQ(run_cli("scan-sim --random 3 bedroom -o " + quoted(dir / "a")).exit_code, 2);
  EXPECT_EQ(run_cli("scan-sim --sensor kinect_v1 -o " + quoted(dir / "b")).exit_code, 2);
  EXPECT_EQ(run_cli("scan-sim --random 3 --sensor kinect_v3 -o " + quoted(dir / "c")).exit_code, 2);
  EXPECT_EQ(run_cli("scan-sim --random 3 --surfaces shiny -o " + quoted(dir / "d")).exit_code, 2);
  for (const char* name : {"a", "b", "c", "d"}) EXPECT_FALSE(fs::exists(dir / name)) << name;
  const CommandResult help = run_cli("scan-sim --help");
  EXPECT_THAT(help.output, AllOf(HasSubstr("--random"), HasSubstr("--sensor"), HasSubstr("--surfaces")));
}

}  // namespace
}  // namespace locard::test
