// Snapping and point-to-point measurement on synthetic geometry with known answers: a crate
// (0.8 x 0.5 x 0.5 m) on the floor of a small room, seen by seven simulated Kinect v2 views
// (axial, lateral and mixed-pixel noise, dropouts) on an arc in front of it. The depth images
// are written as a case's would be, so measurements go back to raw depth points as in a real
// case. What each end snapped to is checked by kind, the distances against the crate's true
// size within the stated expanded uncertainty, and picks moved 1.5 cm along the surface at
// right angles to the line (as a person clicks) must still hold. An end with nothing across
// the line is "not snapped", and a Table I row with one is never "within U".
#include <locard/forensics/measurement.hpp>

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>
#include <locard/sim/kinect_model.hpp>
#include <locard/sim/scene.hpp>
#include <locard/sim/scene_mesh.hpp>
#include <locard/sim/view_renderer.hpp>

#include <gtest/gtest.h>

#include "test_support.hpp"

#include <cmath>
#include <memory>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;

constexpr double kLength = 0.8, kWidth = 0.5, kHeight = 0.5;  // the crate: x, y, z

// Splits every triangle into n^2 so no edge is longer than `max_edge` (a reconstructed mesh
// is dense; distance_to_mesh and the snapping fallback read its vertices).
TriangleMesh densify(const TriangleMesh& in, double max_edge) {
  TriangleMesh out;
  for (const auto& t : in.triangles) {
    const Eigen::Vector3f a = in.vertices[t[0]], b = in.vertices[t[1]], c = in.vertices[t[2]];
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const int n = std::max(1, static_cast<int>(std::ceil(longest / max_edge)));
    const auto base = static_cast<std::uint32_t>(out.vertices.size());
    auto index = [n, base](int i, int j) {  // i along ab, j along ac, i + j <= n
      return base + static_cast<std::uint32_t>(i * (n + 1) - i * (i - 1) / 2 + j);
    };
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n - i; ++j)
        out.vertices.push_back(a + (b - a) * (static_cast<float>(i) / n) + (c - a) * (static_cast<float>(j) / n));
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n - i; ++j) {
        out.triangles.push_back({index(i, j), index(i + 1, j), index(i, j + 1)});
        if (j + 1 <= n - i - 1) out.triangles.push_back({index(i + 1, j), index(i + 1, j + 1), index(i, j + 1)});
      }
  }
  return out;
}

// A camera at `eye` looking at `target`, x right and y down in the image (z up in the world).
Isometry3d look_at(const Vector3d& eye, const Vector3d& target) {
  const Vector3d z = (target - eye).normalized();
  const Vector3d x = z.cross(Vector3d::UnitZ()).normalized();
  const Vector3d y = z.cross(x);
  Isometry3d T = Isometry3d::Identity();
  T.linear() << x, y, z;
  T.translation() = eye;
  return T;
}

sim::SceneObject box(const std::string& name, const Vector3d& center, const Vector3d& size) {
  sim::SceneObject b;
  b.name = name;
  b.center = center;
  b.size = size;
  return b;
}

// `objects` in a room as seen by seven views of `kinect` on an arc of radius `distance` at
// `eye_height` looking at (0, 0, 0.3), every depth image written under the scratch folder `tag`.
// The model's mesh shows `meshed` where given (a fusion that rounded something away), else
// what the views saw.
CaseModel* scene_model(const std::vector<sim::SceneObject>& objects, const sim::KinectModel& kinect,
                       const SensorNoiseModel& noise, double distance, double eye_height,
                       const std::string& tag, const std::vector<sim::SceneObject>* meshed = nullptr) {
  const fs::path dir = test::scratch_dir() / tag;
  fs::create_directories(dir);
  sim::Scene scene;
  scene.room.size = {2 * distance + 1.5, 2 * distance + 1.5, 2.4};
  scene.objects = objects;
  const sim::ViewRenderer renderer(sim::build_scene_mesh(scene));
  std::vector<ViewRecord> views;
  for (int k = 0; k < 7; ++k) {
    const double a = (-60.0 + 20.0 * k) * M_PI / 180.0;
    ViewRecord v;
    v.frame_index = k;
    v.T_world_camera = look_at({distance * std::sin(a), -distance * std::cos(a), eye_height}, {0.0, 0.0, 0.3});
    v.depth_path = dir / ("depth-" + std::to_string(k) + ".png");
    write_png(v.depth_path, renderer.render(kinect, v.T_world_camera, 11, static_cast<std::uint64_t>(k)).depth);
    views.push_back(v);
  }
  sim::Scene shown = scene;
  if (meshed) shown.objects = *meshed;
  return new CaseModel(densify(sim::build_scene_mesh(shown).mesh, 0.02), views, kinect.intrinsics,
                       kinect.depth_scale, noise, 0.01);
}

// The crate on the floor, as scene_model sees it.
CaseModel* crate_model(const sim::KinectModel& kinect, const SensorNoiseModel& noise,
                       double distance, double eye_height, const std::string& tag) {
  return scene_model({box("crate", {0.0, 0.0, 0.5 * kHeight}, {kLength, kWidth, kHeight})}, kinect,
                     noise, distance, eye_height, tag);
}

class Snapping : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // Kinect v2 at 1.4 m (1 mm depth steps).
    model_ = crate_model(sim::KinectModel::kinect_v2(), SensorNoiseModel{}, 1.4, 1.2, "near");
  }
  static void TearDownTestSuite() {
    delete model_;
    model_ = nullptr;
  }
  static const CaseModel& model() { return *model_; }
  static CaseModel* model_;
};
CaseModel* Snapping::model_ = nullptr;

// Within the stated U and a few millimetres of the truth.
void expect_measures(const PointToPointMeasurement& m, double truth, const std::string& what) {
  const double error = m.distance_m - truth;
  EXPECT_LE(std::abs(error), m.expanded_uncertainty_m)
      << what << ": " << m.distance_m << " m, error " << error * 1000 << " mm, U "
      << m.expanded_uncertainty_m * 1000 << " mm (ends " << to_string(m.a.feature) << ", "
      << to_string(m.b.feature) << ")";
  EXPECT_LT(std::abs(error), 0.006) << what;
  EXPECT_GT(m.expanded_uncertainty_m, 0.0005) << what;
  EXPECT_LT(m.expanded_uncertainty_m, 0.015) << what;
}

TEST_F(Snapping, EndFacesAcrossTheLineAreFaces) {
  // The crate's length between its end faces (x = -0.4 and 0.4), picked on the faces (where
  // clicks land on the model) and moved 1.5 cm along them at right angles to the line.
  for (const double dy : {-0.015, 0.0, 0.015})
    for (const double dz : {-0.015, 0.0, 0.015}) {
      const auto m = measure_point_to_point(model(), {-0.401, -0.1 + dy, 0.3 + dz}, {0.402, -0.1 + dy, 0.3 + dz});
      EXPECT_EQ(m.a.feature, SnapFeature::Face) << dy << " " << dz;
      EXPECT_EQ(m.b.feature, SnapFeature::Face) << dy << " " << dz;
      expect_measures(m, kLength, "end faces");
    }
}

TEST_F(Snapping, TheTopEndsAtEdgesAndCorners) {
  // Along the top (z = 0.5) from end to end, picked 1 cm inside the edges: the top is a side
  // plane ending at an edge; near the front (y = -0.25) the front face is a second side plane
  // and the end is a corner. Picks moved 1.5 cm across the line (in y) still hold.
  for (const double dy : {-0.015, 0.0, 0.015}) {
    const auto m = measure_point_to_point(model(), {-0.39, 0.05 + dy, 0.5}, {0.39, 0.05 + dy, 0.5});
    EXPECT_TRUE(m.a.feature == SnapFeature::Edge || m.a.feature == SnapFeature::Corner)
        << to_string(m.a.feature);
    EXPECT_TRUE(m.b.feature == SnapFeature::Edge || m.b.feature == SnapFeature::Corner)
        << to_string(m.b.feature);
    expect_measures(m, kLength, "top edges");
  }
  const auto corner = measure_point_to_point(model(), {-0.39, -0.247, 0.497}, {0.39, -0.247, 0.497});
  EXPECT_EQ(corner.a.feature, SnapFeature::Corner);
  EXPECT_EQ(corner.b.feature, SnapFeature::Corner);
  expect_measures(corner, kLength, "top front corners");
}

TEST_F(Snapping, PicksOffTheSurfaceLandOnItAndSnap) {
  // Clicks near the crate's ends that miss its surface: 1 cm above the top, and in the air
  // 1.2 cm in front of the front face (a side the line runs along). Each lands on the plane the
  // investigator meant, across the line, and snaps to the end's edge or corner there; `given`
  // keeps the click.
  const auto above = measure_point_to_point(model(), {-0.39, 0.05, 0.51}, {0.39, 0.05, 0.51});
  EXPECT_TRUE(is_snapped(above.a.feature) && is_snapped(above.b.feature))
      << to_string(above.a.feature) << " " << to_string(above.b.feature);
  EXPECT_NEAR(above.a.given.z(), 0.51, 1e-12);
  EXPECT_NEAR(above.a.snapped.z(), kHeight, 0.004);  // on the top, not 1 cm above it
  expect_measures(above, kLength, "1 cm above the top");
  const auto in_front = measure_point_to_point(model(), {-0.39, -0.262, 0.49}, {0.39, -0.262, 0.49});
  EXPECT_TRUE(is_snapped(in_front.a.feature) && is_snapped(in_front.b.feature))
      << to_string(in_front.a.feature) << " " << to_string(in_front.b.feature);
  EXPECT_NEAR(in_front.b.snapped.y(), -0.5 * kWidth, 0.004);
  expect_measures(in_front, kLength, "in front of the front face");
}

TEST_F(Snapping, AFloorWithNothingAcrossTheLineIsNotSnapped) {
  // Two points on the open floor, measured along it: nothing ends or faces the line, so each
  // end keeps the picked place along the line - said so, not labelled as a snap.
  const Vector3d a{-0.55, -0.8, 0.0}, b{0.55, -0.8, 0.0};
  const auto m = measure_point_to_point(model(), a, b);
  EXPECT_EQ(m.a.feature, SnapFeature::NotSnapped);
  EXPECT_EQ(m.b.feature, SnapFeature::NotSnapped);
  EXPECT_FALSE(is_snapped(m.a.feature));
  EXPECT_NEAR(m.a.snapped.x(), a.x(), 1e-9);  // as given along the line
  EXPECT_NEAR(m.b.snapped.x(), b.x(), 1e-9);
  EXPECT_NE(describe(m.a.feature).find("not snapped: the picked point is used as given"), std::string::npos);
  // Where it was picked is known only to the mesh, which the fusion places within its
  // truncation band: each end's variance along the line holds that band (uniform, t^2 / 3),
  // not just the poses' millimetres.
  const double t = model().model_truncation_m();
  EXPECT_DOUBLE_EQ(t, 4 * model().model_voxel_m());
  const Vector3d d = (b - a).normalized();
  EXPECT_GE(d.dot(m.a.covariance * d), t * t / 3.0);
  EXPECT_GE(d.dot(m.b.covariance * d), t * t / 3.0);
  EXPECT_GE(m.expanded_uncertainty_m, 2.0 * std::sqrt(2.0 / 3.0) * t);
  // Table I with the tape value equal to the picked distance: the model "reads it back", and
  // that row is never counted as measured within U.
  const auto rows = compare_with_reference(model(), {{"floor", a, b, (b - a).norm()}});
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_FALSE(rows[0].ends_snapped);
  EXPECT_FALSE(rows[0].within_uncertainty);
  const auto crate = compare_with_reference(model(), {{"crate", {-0.401, -0.1, 0.3}, {0.402, -0.1, 0.3}, kLength}});
  EXPECT_TRUE(crate[0].ends_snapped);
  EXPECT_TRUE(crate[0].within_uncertainty) << crate[0].error_m << " " << crate[0].expanded_uncertainty_m;
}

TEST_F(Snapping, WithoutADirectionAPointGoesOntoTheNearestPlane) {
  const SnappedPoint p = snap_point(model(), {0.1, -0.262, 0.2});  // 1.2 cm in front of the front face
  EXPECT_EQ(p.feature, SnapFeature::Face);
  EXPECT_NEAR(p.snapped.y(), -0.5 * kWidth, 0.004);
  EXPECT_GE(p.views, 3u);
  EXPECT_THROW(snap_point(model(), {0.0, -0.8, 0.3}), InputError);  // in the air: off the model
}

// A bed between a headboard and a footboard (5 cm thick, 0.6 m high) whose sides are flush with
// the bed's: the bed's front side and the boards' are one plane, running on past the boards'
// faces. The top's front edge measured from board to board, the picks moved 1.5 cm along the
// surface at right angles to the line - onto the top, up the boards' faces: each end is the
// board's face, where the top stops. The front side going on is the boards', not a reason to
// leave the end unsnapped (the bedroom's bed length was, with the pick on its headboard).
// Picks moved down the front side are not asserted: at the footboard the views see its face
// too obliquely near that corner to find it there (docs/forensics.md, seen and not fixed).
TEST(SnappingAtAFlushSide, TheTopEndsAtTheFaceItMeets) {
  constexpr double kBedLength = 0.8, kBedHeight = 0.3, kBoard = 0.05;
  const double board_x = 0.5 * (kBedLength + kBoard);
  const std::unique_ptr<CaseModel> model(scene_model(
      {box("bed", {0.0, 0.0, 0.5 * kBedHeight}, {kBedLength, kWidth, kBedHeight}),
       box("headboard", {board_x, 0.0, 0.3}, {kBoard, kWidth, 0.6}),
       box("footboard", {-board_x, 0.0, 0.3}, {kBoard, kWidth, 0.6})},
      sim::KinectModel::kinect_v2(), SensorNoiseModel{}, 1.4, 1.2, "bed-boards"));
  const Vector3d a{-0.5 * kBedLength, -0.5 * kWidth, kBedHeight}, b{0.5 * kBedLength, -0.5 * kWidth, kBedHeight};
  for (const Vector3d& moved : {Vector3d{0.0, 0.015, 0.0}, Vector3d{0.0, 0.0, 0.015}}) {
    const auto m = measure_point_to_point(*model, a + moved, b + moved);
    for (const SnappedPoint* end : {&m.a, &m.b})
      EXPECT_TRUE(end->feature == SnapFeature::Edge || end->feature == SnapFeature::Corner)
          << to_string(end->feature) << ", picks moved " << moved.transpose();
    expect_measures(m, kBedLength, "bed top from board to board");
  }
}

// A corner the fusion rounded away: the views see the crate whole, the model's mesh shows it
// 2.5 cm short at +x. A click at the end the mesh shows is 2.8 cm short of the crate's, and its
// end snaps to the edge the depth points count there (the mesh stands 2.5 cm off it). The same
// click on a model that shows the crate whole is a point 2.8 cm inside the top - a stain beside
// an edge, say - and is not carried to the edge.
TEST(SnappingOnARoundedModel, AnEdgeTheMeshLacksIsStillTheEnd) {
  const sim::SceneObject crate = box("crate", {0.0, 0.0, 0.5 * kHeight}, {kLength, kWidth, kHeight});
  const double cut = 0.025;
  const std::vector<sim::SceneObject> rounded = {
      box("crate", {-0.5 * cut, 0.0, 0.5 * kHeight}, {kLength - cut, kWidth, kHeight})};
  const std::unique_ptr<CaseModel> model(scene_model({crate}, sim::KinectModel::kinect_v2(), SensorNoiseModel{},
                                                     1.4, 1.2, "rounded", &rounded));
  const Vector3d a{-0.39, 0.05, kHeight}, b{0.5 * kLength - cut - 0.003, 0.05, kHeight};
  const auto m = measure_point_to_point(*model, a, b);
  EXPECT_TRUE(m.b.feature == SnapFeature::Edge || m.b.feature == SnapFeature::Corner) << to_string(m.b.feature);
  // Counted 2.8 cm beyond the click from the 6 mm window behind it: the count's own noise
  // makes U wider than a counted edge at the click (under 15 mm).
  const double error = m.distance_m - kLength;
  EXPECT_LE(std::abs(error), m.expanded_uncertainty_m) << error << " m";
  EXPECT_LT(std::abs(error), 0.006);
  EXPECT_LT(m.expanded_uncertainty_m, 0.025);
  const std::unique_ptr<CaseModel> whole(scene_model({crate}, sim::KinectModel::kinect_v2(), SensorNoiseModel{},
                                                     1.4, 1.2, "whole"));
  const auto inside = measure_point_to_point(*whole, a, b);
  EXPECT_EQ(inside.b.feature, SnapFeature::NotSnapped) << "snapped " << (inside.b.snapped - b).norm() << " m away";
}

// A board standing 2 cm behind the crate's end, taller than the crate: along the top, the
// board's face is the first face across the line, 2.5 cm past a click 5 mm inside the top's
// edge - and not the crate's end (room 31's table before a wall: +25 mm at U 7.4 mm; here
// +19.5 mm at U 2.4 mm before the rule). A face beyond the click is in reach only within the
// edge margin or as far as the mesh stands off it. What the top's edge then gives is not good
// (the blends bridging the 2 cm gap: an edge counted 11 mm long, or not snapped; see
// docs/forensics.md), but no end is the board's, and none is claimed beyond 3 U.
TEST(SnappingBeforeAWall, AFaceBehindTheEndIsNotTheEnd) {
  const double gap = 0.02;
  const std::unique_ptr<CaseModel> model(scene_model(
      {box("crate", {0.0, 0.0, 0.5 * kHeight}, {kLength, kWidth, kHeight}),
       box("board", {0.5 * kLength + gap + 0.01, 0.0, 0.6}, {0.02, 1.0, 1.2})},
      sim::KinectModel::kinect_v2(), SensorNoiseModel{}, 1.4, 1.2, "board-behind"));
  for (const double dy : {-0.015, 0.0, 0.015}) {
    const auto m = measure_point_to_point(*model, {-0.395, 0.05 + dy, kHeight}, {0.395, 0.05 + dy, kHeight});
    EXPECT_LT(m.b.snapped.x(), 0.5 * kLength + 0.75 * gap) << "the board's face, not the crate's end";
    const double error = m.distance_m - kLength;
    if (is_snapped(m.a.feature) && is_snapped(m.b.feature)) {
      EXPECT_LE(std::abs(error), 3 * m.expanded_uncertainty_m) << error << " m, U " << m.expanded_uncertainty_m;
    }
  }
}

// A table top (0.6 x 1.2 m, 4 cm thick) seen from 30 cm above it, its length running away from
// the views: at its far end, 2.9-3.2 m away, 5-6 degrees of grazing incidence, a pixel's
// footprint on the top several centimetres long and its depth climbing by centimetres a pixel
// (each pixel strictly between its neighbours, as a mixed pixel is), the end face unseen. The
// top's length along its left side, picks moved 1.5 cm onto the top and down the side: both
// ends snap, within U.
TEST(SnappingAtGrazingIncidence, AFarTableTopEndsAtItsFarEdge) {
  constexpr double kTop = 0.77, kTopWidth = 0.6, kTopLength = 1.2;
  const std::unique_ptr<CaseModel> model(scene_model(
      {box("table top", {0.0, 0.0, kTop - 0.02}, {kTopWidth, kTopLength, 0.04})},
      sim::KinectModel::kinect_v2(), SensorNoiseModel{}, 2.6, kTop + 0.3, "grazing-top"));
  const Vector3d a{-0.5 * kTopWidth, -0.5 * kTopLength, kTop}, b{-0.5 * kTopWidth, 0.5 * kTopLength, kTop};
  for (const Vector3d& moved : {Vector3d{0.015, 0.0, 0.0}, Vector3d{0.0, 0.0, -0.015}}) {
    const auto m = measure_point_to_point(*model, a + moved, b + moved);
    EXPECT_TRUE(is_snapped(m.a.feature) && is_snapped(m.b.feature))
        << to_string(m.a.feature) << " " << to_string(m.b.feature) << ", picks moved " << moved.transpose();
    const double error = m.distance_m - kTopLength;
    EXPECT_LE(std::abs(error), m.expanded_uncertainty_m) << error << " m, picks moved " << moved.transpose();
    EXPECT_LT(std::abs(error), 0.015) << "picks moved " << moved.transpose();
  }
}

// A drum (radius 22 cm, 24 cm high) on the floor seen by a structured-light sensor from 2.2 m:
// the inlier band is nearly 2 cm, so the drum's wall - the first, largest plane - takes the
// floor's strip before its foot and the lid's beside its rim as its own. Its height picked on
// the wall's front line and moved 1.5 cm around it: each end is where the wall stops, the
// other surfaces' strips left to them: +10 and +5 mm at U 17 and 11 mm (before: +20 and +14
// mm at U 15 and 12 mm, outside U; generated room 2's drum 2 cm long at U 12 mm).
TEST(SnappingAtACylinder, ItsHeightEndsAtTheFloorAndTheLid) {
  constexpr double kRadius = 0.22, kDrumHeight = 0.24;
  sim::SceneObject drum;
  drum.name = "drum";
  drum.shape = sim::ShapeKind::Cylinder;
  drum.center = {0.0, 0.0, 0.5 * kDrumHeight};
  drum.radius = kRadius;
  drum.height = kDrumHeight;
  SensorNoiseModel structured_light;
  structured_light.name = "structured_light";
  const std::unique_ptr<CaseModel> model(scene_model({drum}, sim::KinectModel::kinect_v1(), structured_light,
                                                     2.2, 1.2, "drum-structured-light"));
  for (const double turn : {-0.015 / kRadius, 0.015 / kRadius}) {
    const Vector3d front{kRadius * std::sin(turn), -kRadius * std::cos(turn), 0.0};
    const auto m = measure_point_to_point(*model, front, front + Vector3d{0.0, 0.0, kDrumHeight});
    EXPECT_TRUE(is_snapped(m.a.feature) && is_snapped(m.b.feature))
        << to_string(m.a.feature) << " " << to_string(m.b.feature);
    const double error = m.distance_m - kDrumHeight;
    EXPECT_LE(std::abs(error), m.expanded_uncertainty_m) << error << " m, U " << m.expanded_uncertainty_m;
    EXPECT_LT(std::abs(error), 0.012) << "picks turned " << turn << " rad";
  }
}

TEST(SnapFeatureNames, EveryFeatureHasItsName) {
  EXPECT_EQ(to_string(SnapFeature::Face), "face");
  EXPECT_EQ(to_string(SnapFeature::NotSnapped), "not snapped");
  EXPECT_EQ(to_string(SnapFeature::EdgeOutermost), "edge (outermost point)");
  EXPECT_TRUE(is_snapped(SnapFeature::MeshSurface));
  EXPECT_FALSE(is_snapped(SnapFeature::NotSnapped));
}

}  // namespace
}  // namespace locard::forensics
