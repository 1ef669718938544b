// CaseModel::load reads case.json's "sensor", alignment/pose_covariance.json and mesh/mesh.json
// of a case: every malformed shape, missing key, wrong type or out-of-range number is an
// InputError naming the file (and view) - never a raw JSON exception (found by case_model_fuzz:
// fuzz/corpus/case_model/crash-view-without-frame-index.txt).
#include <locard/forensics/case_model.hpp>

#include <locard/core/error.hpp>
#include <locard/forensics/case_folder.hpp>

#include <gtest/gtest.h>

#include "test_support.hpp"

#include <fstream>
#include <string>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

constexpr const char* kSensor =
    R"({"sensor": {"width": 512, "height": 424, "fx": 361.5, "fy": 367.2, "cx": 255.5,
        "cy": 211.5, "depth_scale": 1000.0, "noise_model": "kinect_v2"}})";
constexpr const char* kIdentity = "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";
const std::string kZero6 = "[[0,0,0,0,0,0],[0,0,0,0,0,0],[0,0,0,0,0,0],[0,0,0,0,0,0],"
                           "[0,0,0,0,0,0],[0,0,0,0,0,0]]";

std::string one_view(const std::string& fields) {
  return R"({"views": [{)" + fields + "}]}";
}
std::string good_view() {
  return one_view(R"("frame_index": 0, "timestamp": 0.5, "T_world_camera": )" +
                  std::string(kIdentity) + R"(, "covariance": )" + kZero6);
}

// A case folder the model can be loaded from: a two-triangle mesh, manifest, case.json and
// pose_covariance.json as given.
fs::path make_case(const std::string& name, const std::string& case_json,
                   const std::string& covariance_json) {
  const fs::path root = test::scratch_dir() / name;
  fs::remove_all(root);
  write(root / "manifest.json", R"({"files": {}})");
  write(root / "mesh" / "mesh.ply",
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n");
  write(root / "case.json", case_json);
  write(root / "alignment" / "pose_covariance.json", covariance_json);
  return root;
}

// The InputError's message (empty when another exception, or none, was thrown).
std::string load_error(const fs::path& root) {
  try {
    (void)CaseModel::load(CaseFolder::open(root, CaseAccess::Read));
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
}

TEST(CaseModelLoad, ReadsAWellFormedCase) {
  const fs::path root = make_case("good", kSensor, good_view());
  const CaseModel model = CaseModel::load(CaseFolder::open(root, CaseAccess::Read));
  ASSERT_EQ(model.views().size(), 1u);
  EXPECT_EQ(model.intrinsics().width, 512);
  EXPECT_DOUBLE_EQ(model.intrinsics().fx, 361.5);
  EXPECT_EQ(model.noise().name, "kinect_v2");
}

TEST(CaseModelLoad, ViewsTheSelfCheckFlaggedAreNotMeasuredFrom) {
  // reconstruct marks each view "verified"; a flagged view's depth is left out of the
  // measurements as it is of the mesh. Without the field (older cases, laser scans) a view is
  // read; a field that is not a boolean names the file and the view.
  auto view = [](int frame, const std::string& verified) {
    return R"({"frame_index": )" + std::to_string(frame) + R"(, "timestamp": 0, "T_world_camera": )" +
           std::string(kIdentity) + verified + R"(, "covariance": )" + kZero6 + "}";
  };
  const fs::path root = make_case(
      "flagged", kSensor,
      R"({"views": [)" + view(0, R"(, "verified": true)") + "," + view(1, R"(, "verified": false)") +
          "," + view(2, "") + "]}");
  const CaseModel model = CaseModel::load(CaseFolder::open(root, CaseAccess::Read));
  ASSERT_EQ(model.views().size(), 2u);
  EXPECT_EQ(model.views()[0].frame_index, 0);
  EXPECT_EQ(model.views()[1].frame_index, 2);
  const std::string error =
      load_error(make_case("verified_text", kSensor, R"({"views": [)" + view(0, R"(, "verified": "yes")") + "]}"));
  EXPECT_NE(error.find("pose_covariance.json"), std::string::npos) << error;
  EXPECT_NE(error.find("views[0]"), std::string::npos) << error;
  EXPECT_NE(error.find("verified"), std::string::npos) << error;
}

TEST(CaseModelLoad, AViewWithoutAFrameIndexNamesTheFileAndTheView) {
  const fs::path root = make_case(
      "no_frame_index", kSensor,
      one_view(R"("timestamp": 0.5, "T_world_camera": )" + std::string(kIdentity) +
               R"(, "covariance": )" + kZero6));
  const std::string error = load_error(root);
  EXPECT_NE(error.find("pose_covariance.json"), std::string::npos) << error;
  EXPECT_NE(error.find("views[0]"), std::string::npos) << error;
  EXPECT_NE(error.find("frame_index"), std::string::npos) << error;
}

TEST(CaseModelLoad, WrongShapesAndTypesAreInputErrors) {
  const std::string id(kIdentity);
  struct Case {
    const char* name;
    std::string case_json;
    std::string covariance_json;
    const char* names;  // the file the message must name
  };
  const std::vector<Case> cases = {
      {"views_not_array", kSensor, R"({"views": 3})", "pose_covariance.json"},
      {"cov_is_array", kSensor, "[]", "pose_covariance.json"},
      {"pose_3x4", kSensor,
       one_view(R"("frame_index": 0, "timestamp": 0, "T_world_camera": [[1,0,0,0],[0,1,0,0],[0,0,1,0]], "covariance": )" + kZero6),
       "pose_covariance.json"},
      {"pose_strings", kSensor,
       one_view(R"("frame_index": 0, "timestamp": 0, "T_world_camera": [["a",0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "covariance": )" + kZero6),
       "pose_covariance.json"},
      {"covariance_5x6", kSensor,
       one_view(R"("frame_index": 0, "timestamp": 0, "T_world_camera": )" + id +
                R"(, "covariance": [[0,0,0,0,0,0]])"),
       "pose_covariance.json"},
      {"no_sensor", R"({"inputs": {}})", good_view(), "case.json"},
      {"sensor_string", R"({"sensor": "kinect"})", good_view(), "case.json"},
      {"width_text", R"({"sensor": {"width": "512", "height": 424, "fx": 1, "fy": 1, "cx": 0, "cy": 0}})",
       good_view(), "case.json"},
      {"width_huge", R"({"sensor": {"width": 1e10, "height": 424, "fx": 1, "fy": 1, "cx": 0, "cy": 0}})",
       good_view(), "case.json"},
      {"fx_negative", R"({"sensor": {"width": 4, "height": 3, "fx": -1, "fy": 1, "cx": 0, "cy": 0}})",
       good_view(), "case.json"},
      {"noise_model_number", R"({"sensor": {"width": 4, "height": 3, "fx": 1, "fy": 1, "cx": 0, "cy": 0, "noise_model": 7}})",
       good_view(), "case.json"},
      {"depth_scale_zero", R"({"sensor": {"width": 4, "height": 3, "fx": 1, "fy": 1, "cx": 0, "cy": 0, "depth_scale": 0}})",
       good_view(), "case.json"},
  };
  for (const Case& c : cases) {
    const std::string error = load_error(make_case(c.name, c.case_json, c.covariance_json));
    EXPECT_NE(error.find(c.names), std::string::npos) << c.name << ": '" << error << "'";
  }
}

TEST(CaseModelLoad, AMeshJsonThatIsNotAnObjectIsAnInputError) {
  const fs::path root = make_case("mesh_json_array", kSensor, good_view());
  write(root / "mesh" / "mesh.json", "[1, 2]");
  const std::string error = load_error(root);
  EXPECT_NE(error.find("mesh.json"), std::string::npos) << error;
}

}  // namespace
}  // namespace locard::forensics
