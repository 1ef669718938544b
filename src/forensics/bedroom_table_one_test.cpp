// The "must show" on the full simulated bedroom (66 views in two rings, default parameters, the
// scan `make demo` makes): Table I from the reconstructed case, room width within 1 cm, every
// object dimension within 5 mm, each error inside its stated (k = 2) uncertainty; and the
// fresh case verifies; and the same distances picked as a person clicks (issue 15's pick
// study). About a minute in release; skipped under AddressSanitizer (slow).
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_model.hpp>
#include <locard/forensics/measurement.hpp>
#include <locard/forensics/reconstruct.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numeric>

namespace locard::forensics {
namespace {

using test::kSanitized;

using Eigen::Vector3d;

// The closest point of triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5).
Vector3d closest_on_triangle(const Vector3d& p, const Vector3d& a, const Vector3d& b, const Vector3d& c) {
  const Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double den = 1.0 / (va + vb + vc);
  return a + ab * vb * den + ac * vc * den;
}

// Where clicks land on the model's mesh, as bench/pick_study.py places them.
class MeshPicks {
 public:
  explicit MeshPicks(const TriangleMesh& mesh) : mesh_(mesh) {
    for (const auto& t : mesh.triangles) {
      const Vector3d a = vertex(t[0]), b = vertex(t[1]), c = vertex(t[2]);
      centroids_.push_back((a + b + c) / 3.0);
      normals_.push_back((b - a).cross(c - a).normalized());
    }
  }
  // The mean normal of the n triangles nearest p, each turned to agree with the nearest.
  Vector3d normal_at(const Vector3d& p, std::size_t n = 30) const {
    Vector3d sum = Vector3d::Zero();
    const std::vector<std::size_t> near = nearest(p, n);
    for (auto f : near) sum += normals_[f] * (normals_[f].dot(normals_[near[0]]) < 0 ? -1.0 : 1.0);
    return sum.normalized();
  }
  // The closest point of the mesh near p (the 64 triangles with the nearest centroids).
  Vector3d onto_mesh(const Vector3d& p) const {
    Vector3d best = p;
    double best_d = std::numeric_limits<double>::infinity();
    for (auto f : nearest(p, 64)) {
      const auto& t = mesh_.triangles[f];
      const Vector3d q = closest_on_triangle(p, vertex(t[0]), vertex(t[1]), vertex(t[2]));
      if ((q - p).norm() < best_d) {
        best_d = (q - p).norm();
        best = q;
      }
    }
    return best;
  }

 private:
  Vector3d vertex(std::uint32_t i) const { return mesh_.vertices[i].cast<double>(); }
  std::vector<std::size_t> nearest(const Vector3d& p, std::size_t n) const {
    std::vector<std::size_t> idx(centroids_.size());
    std::iota(idx.begin(), idx.end(), 0);
    n = std::min(n, idx.size());
    std::partial_sort(idx.begin(), idx.begin() + static_cast<long>(n), idx.end(), [&](auto x, auto y) {
      return (centroids_[x] - p).squaredNorm() < (centroids_[y] - p).squaredNorm();
    });
    idx.resize(n);
    return idx;
  }
  const TriangleMesh& mesh_;
  std::vector<Vector3d> centroids_, normals_;
};

// Issue 15's pick study on the bedroom: each Table I distance measured with both ends moved
// 1.5 cm along the surface at right angles to the line, both ways, then onto the mesh where a
// click lands. A row counts within U only with both ends snapped. None may be off by more than
// 3 U (bed width's corner end was 11 mm off at U 2.2 mm while a sliver plane of the bed's top
// carried it); at least 18 of the 24 within U (20 on 7 December 2026: the socket's centre is
// never snapped, the chair seat's far corner is hidden from one side).
void expect_picks_hold(const std::filesystem::path& scan, const std::filesystem::path& case_dir) {
  const CaseModel model = CaseModel::load(CaseFolder::open(case_dir, CaseAccess::Read));
  const MeshPicks picks(model.mesh());
  const auto refs = nlohmann::json::parse(std::ifstream(scan / "measurements.json"))["measurements"];
  int within = 0, total = 0;
  for (const auto& r : refs) {
    const Vector3d a(r["a"][0].get<double>(), r["a"][1].get<double>(), r["a"][2].get<double>());
    const Vector3d b(r["b"][0].get<double>(), r["b"][1].get<double>(), r["b"][2].get<double>());
    const Vector3d d = (b - a).normalized();
    for (const double side : {1.0, -1.0}) {
      Vector3d ends[2];
      for (int k = 0; k < 2; ++k) {
        const Vector3d p = k == 0 ? a : b;
        Vector3d t = picks.normal_at(p).cross(d);
        if (t.norm() < 1e-6) t = Vector3d::UnitZ().cross(d);
        ends[k] = picks.onto_mesh(p + side * 0.015 * t.normalized());
      }
      const PointToPointMeasurement m = measure_point_to_point(model, ends[0], ends[1]);
      const double error = m.distance_m - r["distance_m"].get<double>(), u = m.expanded_uncertainty_m;
      const bool snapped = is_snapped(m.a.feature) && is_snapped(m.b.feature);
      ++total;
      within += snapped && std::abs(error) <= u;
      std::printf("picks %-16s %+.0f error %+6.1f mm U %.1f mm %s/%s\n", r["name"].get<std::string>().c_str(),
                  side, 1000 * error, 1000 * u, std::string(to_string(m.a.feature)).c_str(),
                  std::string(to_string(m.b.feature)).c_str());
      EXPECT_LE(std::abs(error), 3 * u) << r["name"] << " picked " << side << ": beyond 3 U";
    }
  }
  EXPECT_EQ(total, 24);
  EXPECT_GE(within, 18) << "of " << total << " picked distances within U";
}

TEST(BedroomTableOne, EveryDimensionWithinBoundsAndItsUncertainty) {
  if (kSanitized) GTEST_SKIP() << "full 66-view reconstruction: release builds only";
  const auto dir = test::scratch_dir();
  const auto sim = test::run_cli("scan-sim -o '" + (dir / "scan").string() + "'");
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  ReconstructParameters p;
  p.pdf = false;
  const ReconstructSummary s = reconstruct_case(dir / "scan", dir / "case", p, false);
  EXPECT_EQ(s.registered, 66u);  // two rings: 50 views at -10 degrees, 16 at -50
  const auto table = nlohmann::json::parse(std::ifstream(dir / "case" / "measurements" / "table.json"));
  ASSERT_EQ(table["rows"].size(), 12u);
  const double truncation =
      nlohmann::json::parse(std::ifstream(dir / "case" / "mesh" / "mesh.json"))["truncation"].get<double>();
  int not_snapped = 0;
  for (const auto& row : table["rows"]) {
    const std::string name = row["name"];
    ASSERT_FALSE(row.contains("not_measured")) << name << ": " << row["not_measured"];
    const double error = row["error_m"], u = row["expanded_uncertainty_m"];
    std::printf("%-16s real %.4f model %.4f error %+6.1f mm U %.1f mm%s\n", name.c_str(),
                row["real_m"].get<double>(), row["model_m"].get<double>(), 1000 * error, 1000 * u,
                row["ends_snapped"] ? "" : " (an end not snapped)");
    // A row with an end nothing fixed reads the tape point back: never counted within U, and
    // its U holds that end only to the mesh (the fusion's truncation band), not millimetres.
    if (!row["ends_snapped"].get<bool>()) {
      ++not_snapped;
      EXPECT_FALSE(row["within_uncertainty"].get<bool>()) << name;
      EXPECT_GE(u, 2.0 * truncation / std::sqrt(3.0)) << name << ": U of an end not snapped";
      continue;
    }
    // An end fixed by the outermost of a few points (the chair seat's far corner, hidden by its
    // back) is half a pixel's footprint beyond it, uncertain by a footprint (here 18 mm): held
    // to 1 cm and its U to 3 cm.
    bool outermost = false;
    for (const char* end : {"a", "b"})
      outermost |= row["measurement"][end]["feature"].get<std::string>().ends_with("(outermost point)");
    EXPECT_LE(std::abs(error), name == "Room width" || outermost ? 0.010 : 0.005) << name;
    EXPECT_LE(std::abs(error), u) << name << ": error outside its stated uncertainty";
    EXPECT_LT(u, outermost ? 0.03 : 0.02) << name << ": an uncertainty this large says nothing";
  }
  // The table's near corner (its top seen at grazing) and the socket's centre (a face
  // ends nothing across the wall) are not snapped at the tape points (7 December 2026).
  EXPECT_LE(not_snapped, 2) << "Table I rows with an end not snapped";
  EXPECT_TRUE(verify_case(dir / "case").ok());
  expect_picks_hold(dir / "scan", dir / "case");
}

}  // namespace
}  // namespace locard::forensics
