// Evidence markers: numbering, labels, the chosen case frame, JSON/CSV round trip.
#include <locard/forensics/evidence_markers.hpp>

#include <locard/core/error.hpp>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <fstream>

namespace locard::forensics {
namespace {

using Eigen::Vector3d;

TEST(CaseFrame, FromThreePointsIsRightHandedAndOrthonormal) {
  // Origin at a room corner, x along the south wall, y into the room.
  const CaseFrame f = CaseFrame::from_points(Vector3d(-1.92, -2.0, 0), Vector3d(1.92, -2.0, 0),
                                             Vector3d(-1.92, 2.0, 0.0), "SW corner");
  EXPECT_TRUE((f.axes.transpose() * f.axes).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_NEAR(f.axes.determinant(), 1.0, 1e-12);
  const Vector3d local = f.to_local(Vector3d(0, 0, 1));
  EXPECT_NEAR(local.x(), 1.92, 1e-12);
  EXPECT_NEAR(local.y(), 2.0, 1e-12);
  EXPECT_NEAR(local.z(), 1.0, 1e-12);
  EXPECT_TRUE(f.to_world(local).isApprox(Vector3d(0, 0, 1), 1e-12));
  EXPECT_THROW(CaseFrame::from_points(Vector3d::Zero(), Vector3d::UnitX(), 2 * Vector3d::UnitX(), ""),
               InputError);
  EXPECT_THROW(CaseFrame::from_points(Vector3d::Zero(), Vector3d::Zero(), Vector3d::UnitY(), ""),
               InputError);
}

TEST(MarkerSet, NumbersAreNeverReusedAndLabelsUnique) {
  MarkerSet s;
  EvidenceMarker m;
  m.label = "cartridge case";
  m.world = Vector3d(0.1, 0.2, 0.0);
  EXPECT_EQ(s.add(m).number, 1);
  m.label = "blood stain";
  EXPECT_EQ(s.add(m).number, 2);
  EXPECT_THROW(s.add(m), InputError);  // duplicate label
  m.label = "";
  EXPECT_THROW(s.add(m), InputError);
  EXPECT_TRUE(s.remove(2));
  EXPECT_FALSE(s.remove(2));
  m.label = "bullet hole";
  EXPECT_EQ(s.add(m).number, 2);  // one past the highest left
  ASSERT_NE(s.find("marker:1"), nullptr);
  EXPECT_EQ(s.find("bullet hole")->number, 2);
  EXPECT_EQ(s.find("7"), nullptr);
}

TEST(MarkerSet, JsonAndCsvRoundTrip) {
  const auto dir = test::scratch_dir();
  MarkerSet s;
  s.frame = CaseFrame::from_points(Vector3d(1, 0, 0), Vector3d(1, 1, 0), Vector3d(0, 0, 0), "door");
  EvidenceMarker m;
  m.label = "knife, kitchen";
  m.note = "under the \"table\"";
  m.world = Vector3d(1.5, 0.5, 0.25);
  m.expanded_uncertainty_m = 0.004;
  s.add(m);
  write_markers(dir / "evidence" / "markers.json", s);
  const MarkerSet back = read_markers(dir / "evidence" / "markers.json");
  ASSERT_EQ(back.markers.size(), 1u);
  EXPECT_EQ(back.markers[0].label, "knife, kitchen");
  EXPECT_TRUE(back.markers[0].world.isApprox(m.world));
  EXPECT_TRUE(back.frame.axes.isApprox(s.frame.axes));
  const std::string csv = markers_csv(back);
  // x along world +y from (1,0,0), y along world -x: local (0.5, -0.5, 0.25).
  EXPECT_NE(csv.find("1,\"knife, kitchen\",0.5000,-0.5000,0.2500,1.5000,0.5000,0.2500,0.0040,"
                     "\"under the \"\"table\"\"\""),
            std::string::npos)
      << csv;
  EXPECT_TRUE(std::filesystem::exists(dir / "evidence" / "markers.csv"));
  EXPECT_TRUE(read_markers(dir / "none.json").markers.empty());
  { std::ofstream(dir / "bad.json") << "{\"frame\": 3}"; }
  EXPECT_THROW(read_markers(dir / "bad.json"), InputError);
}

// `locard level`: floor points picked on a floor tilted 7 degrees about a skew axis (with 1 mm
// of noise) level a frame that was off by that tilt: its z lands on the floor's normal within
// 0.2 degree, its origin on the floor, its x in the floor plane under the old x.
TEST(LevelFrame, PickedFloorPointsTurnZOntoTheFloorsNormal) {
  const Eigen::Matrix3d tilt =
      Eigen::AngleAxisd(7.0 * M_PI / 180.0, Vector3d(1, 2, 0).normalized()).toRotationMatrix();
  const Vector3d normal = tilt * Vector3d::UnitZ(), floor_point(0.3, -0.2, -1.1);
  std::vector<Vector3d> picks;
  for (int i = 0; i < 6; ++i) {
    const double a = 2.0 * M_PI * i / 6.0;
    const Vector3d in_plane = tilt * Vector3d(1.5 * std::cos(a), 1.2 * std::sin(a), 0.0);
    picks.push_back(floor_point + in_plane + 0.001 * ((i % 3) - 1) * normal);
  }
  CaseFrame current;  // the world frame: z off the floor's normal by 7 degrees
  current.origin = Vector3d(0.5, 0.5, 0.4);
  const LevelledFrame level = level_frame(current, picks);
  EXPECT_NEAR(level.tilt_deg, 7.0, 0.2);
  const double off_deg = std::acos(std::min(1.0, level.frame.axes.col(2).dot(normal))) * 180.0 / M_PI;
  EXPECT_LT(off_deg, 0.2);
  EXPECT_NEAR(normal.dot(level.frame.origin - floor_point), 0.0, 0.002);  // on the floor
  EXPECT_NEAR(level.frame.axes.col(0).dot(level.frame.axes.col(2)), 0.0, 1e-12);
  EXPECT_GT(level.frame.axes.col(0).dot(Vector3d::UnitX()), 0.99);  // under the old x
  EXPECT_NEAR(level.frame.axes.determinant(), 1.0, 1e-12);           // right-handed
  EXPECT_LT(level.rms_m, 0.002);
  // A picked point in the new frame reads z = 0 on the floor.
  EXPECT_NEAR(level.frame.to_local(picks[0]).z(), 0.0, 0.002);

  // The normal is taken on the side of the frame's z: a frame upside down stays upside down.
  CaseFrame flipped;
  flipped.axes.col(1) = -Vector3d::UnitY();
  flipped.axes.col(2) = -Vector3d::UnitZ();
  EXPECT_LT(level_frame(flipped, picks).frame.axes.col(2).dot(normal), -0.99);
}

TEST(LevelFrame, TooFewOrCollinearPointsAreRefused) {
  const CaseFrame current;
  EXPECT_THROW(level_frame(current, {Vector3d(0, 0, 0), Vector3d(1, 0, 0)}), InputError);
  try {
    level_frame(current, {Vector3d(0, 0, 0), Vector3d(1, 0.01, 0), Vector3d(2, 0, 0), Vector3d(3, 0.01, 0)});
    ADD_FAILURE() << "collinear points accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("along a line"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace locard::forensics
