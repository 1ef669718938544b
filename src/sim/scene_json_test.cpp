// Scene files: the built-in bedroom, defaults, and clear errors for malformed input (unknown
// key, missing key, wrong type, bad JSON), each naming the file and the key.
#include <locard/sim/scene.hpp>

#include <locard/core/error.hpp>

#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>

namespace locard::sim {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The message of the InputError that parsing `text` (as file `name`) throws.
std::string error_of(const std::string& text, const std::string& name = "scene.json") {
  try {
    parse_scene(text, name);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError for: " << text;
  return {};
}

const char* kMinimal = R"({"room": {"size": [3, 4, 2.5]}})";

TEST(SceneJson, BuiltinBedroomMatchesDataFile) {
  const auto file = std::filesystem::path(LOCARD_SOURCE_DIR) / "data/scenes/bedroom.json";
  ASSERT_TRUE(std::filesystem::exists(file));
  // The compiled-in copy is the data file verbatim.
  EXPECT_EQ(read_text(file), std::string(builtin_scene_json("bedroom")));
  const Scene from_file = read_scene(file);
  const Scene builtin = builtin_scene("bedroom");
  EXPECT_EQ(from_file.name, "bedroom");
  EXPECT_EQ(builtin.name, "bedroom");
  EXPECT_EQ(from_file.objects.size(), builtin.objects.size());
  EXPECT_EQ(builtin.source, "built-in:bedroom");
}

TEST(SceneJson, BedroomContents) {
  const Scene s = builtin_scene("bedroom");
  EXPECT_DOUBLE_EQ(s.room.size.x(), 3.84);  // Table I room width
  EXPECT_DOUBLE_EQ(s.room.size.y(), 4.00);
  EXPECT_EQ(s.room.texture, Texture::Noise);
  EXPECT_EQ(s.objects.size(), 27u);
  EXPECT_EQ(s.measurements.size(), 12u);
  EXPECT_EQ(s.scanner.views, 50);
  EXPECT_EQ(s.scanner.ring_views, (std::vector<int>{50, 16}));  // a downward ring for the floor
  EXPECT_EQ(s.scanner.pitch_deg, (std::vector<double>{-10.0, -50.0}));
  EXPECT_EQ(s.scanner.total_views(), 66u);
  EXPECT_EQ(s.scanner.seed, 1u);
  EXPECT_TRUE(s.scanner.noise);
  const SceneObject& bed = s.objects.front();
  EXPECT_EQ(bed.name, "bed");
  EXPECT_EQ(bed.shape, ShapeKind::Box);
  EXPECT_TRUE(bed.size.isApprox(Eigen::Vector3d(0.97, 2.04, 0.50)));
  EXPECT_EQ(bed.texture, Texture::Checker);
  EXPECT_EQ(bed.color, (Rgb8{150, 30, 30}));
  EXPECT_THAT(builtin_scene_names(), ::testing::Contains("bedroom"));
  EXPECT_THROW(builtin_scene("kitchen"), InputError);
}

// Rings of their own sizes survive a write and a read, and plan that many poses a ring.
TEST(SceneJson, RingsOfTheirOwnSizesRoundTrip) {
  const Scene s = parse_scene(R"({"room": {"size": [3, 4, 2.5]},
      "scanner": {"views": [30, 12], "pitch_deg": [0, -45]}})", "rings.json");
  EXPECT_EQ(s.scanner.ring_views, (std::vector<int>{30, 12}));
  EXPECT_EQ(s.scanner.total_views(), 42u);
  const Scene back = parse_scene(scene_json(s), "written.json");
  EXPECT_EQ(back.scanner.ring_views, s.scanner.ring_views);
  EXPECT_EQ(back.scanner.pitch_deg, s.scanner.pitch_deg);
}

TEST(SceneJson, DefaultsForOptionalKeys) {
  const Scene s = parse_scene(kMinimal, "/tmp/minimal.json");
  EXPECT_EQ(s.name, "minimal");  // file stem
  EXPECT_TRUE(s.objects.empty());
  EXPECT_TRUE(s.measurements.empty());
  EXPECT_EQ(s.scanner.model, ScannerModel::KinectV2);
  EXPECT_EQ(s.scanner.views, 50);
  EXPECT_EQ(s.scanner.pitch_deg, std::vector<double>{0.0});
  EXPECT_TRUE(s.scanner.position.isApprox(Eigen::Vector3d(0, 0, 1.2)));
  EXPECT_EQ(s.room.texture, Texture::Plain);
}

TEST(SceneJson, AllShapesAndScannerKeys) {
  const Scene s = parse_scene(R"({
    "name": "lab",
    "room": {"size": [5, 6, 3], "wall_color": [1, 2, 3], "texture": "checker"},
    "objects": [
      {"name": "crate", "shape": "box", "size": [1, 2, 0.5], "center": [0, 1, 0.25], "yaw_deg": 30},
      {"name": "bin", "shape": "cylinder", "radius": 0.2, "height": 0.6, "center": [1, 1, 0.3],
       "segments": 12, "texture": "noise", "texture_scale": 0.1}
    ],
    "scanner": {"position": [0.1, 0.2, 1.5], "views": 8, "pitch_deg": [-20, 0, 20],
                "yaw_jitter_deg": 0, "position_jitter_m": 0, "seed": 99, "noise": false}
  })", "lab.json");
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.objects[0].yaw_deg, 30.0);
  EXPECT_EQ(s.objects[1].shape, ShapeKind::Cylinder);
  EXPECT_EQ(s.objects[1].segments, 12);
  EXPECT_EQ(s.objects[1].texture_scale, 0.1);
  EXPECT_EQ(s.room.wall_color, (Rgb8{1, 2, 3}));
  EXPECT_EQ(s.scanner.pitch_deg.size(), 3u);
  EXPECT_EQ(s.scanner.seed, 99u);
  EXPECT_FALSE(s.scanner.noise);
}

TEST(SceneJson, UnknownKeysAreNamed) {
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "rooms": {}})"),
              AllOf(HasSubstr("scene.json"), HasSubstr("unknown key 'rooms'")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2], "colour": [1, 2, 3]}})"),
              AllOf(HasSubstr("room"), HasSubstr("unknown key 'colour'")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": [
                 {"name": "bed", "shape": "box", "size": [1, 2, 0.5], "center": [0, 0, 0.25],
                  "colour": [1, 2, 3]}]})"),
              AllOf(HasSubstr("objects[0] \"bed\""), HasSubstr("unknown key 'colour'")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"view": 10}})"),
              AllOf(HasSubstr("scanner"), HasSubstr("unknown key 'view'")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]},
                 "measurements": [{"name": "x", "a": [0, 0, 0], "b": [1, 0, 0], "c": 1}]})"),
              AllOf(HasSubstr("measurements[0]"), HasSubstr("unknown key 'c'")));
  // A key that belongs to another shape is unknown for this one.
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": [
                 {"name": "b", "shape": "box", "size": [1, 1, 1], "center": [0, 0, 0.5], "radius": 1}]})"),
              HasSubstr("unknown key 'radius'"));
}

TEST(SceneJson, MissingRequiredKeysAreNamed) {
  EXPECT_THAT(error_of(R"({"name": "x"})", "/data/x.json"),
              AllOf(HasSubstr("/data/x.json"), HasSubstr("missing required key 'room'")));
  EXPECT_THAT(error_of(R"({"room": {}})"), AllOf(HasSubstr("room"), HasSubstr("missing required key 'size'")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": [{"shape": "box"}]})"),
              AllOf(HasSubstr("objects[0]"), HasSubstr("missing required key 'name'")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": [
                 {"name": "lamp", "shape": "cylinder", "radius": 0.1, "center": [0, 0, 1]}]})"),
              AllOf(HasSubstr("objects[0] \"lamp\""), HasSubstr("missing required key 'height'")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": [
                 {"name": "bed", "shape": "box", "center": [0, 0, 0]}]})"),
              HasSubstr("missing required key 'size'"));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "measurements": [{"name": "m", "a": [0, 0, 0]}]})"),
              AllOf(HasSubstr("measurements[0]"), HasSubstr("missing required key 'b'")));
}

TEST(SceneJson, WrongTypesAndValuesAreNamed) {
  EXPECT_THAT(error_of(R"({"room": {"size": "big"}})"),
              AllOf(HasSubstr("room.size"), HasSubstr("expected an array of 3 numbers, found a string")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4]}})"), HasSubstr("found an array of 2"));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, -4, 2]}})"), HasSubstr("positive"));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2], "wall_color": [300, 0, 0]}})"),
              AllOf(HasSubstr("room.wall_color"), HasSubstr("0..255")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2], "texture": "marble"}})"),
              AllOf(HasSubstr("room.texture"), HasSubstr("unknown texture 'marble'")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": {"name": "bed"}})"),
              AllOf(HasSubstr("objects"), HasSubstr("expected an array, found an object")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": [
                 {"name": "x", "shape": "sphere", "center": [0, 0, 0]}]})"),
              AllOf(HasSubstr("objects[0] \"x\".shape"), HasSubstr("unknown shape 'sphere'")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": [
                 {"name": 5, "shape": "box", "size": [1, 1, 1], "center": [0, 0, 0]}]})"),
              AllOf(HasSubstr("objects[0].name"), HasSubstr("expected a string, found a number")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"views": 0}})"),
              AllOf(HasSubstr("scanner.views"), HasSubstr("integer")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"views": 2.5}})"), HasSubstr("scanner.views"));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"seed": -1}})"),
              AllOf(HasSubstr("scanner.seed"), HasSubstr("non-negative integer")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"noise": "no"}})"),
              AllOf(HasSubstr("scanner.noise"), HasSubstr("true or false")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"model": "kinect_v3"}})"),
              AllOf(HasSubstr("unknown scanner model 'kinect_v3'"), HasSubstr("kinect_v1")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": [{"name": "m", "shape": "mesh",
                 "center": [0, 0, 0], "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                 "triangles": [[0, 1, 3]]}]})"),
              AllOf(HasSubstr("objects[0] \"m\".triangles[0]"), HasSubstr("from 0 to 2")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "objects": [{"name": "m", "shape": "mesh",
                 "center": [0, 0, 0], "file": "m.ply", "vertices": [[0, 0, 0]], "triangles": []}]})"),
              HasSubstr("not both"));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"pitch_deg": []}})"),
              HasSubstr("scanner.pitch_deg"));
  // One view count a pitch row, or one for all.
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"views": [40, 20], "pitch_deg": [0]}})"),
              AllOf(HasSubstr("scanner.views"), HasSubstr("2 view counts for 1 pitch rows")));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"views": [40, 0], "pitch_deg": [0, -45]}})"),
              HasSubstr("scanner.views[1]"));
  EXPECT_THAT(error_of(R"({"room": {"size": [3, 4, 2]}, "scanner": {"views": []}})"),
              HasSubstr("scanner.views"));
  EXPECT_THAT(error_of(R"([1, 2, 3])"), HasSubstr("scene: expected an object, found an array"));
}

TEST(SceneJson, BadJsonReportsFileAndLine) {
  const std::string message = error_of("{\n  \"room\": {\"size\": [3, 4, 2]},\n  \"objects\": [,]\n}", "broken.json");
  EXPECT_THAT(message, AllOf(HasSubstr("broken.json:3:"), HasSubstr("not valid JSON")));
  EXPECT_THAT(error_of(""), HasSubstr("not valid JSON"));
}

TEST(SceneJson, ReadSceneReportsMissingFileAndMeshFile) {
  const auto dir = test::scratch_dir();
  EXPECT_THROW(read_scene(dir / "nope.json"), InputError);
  std::ofstream(dir / "scene.json") << R"({"room": {"size": [3, 4, 2]}, "objects": [
      {"name": "statue", "shape": "mesh", "file": "statue.ply", "center": [0, 0, 0.5]}]})";
  try {
    read_scene(dir / "scene.json");
    FAIL() << "missing mesh file accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("scene.json"), HasSubstr("objects[0] \"statue\".file"),
                                HasSubstr("statue.ply")));
  }
}

}  // namespace
}  // namespace locard::sim
