// Renaming and withdrawing a case's markers, measurements and trajectory analyses (issue 15,
// item 6): each edit is one logged step, nothing is erased (earlier names and the withdrawal
// stay in the object and its CSV row), the case still verifies, a withdrawn marker cannot be
// used as a point, a withdrawn trajectory cannot start a simulation, and the viewer's API
// makes the same edits and lists the same objects as the CLI.
#include <locard/forensics/case_edits.hpp>

#include <locard/core/error.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/evidence_markers.hpp>
#include <locard/forensics/measurement.hpp>
#include <locard/forensics/trajectory_analysis.hpp>
#include <locard/sim/physics_scenario.hpp>
#include <locard/viewer/case_api.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.hpp"

#include <algorithm>
#include <fstream>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<json> log_lines(const fs::path& root) {
  std::vector<json> out;
  std::ifstream in(root / "log.jsonl");
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(json::parse(line));
  return out;
}

// A case holding two markers, two measurements both named "measurement" (the CLI's default
// name) and two trajectory analyses, each added by a logged step as the commands do.
fs::path make_case() {
  const fs::path root = test::scratch_dir() / "case";
  CaseFolder c = CaseFolder::create(root, false);
  {
    std::ofstream(c.path("case.json")) << R"({"title": "edits"})";
    LogStep s;
    s.step = "create";
    s.outputs = {"case.json"};
    c.append_log_step(s);
  }
  {
    MarkerSet set;
    EvidenceMarker m;
    m.label = "hole";
    m.world = {1.0, 0.5, 1.2};
    set.add(m);
    m.label = "casing";
    m.world = {0.3, -0.2, 0.0};
    set.add(m);
    CaseChange change(c, {"evidence/markers.json", "evidence/markers.csv"});
    write_markers(c.path("evidence/markers.json"), set);
    LogStep s;
    s.step = "marker add";
    s.outputs = {"evidence/markers.json", "evidence/markers.csv"};
    change.commit(s);
  }
  for (double d : {0.8, 1.25}) {
    CaseChange change(c, {"measurements/measurements.json", "measurements/measurements.csv"});
    PointToPointMeasurement m;
    m.distance_m = d;
    m.expanded_uncertainty_m = 0.004;
    LogStep s;
    s.step = "measure";
    s.outputs = append_measurement(c, "measurement", m);
    change.commit(s);
  }
  {
    std::vector<TrajectoryAnalysis> all(2);
    all[0].name = "shot 1";
    all[0].points = {{0, 0, 1.2}, {0.5, 0, 1.25}};
    all[0].direction = {1, 0, 0.1};
    all[1].name = "shot 2";
    all[1].points = {{0, 1, 1.2}, {0.5, 1, 1.0}};
    all[1].direction = {1, 0, -0.4};
    CaseChange change(c, {"trajectories/analyses.json", "trajectories/analyses.csv"});
    write_trajectory_analyses(c.path("trajectories/analyses.json"), all);
    LogStep s;
    s.step = "trajectory";
    s.outputs = {"trajectories/analyses.json", "trajectories/analyses.csv"};
    change.commit(s);
  }
  return root;
}

CaseEditResult edit(const fs::path& root, CaseObjectKind kind, const std::string& which,
                    CaseEditKind what, const std::string& text) {
  CaseFolder c = CaseFolder::open(root, CaseAccess::Change);
  CaseEdit e;
  e.object = kind;
  e.which = which;
  e.edit = what;
  (what == CaseEditKind::Rename ? e.new_name : e.reason) = text;
  return apply_case_edit(c, e);
}

TEST(CaseEdits, AMarkerRenamedAndAnotherWithdrawnStayInTheCaseAndTheLog) {
  const fs::path root = make_case();
  const std::size_t before = log_lines(root).size();
  const CaseEditResult r =
      edit(root, CaseObjectKind::Marker, "hole", CaseEditKind::Rename, "entry hole");
  EXPECT_EQ(r.summary, "marker 1 renamed 'entry hole' (was 'hole')");
  edit(root, CaseObjectKind::Marker, "2", CaseEditKind::Withdraw, "photographed twice");

  const MarkerSet set = read_markers(root / "evidence/markers.json");
  ASSERT_EQ(set.markers.size(), 2u);  // nothing erased
  EXPECT_EQ(set.markers[0].label, "entry hole");
  EXPECT_EQ(set.markers[0].revisions.previous_names, std::vector<std::string>{"hole"});
  EXPECT_FALSE(set.markers[0].revisions.withdrawn());
  EXPECT_TRUE(set.markers[1].revisions.withdrawn());
  EXPECT_EQ(set.markers[1].revisions.withdrawn_reason, "photographed twice");
  EXPECT_EQ(set.markers[1].world, Eigen::Vector3d(0.3, -0.2, 0.0));
  // The withdrawn marker is refused as a point, by number and by label; the renamed one found.
  EXPECT_THROW((void)set.find_usable("2"), InputError);
  EXPECT_THROW((void)set.find_usable("casing"), InputError);
  ASSERT_NE(set.find_usable("entry hole"), nullptr);
  EXPECT_EQ(set.find_usable("hole"), nullptr);

  const std::string csv = slurp(root / "evidence/markers.csv");
  EXPECT_NE(csv.find(",status,previous_labels\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("1,entry hole,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",current,hole\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("withdrawn 20"), std::string::npos) << csv;
  EXPECT_NE(csv.find(": photographed twice"), std::string::npos) << csv;

  const std::vector<json> log = log_lines(root);
  ASSERT_EQ(log.size(), before + 2);
  EXPECT_EQ(log[before]["step"], "marker rename");
  EXPECT_EQ(log[before]["parameters"]["new_name"], "entry hole");
  EXPECT_EQ(log[before]["parameters"]["object"]["label"], "hole");
  EXPECT_EQ(log[before]["parameters"]["source"], "cli");
  EXPECT_EQ(log[before + 1]["step"], "marker withdraw");
  EXPECT_EQ(log[before + 1]["parameters"]["reason"], "photographed twice");
  const VerifyReport v = verify_case(root);
  EXPECT_TRUE(v.ok()) << (v.problems.empty() ? "" : v.problems.front().detail);
}

TEST(CaseEdits, RefusalsWriteNothing) {
  const fs::path root = make_case();
  edit(root, CaseObjectKind::Marker, "casing", CaseEditKind::Withdraw, "duplicate");
  const std::string log_before = slurp(root / "log.jsonl");
  const std::string markers_before = slurp(root / "evidence/markers.json");
  // Withdrawn already; renamed onto a label in use; no reason; no new name; no such marker.
  EXPECT_THROW(edit(root, CaseObjectKind::Marker, "casing", CaseEditKind::Withdraw, "again"), InputError);
  EXPECT_THROW(edit(root, CaseObjectKind::Marker, "casing", CaseEditKind::Rename, "x"), InputError);
  EXPECT_THROW(edit(root, CaseObjectKind::Marker, "1", CaseEditKind::Rename, "casing"), InputError);
  EXPECT_THROW(edit(root, CaseObjectKind::Marker, "1", CaseEditKind::Withdraw, ""), InputError);
  EXPECT_THROW(edit(root, CaseObjectKind::Marker, "1", CaseEditKind::Rename, ""), InputError);
  EXPECT_THROW(edit(root, CaseObjectKind::Marker, "7", CaseEditKind::Rename, "y"), InputError);
  EXPECT_THROW(edit(root, CaseObjectKind::Trajectory, "shot 9", CaseEditKind::Rename, "y"), InputError);
  EXPECT_EQ(slurp(root / "log.jsonl"), log_before);
  EXPECT_EQ(slurp(root / "evidence/markers.json"), markers_before);
  EXPECT_TRUE(verify_case(root).ok());
}

TEST(CaseEdits, MeasurementsWithTheSameNameAreChosenByPosition) {
  const fs::path root = make_case();
  try {
    edit(root, CaseObjectKind::Measurement, "measurement", CaseEditKind::Rename, "door");
    FAIL() << "an ambiguous name was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("#1, #2"), std::string::npos) << e.what();
  }
  edit(root, CaseObjectKind::Measurement, "#2", CaseEditKind::Rename, "door width");
  edit(root, CaseObjectKind::Measurement, "measurement", CaseEditKind::Withdraw, "wrong wall");
  EXPECT_THROW(edit(root, CaseObjectKind::Measurement, "#3", CaseEditKind::Rename, "z"), InputError);
  const json all = json::parse(slurp(root / "measurements/measurements.json"));
  ASSERT_EQ(all["measurements"].size(), 2u);
  EXPECT_EQ(all["measurements"][0]["withdrawn"]["reason"], "wrong wall");
  EXPECT_DOUBLE_EQ(all["measurements"][0]["distance_m"].get<double>(), 0.8);  // kept
  EXPECT_EQ(all["measurements"][1]["name"], "door width");
  EXPECT_EQ(all["measurements"][1]["previous_names"][0], "measurement");
  const std::string csv = slurp(root / "measurements/measurements.csv");
  EXPECT_NE(csv.find("door width,point_to_point,1.25000,m,0.00400,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(": wrong wall,\n"), std::string::npos) << csv;
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3);
  EXPECT_TRUE(verify_case(root).ok());
}

TEST(CaseEdits, AWithdrawnTrajectoryStaysListedButStartsNoSimulation) {
  const fs::path root = make_case();
  edit(root, CaseObjectKind::Trajectory, "shot 1", CaseEditKind::Rename, "shot A");
  edit(root, CaseObjectKind::Trajectory, "shot 2", CaseEditKind::Withdraw, "ricochet, not a line");
  const auto all = read_trajectory_analyses(root / "trajectories/analyses.json");
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].name, "shot A");
  EXPECT_TRUE(all[1].revisions.withdrawn());
  const auto lines = sim::read_trajectory_analyses(root / "trajectories/analyses.json");
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_FALSE(lines[0].withdrawn);
  EXPECT_TRUE(lines[1].withdrawn);
  const std::string scenario = R"({"name": "s", "duration": 0.5, "projectiles": [
      {"name": "bullet", "trajectory": "shot 2", "speed": 300}]})";
  // The one still standing starts one.
  EXPECT_NO_THROW((void)sim::parse_scenario(R"({"name": "s", "duration": 0.5, "projectiles": [
      {"name": "bullet", "trajectory": "shot A", "speed": 300}]})", "scenario.json", root, root));
  try {
    (void)sim::parse_scenario(scenario, "scenario.json", root, root);
    FAIL() << "a withdrawn trajectory started a simulation";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("withdrawn"), std::string::npos) << e.what();
  }
  const std::string csv = slurp(root / "trajectories/analyses.csv");
  EXPECT_NE(csv.find("shot A,2,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",current,shot 1\n"), std::string::npos) << csv;
  EXPECT_TRUE(verify_case(root).ok());
}

TEST(CaseEdits, TheViewerEditsAndListsWhatTheCliDoes) {
  const fs::path root = make_case();
  viewer::CaseApi api(root);
  auto r = api.handle("POST", "/api/evidence/rename",
                      R"({"kind": "trajectory", "which": "shot 2", "name": "shot B"})");
  ASSERT_EQ(r.status, 201) << r.body;
  r = api.handle("POST", "/api/evidence/withdraw",
                 R"({"kind": "measurement", "which": "#1", "reason": "tape slipped"})");
  ASSERT_EQ(r.status, 201) << r.body;
  r = api.handle("POST", "/api/evidence/withdraw", R"({"kind": "marker", "which": "1"})");
  EXPECT_EQ(r.status, 400) << r.body;  // no reason
  r = api.handle("POST", "/api/evidence/rename", R"({"kind": "photo", "which": "1", "name": "a"})");
  EXPECT_EQ(r.status, 400) << r.body;

  r = api.handle("GET", "/api/trajectories", "");
  ASSERT_EQ(r.status, 200);
  const json t = json::parse(r.body);
  EXPECT_EQ(t["analyses"][1]["name"], "shot B");
  EXPECT_EQ(t["analyses"][1]["previous_names"][0], "shot 2");
  r = api.handle("GET", "/api/measurements", "");
  const json m = json::parse(r.body);
  EXPECT_EQ(m["measurements"][0]["withdrawn"]["reason"], "tape slipped");
  EXPECT_FALSE(m["measurements"][1].contains("withdrawn"));

  const std::vector<json> log = log_lines(root);
  EXPECT_EQ(log.back()["step"], "measurement withdraw");
  EXPECT_EQ(log.back()["parameters"]["source"], "viewer");
  // The CLI's listing shows what the viewer did.
  const CaseFolder c = CaseFolder::open(root, CaseAccess::Read);
  EXPECT_NE(case_objects_csv(c, CaseObjectKind::Trajectory).find("shot B,"), std::string::npos);
  EXPECT_NE(case_objects_csv(c, CaseObjectKind::Measurement).find(": tape slipped"), std::string::npos);
  EXPECT_TRUE(verify_case(root).ok());
}

}  // namespace
}  // namespace locard::forensics
