// The case's ad-hoc measurements file (case_measurements.hpp): every kind written and read back
// field for field, rewritten byte for byte, a file from before "snapped_to_feature" existed
// read as it was meant, and malformed files refused with the file and the place named.
#include <locard/forensics/case_measurements.hpp>

#include <locard/core/error.hpp>
#include <locard/forensics/case_folder.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.hpp"

#include <cmath>
#include <fstream>
#include <functional>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;
using nlohmann::json;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

SnappedPoint snapped(const Vector3d& given, const Vector3d& at, SnapFeature feature) {
  SnappedPoint p;
  p.given = given;
  p.snapped = at;
  p.feature = feature;
  p.covariance = Eigen::Vector3d(1e-6, 4e-6, 4e-6).asDiagonal();  // sqrt(trace) = 3 mm
  p.views = 13;
  p.points = 751;
  p.planes = 2;
  return p;
}

PlaneEstimate plane(const Vector3d& point, const Vector3d& normal) {
  PlaneEstimate p;
  p.point = point;
  p.normal = normal;
  p.rms_m = 0.0011;
  p.points = 640;
  p.offset_sigma_m = 0.0007;
  p.normal_sigma_rad = 0.5 * M_PI / 180.0;
  return p;
}

// One of each kind: a distance with one end not snapped, renamed twice; a point-to-plane
// distance, withdrawn; an angle. Values that are not short decimals (1/3, 0.1 + 0.2) so that
// a round trip that loses a bit shows.
std::vector<CaseMeasurement> three_measurements() {
  PointToPointMeasurement d;
  d.a = snapped({0.39, -1.6, 0.55}, {0.1 + 0.2, -1.6000998825648, 0.5495291674264977},
                SnapFeature::Edge);
  d.b = snapped({0.85, -1.6, 0.55}, {0.85, -1.6, 0.55}, SnapFeature::NotSnapped);
  d.distance_m = 1.0 / 3.0;
  d.standard_uncertainty_m = 0.0053;
  d.expanded_uncertainty_m = 0.0106;
  CaseMeasurement first = case_measurement("bed width", d);
  first.created = "2026-12-06T12:00:00Z";
  first.revisions.previous_names = {"bed", "bed, end to end"};

  PointToPlaneMeasurement p;
  p.point = snapped({1, 1, 0}, {1, 1, 0.0004}, SnapFeature::Face);
  p.plane = plane({1.92, 1, 0.0004}, {-1, 0, 0});
  p.distance_m = -0.9231;  // signed: behind the plane's normal
  p.standard_uncertainty_m = 0.0027;
  p.expanded_uncertainty_m = 0.0055;
  CaseMeasurement second = case_measurement("to wall", p);
  second.created = "2026-12-06T12:00:01Z";
  second.revisions.withdrawn_reason = "picked the floor, not the wall";
  second.revisions.withdrawn_at = "2026-12-06T12:05:00Z";

  PlaneAngleMeasurement a;
  a.first = plane({1.92, 0, 1.4}, {-1, 0, 0});
  a.second = plane({0, 1.99, 1.4}, {0, -1, 0});
  a.angle_deg = 89.9065;
  a.standard_uncertainty_deg = 0.096;
  a.expanded_uncertainty_deg = 0.192;
  CaseMeasurement third = case_measurement("walls", a);
  third.created = "2026-12-06T12:00:02Z";
  return {first, second, third};
}

void expect_same_end(const MeasuredEnd& x, const MeasuredEnd& y) {
  EXPECT_EQ(x.given, y.given);  // bit for bit: the file holds doubles exactly
  EXPECT_EQ(x.snapped, y.snapped);
  EXPECT_EQ(x.feature, y.feature);
  EXPECT_EQ(x.snapped_to_feature, y.snapped_to_feature);
  EXPECT_EQ(x.views, y.views);
  EXPECT_EQ(x.points, y.points);
  EXPECT_EQ(x.planes, y.planes);
  EXPECT_EQ(x.standard_uncertainty_m, y.standard_uncertainty_m);
}

void expect_same_plane(const MeasuredPlane& x, const MeasuredPlane& y) {
  EXPECT_EQ(x.point, y.point);
  EXPECT_EQ(x.normal, y.normal);
  EXPECT_EQ(x.rms_m, y.rms_m);
  EXPECT_EQ(x.points, y.points);
  EXPECT_EQ(x.offset_sigma_m, y.offset_sigma_m);
  EXPECT_EQ(x.normal_sigma_deg, y.normal_sigma_deg);
}

TEST(CaseMeasurements, FromTheMeasuringFunctionsAsRecorded) {
  const std::vector<CaseMeasurement> all = three_measurements();
  ASSERT_TRUE(all[0].a && all[0].b);
  EXPECT_NEAR(all[0].a->standard_uncertainty_m, 0.003, 1e-15);
  EXPECT_EQ(all[0].a->snapped_to_feature, true);
  EXPECT_EQ(all[0].b->snapped_to_feature, false);
  EXPECT_EQ(all[0].coverage_factor, 2.0);
  EXPECT_EQ(all[0].unit(), "m");
  ASSERT_TRUE(all[1].a && all[1].plane);
  EXPECT_FALSE(all[1].b || all[1].second_plane || all[1].coverage_factor);
  EXPECT_NEAR(all[1].plane->normal_sigma_deg, 0.5, 1e-12);
  ASSERT_TRUE(all[2].plane && all[2].second_plane);
  EXPECT_FALSE(all[2].a || all[2].b);
  EXPECT_EQ(all[2].unit(), "deg");
}

TEST(CaseMeasurements, EveryKindReadsBackFieldForFieldAndRewritesByteForByte) {
  const fs::path path = test::scratch_dir() / "measurements" / "measurements.json";
  const std::vector<CaseMeasurement> written = three_measurements();
  write_case_measurements(path, written);
  const std::vector<CaseMeasurement> read = read_case_measurements(path);
  ASSERT_EQ(read.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    SCOPED_TRACE(written[i].name);
    const CaseMeasurement& w = written[i];
    const CaseMeasurement& r = read[i];
    EXPECT_EQ(r.name, w.name);
    EXPECT_EQ(r.kind, w.kind);
    EXPECT_EQ(r.value, w.value);
    EXPECT_EQ(r.standard_uncertainty, w.standard_uncertainty);
    EXPECT_EQ(r.expanded_uncertainty, w.expanded_uncertainty);
    EXPECT_EQ(r.coverage_factor, w.coverage_factor);
    EXPECT_EQ(r.created, w.created);
    EXPECT_EQ(r.revisions.previous_names, w.revisions.previous_names);
    EXPECT_EQ(r.revisions.withdrawn_reason, w.revisions.withdrawn_reason);
    EXPECT_EQ(r.revisions.withdrawn_at, w.revisions.withdrawn_at);
    ASSERT_EQ(r.a.has_value(), w.a.has_value());
    ASSERT_EQ(r.b.has_value(), w.b.has_value());
    ASSERT_EQ(r.plane.has_value(), w.plane.has_value());
    ASSERT_EQ(r.second_plane.has_value(), w.second_plane.has_value());
    if (w.a) expect_same_end(*r.a, *w.a);
    if (w.b) expect_same_end(*r.b, *w.b);
    if (w.plane) expect_same_plane(*r.plane, *w.plane);
    if (w.second_plane) expect_same_plane(*r.second_plane, *w.second_plane);
  }
  // The file's keys, as `locard measure` has always written them.
  const json j = json::parse(slurp(path));
  EXPECT_EQ(j["measurements"][0]["b"]["feature"], "not snapped");
  EXPECT_EQ(j["measurements"][0]["b"]["snapped_to_feature"], false);
  EXPECT_TRUE(j["measurements"][1].contains("point"));
  EXPECT_EQ(j["measurements"][1]["withdrawn"]["at"], "2026-12-06T12:05:00Z");
  EXPECT_TRUE(j["measurements"][2].contains("angle_deg"));
  EXPECT_TRUE(j["measurements"][2]["second"].contains("normal_sigma_deg"));

  const std::string json_bytes = slurp(path);
  const std::string csv_bytes = slurp(fs::path(path).replace_extension(".csv"));
  write_case_measurements(path, read);
  EXPECT_EQ(slurp(path), json_bytes);
  EXPECT_EQ(slurp(fs::path(path).replace_extension(".csv")), csv_bytes);
  EXPECT_EQ(csv_bytes,
            "name,kind,value,unit,expanded_uncertainty,a_feature,b_feature,created,status,"
            "previous_names\n"
            "bed width,point_to_point,0.33333,m,0.01060,edge,not snapped,2026-12-06T12:00:00Z,"
            "current,\"bed; bed, end to end\"\n"
            "to wall,point_to_plane,-0.92310,m,0.00550,face,plane,2026-12-06T12:00:01Z,"
            "\"withdrawn 2026-12-06T12:05:00Z: picked the floor, not the wall\",\n"
            "walls,plane_angle,89.90650,deg,0.19200,,,2026-12-06T12:00:02Z,current,\n");
}

TEST(CaseMeasurements, AMissingFileIsNoMeasurements) {
  EXPECT_TRUE(read_case_measurements(test::scratch_dir() / "none.json").empty());
  EXPECT_EQ(case_measurements_csv({}),
            "name,kind,value,unit,expanded_uncertainty,a_feature,b_feature,created,status,"
            "previous_names\n");
}

// Before snapping said when it did not snap, an end left where it was picked was also called
// "face" and the file had no "snapped_to_feature": such an end is not taken as fixed by the
// model, and rewriting the file (a rename) adds nothing to it.
TEST(CaseMeasurements, AFileFromBeforeSnappedToFeatureReadsAsItWasMeant) {
  const fs::path path = test::scratch_dir() / "measurements.json";
  write_case_measurements(path, three_measurements());
  json j = json::parse(slurp(path));
  j["measurements"][0]["a"].erase("snapped_to_feature");
  j["measurements"][0]["b"].erase("snapped_to_feature");
  j["measurements"][0]["b"]["feature"] = "face";
  const std::string old_bytes = j.dump(1) + "\n";
  std::ofstream(path, std::ios::binary) << old_bytes;

  const std::vector<CaseMeasurement> read = read_case_measurements(path);
  EXPECT_FALSE(read[0].a->snapped_to_feature.has_value());
  EXPECT_FALSE(read[0].b->fixed_by_model());
  EXPECT_EQ(read[0].b->feature, SnapFeature::Face);
  EXPECT_TRUE(read[1].a->fixed_by_model());
  write_case_measurements(path, read);
  EXPECT_EQ(slurp(path), old_bytes);
}

TEST(CaseMeasurements, AppendedInTheCaseWithTheTimeAndAName) {
  const fs::path root = test::scratch_dir() / "case";
  CaseFolder c = CaseFolder::create(root, false);
  std::vector<CaseMeasurement> all = three_measurements();
  all[0].created.clear();
  EXPECT_EQ(append_case_measurement(c, all[0]),
            (std::vector<fs::path>{kCaseMeasurementsJson, kCaseMeasurementsCsv}));
  append_case_measurement(c, all[2]);
  CaseMeasurement unnamed = all[2];
  unnamed.name.clear();
  EXPECT_THROW(append_case_measurement(c, unnamed), InputError);
  const std::vector<CaseMeasurement> read = read_case_measurements(c.path(kCaseMeasurementsJson));
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].created.size(), std::string("2026-12-06T12:00:00Z").size());
  EXPECT_EQ(read[1].created, "2026-12-06T12:00:02Z");  // kept when given
  EXPECT_EQ(read[1].name, "walls");
}

TEST(CaseMeasurements, TheWriterRefusesWhatTheReaderWould) {
  const fs::path path = test::scratch_dir() / "measurements.json";
  std::vector<CaseMeasurement> all = three_measurements();
  all[0].b.reset();  // a distance with one end
  EXPECT_THROW(write_case_measurements(path, all), InputError);
  all = three_measurements();
  all[2].a = all[0].a;  // an angle with an end
  EXPECT_THROW(write_case_measurements(path, all), InputError);
  all = three_measurements();
  all[1].value = std::nan("");
  EXPECT_THROW(write_case_measurements(path, all), InputError);
  all = three_measurements();
  all[1].name.clear();
  EXPECT_THROW(write_case_measurements(path, all), InputError);
  EXPECT_FALSE(fs::exists(path));  // nothing written
}

// A valid file changed by `edit` must be refused naming the file and each of `places`.
void expect_refused(const std::function<void(json&)>& edit, std::vector<std::string> places) {
  const fs::path path = test::scratch_dir() / "measurements.json";
  write_case_measurements(path, three_measurements());
  json j = json::parse(slurp(path));
  edit(j);
  std::ofstream(path, std::ios::binary) << j.dump(1);
  try {
    read_case_measurements(path);
    ADD_FAILURE() << "accepted: " << places.back();
  } catch (const InputError& e) {
    const std::string what = e.what();
    places.push_back(path.string());
    for (const std::string& place : places)
      EXPECT_NE(what.find(place), std::string::npos) << "'" << place << "' not in: " << what;
  }
}

TEST(CaseMeasurements, AMalformedFileIsRefusedWithTheFileAndThePlaceNamed) {
  expect_refused([](json& j) { j["measurements"][1].erase("distance_m"); },
                 {"measurement 2 \"to wall\"", "missing required key 'distance_m'"});
  expect_refused([](json& j) { j["measurements"][0]["b"]["feature"] = "knob"; },
                 {"measurement 1 \"bed width\".b.feature", "unknown feature \"knob\""});
  expect_refused([](json& j) { j["measurements"][2]["second"]["points"] = -3; },
                 {"measurement 3 \"walls\".second.points", "expected a whole number >= 0"});
  expect_refused([](json& j) { j["measurements"][0]["a"]["given"] = json::array({1, 2}); },
                 {"measurement 1 \"bed width\".a.given", "expected an array of 3 numbers"});
  expect_refused([](json& j) { j["measurements"][0]["b"]["snapped_to_feature"] = true; },
                 {"measurement 1 \"bed width\".b.snapped_to_feature", "contradicts"});
  expect_refused([](json& j) { j["measurements"][2]["colour"] = "red"; },
                 {"measurement 3 \"walls\"", "unknown key 'colour'"});
  expect_refused([](json& j) { j["measurements"][1]["kind"] = "area"; },
                 {"measurement 2 \"to wall\".kind", "unknown kind \"area\""});
  expect_refused([](json& j) { j["measurements"][0]["previous_names"] = "bed"; },
                 {"measurement 1 \"bed width\"", "'previous_names' is not a list"});
  expect_refused([](json& j) { j["measurements"][2]["expanded_uncertainty_deg"] = -0.1; },
                 {"measurement 3 \"walls\".expanded_uncertainty_deg", "expected a number >= 0"});
  expect_refused([](json& j) { j["measurements"][1].erase("name"); },
                 {"measurement 2", "missing required key 'name'"});
  expect_refused([](json& j) { j["measurements"] = json::object(); },
                 {"measurements", "expected an array"});

  const fs::path path = test::scratch_dir() / "broken.json";
  std::ofstream(path) << R"({"measurements": [{"name": "x",)";
  try {
    read_case_measurements(path);
    ADD_FAILURE() << "a file that is not JSON was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path.string() + ": not valid JSON"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace locard::forensics
