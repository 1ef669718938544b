// CaseModel::load reads case.json's "sensor", alignment/pose_covariance.json and mesh/mesh.json
// of a case: every malformed shape, missing key, wrong type or out-of-range number is an
// InputError naming the file (and view) - never a raw JSON exception (found by case_model_fuzz:
// fuzz/corpus/case_model/crash-view-without-frame-index.txt).
#include <locard/forensics/case_model.hpp>

#include <locard/core/error.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/io/image_io.hpp>

#include <gtest/gtest.h>

#include "test_support.hpp"

#include <cmath>
#include <fstream>
#include <set>
#include <string>
#include <utility>

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

// The raw points around a spot leave out mixed ("flying") pixels - a depth between two surfaces
// across a jump - but not a surface whose depth climbs steeply from pixel to pixel (a table top
// seen from just above it). One camera at the origin looking along +z, a 64 x 48 depth image
// in three bands of rows:
//   rows  2-13: a slope climbing 3 cm a pixel (each pixel strictly between its neighbours,
//               6 cm across them: the jump a mixed pixel shows) up to column 40, a wall at
//               3 m behind it;
//   rows 18-29: a plateau at 1.0 m, a pixel at 1.25 m, a plateau at 1.5 m;
//   rows 34-45: the plateau at 1.0 m, a pixel at 1.1 m, then a surface climbing 20 cm a pixel
//               (a floor far behind an edge, at grazing incidence) - the mixed pixel's far
//               side goes on climbing, its near side does not.
TEST(CaseModelLocalPoints, MixedPixelsAreLeftOutAndSteepSurfacesKept) {
  const fs::path dir = test::scratch_dir() / "local-points-mixed";
  fs::create_directories(dir);
  CameraIntrinsics K;
  K.width = 64;
  K.height = 48;
  K.fx = K.fy = 50.0;
  K.cx = 31.5;
  K.cy = 23.5;
  DepthImage depth(K.width, K.height, 0);
  auto band = [](int v) { return v < 16 ? 0 : (v < 32 ? 1 : 2); };
  auto depth_m = [&](int u, int v) {
    switch (band(v)) {
      case 0: return u <= 40 ? 1.0 + 0.03 * u : 3.0;
      case 1: return u < 32 ? 1.0 : (u == 32 ? 1.25 : 1.5);
      default: return u < 32 ? 1.0 : (u == 32 ? 1.1 : 1.5 + 0.2 * (u - 33));
    }
  };
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u)
      if (v % 16 != 15 && v % 16 != 0) depth.at(u, v) = static_cast<std::uint16_t>(std::lround(depth_m(u, v) * 1000.0));
  ViewRecord view;
  view.frame_index = 0;
  view.depth_path = dir / "depth.png";
  write_png(view.depth_path, depth);
  TriangleMesh far_behind;  // nothing in front of the camera to hide a point
  far_behind.vertices = {{0.f, 0.f, -10.f}, {0.1f, 0.f, -10.f}, {0.f, 0.1f, -10.f}};
  far_behind.triangles = {{0u, 1u, 2u}};
  const CaseModel model(far_behind, {view}, K, 1000.0, SensorNoiseModel{}, 0.01);
  // Which pixels came back: each point projected into the image.
  auto pixels_near = [&](int u, int v, double radius) {
    const double z = depth_m(u, v);
    const LocalPoints L = model.local_points({(u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z}, radius);
    EXPECT_TRUE(L.from_raw_depth);
    std::set<std::pair<int, int>> px;
    for (const Eigen::Vector3d& q : L.points)
      px.insert({static_cast<int>(std::lround(K.fx * q.x() / q.z() + K.cx)),
                 static_cast<int>(std::lround(K.fy * q.y() / q.z() + K.cy))});
    return px;
  };
  // The slope: every pixel with two valid neighbours on each side along the row is kept.
  const auto slope = pixels_near(20, 8, 0.3);
  for (int u = 16; u <= 24; ++u)
    for (int v = 6; v <= 10; ++v) EXPECT_TRUE(slope.count({u, v})) << "slope pixel " << u << ", " << v;
  // Its last pixel, strictly between the one before it and the wall, with a flat wall beyond:
  // left out as a mixed pixel would be (the depth stencil cannot tell them apart; measured
  // in docs/forensics.md), the one before it kept.
  const auto edge = pixels_near(39, 8, 0.15);
  for (int v = 6; v <= 10; ++v) {
    EXPECT_FALSE(edge.count({40, v})) << "the slope's last pixel at row " << v;
    EXPECT_TRUE(edge.count({39, v})) << "the slope's last but one pixel at row " << v;
  }
  // Between two plateaus: the mixed pixel is out, the plateaus' pixels beside it in.
  const auto step = pixels_near(31, 24, 0.6);
  for (int v = 20; v <= 27; ++v) {
    EXPECT_FALSE(step.count({32, v})) << "mixed pixel at row " << v;
    EXPECT_TRUE(step.count({31, v})) << "near plateau at row " << v;
    EXPECT_TRUE(step.count({33, v})) << "far plateau at row " << v;
  }
  // Between a plateau and a steep surface: still mixed (its near side stops).
  const auto steep = pixels_near(31, 40, 0.6);
  for (int v = 36; v <= 43; ++v) {
    EXPECT_FALSE(steep.count({32, v})) << "mixed pixel before a steep surface at row " << v;
    EXPECT_TRUE(steep.count({31, v})) << "plateau at row " << v;
  }
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
