// The CLI takes its defaults from what the data is (SequenceTraits): `locard info` shows the
// traits, `locard align` picks its scheme from them, flags override (docs/sensors.md).
#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

std::string seven_scenes() { return (test::shared_data() / "7scenes-tsdf-fusion" / "data").string(); }

TEST(TraitsCli, InfoPrintsTheTraits) {
  const auto text = test::run_cli("info " + seven_scenes());
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_THAT(text.output, AllOf(HasSubstr("depth sensor:  structured_light"),
                                 HasSubstr("capture:       hand_held_video"),
                                 HasSubstr("colour:        not registered to depth")));

  const auto r = test::run_cli("info --json " + (test::shared_data() / "tum-fr2-desk-50").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["frames"], 50);
  EXPECT_EQ(j["ground_truth_poses"], 50);
  EXPECT_EQ(j["traits"]["sensor"], "structured_light");
  EXPECT_EQ(j["traits"]["capture"], "hand_held_video");
  EXPECT_EQ(j["traits"]["color_registered_to_depth"], true);
}

TEST(TraitsCli, BadCaptureJsonIsExit2NamingFileAndKey) {
  const fs::path dir = test::scratch_dir() / "scan";
  fs::create_directories(dir);
  std::ofstream(dir / "rgb.txt") << "0.0 rgb/0.png\n1.0 rgb/1.png\n";
  std::ofstream(dir / "depth.txt") << "0.0 depth/0.png\n1.0 depth/1.png\n";
  std::ofstream(dir / "capture.json")
      << R"({"sensor": "kinect_v2", "capture": "tripod_turn", "color_registered_to_depth": 1})";
  const auto r = test::run_cli("info " + dir.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, AllOf(HasSubstr("capture.json"), HasSubstr("color_registered_to_depth")));
}

TEST(TraitsCli, AlignWithoutFlagsTracksSevenScenesAsVideo) {
  const fs::path out = test::scratch_dir() / "align";
  const auto r = test::run_cli("align " + seven_scenes() + " --frames 20 -o " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, AllOf(HasSubstr("align: odometry mode"),
                              HasSubstr("point-to-plane ICP for odometry, depth to 3.0 m")));
  EXPECT_TRUE(fs::exists(out / "trajectory.txt"));
}

TEST(TraitsCli, AlignFlagsOverrideTheDataDefaults) {
  const fs::path out = test::scratch_dir() / "align";
  const auto r = test::run_cli("align " + seven_scenes() +
                               " --frames 3 --mode cumulative --max-depth 2.5 -o " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, AllOf(HasSubstr("cumulative mode (--mode)"), HasSubstr("depth to 2.5 m"),
                              HasSubstr("align: cumulative mode"),
                              Not(HasSubstr("align: odometry mode"))));
  const auto help = test::run_cli("align --help");
  EXPECT_THAT(help.output, HasSubstr("default: from the data"));
  const auto mesh_help = test::run_cli("mesh --help");
  EXPECT_THAT(mesh_help.output, HasSubstr("default: from the data"));
}

}  // namespace
}  // namespace locard
