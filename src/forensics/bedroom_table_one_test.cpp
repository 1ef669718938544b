// The "must show" on the full simulated bedroom (66 views in two rings, default parameters, the
// scan `make demo` makes): Table I from the reconstructed case, room width within 1 cm, every
// object dimension within 5 mm, each error inside its stated (k = 2) uncertainty; and the
// fresh case verifies. About a minute in release; skipped under AddressSanitizer (slow).
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/reconstruct.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.hpp"

#include <cmath>
#include <fstream>

namespace locard::forensics {
namespace {

using test::kSanitized;

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
  for (const auto& row : table["rows"]) {
    const std::string name = row["name"];
    ASSERT_FALSE(row.contains("not_measured")) << name << ": " << row["not_measured"];
    const double error = row["error_m"], u = row["expanded_uncertainty_m"];
    std::printf("%-16s real %.4f model %.4f error %+6.1f mm U %.1f mm\n", name.c_str(),
                row["real_m"].get<double>(), row["model_m"].get<double>(), 1000 * error, 1000 * u);
    EXPECT_LE(std::abs(error), name == "Room width" ? 0.010 : 0.005) << name;
    EXPECT_LE(std::abs(error), u) << name << ": error outside its stated uncertainty";
    EXPECT_LT(u, 0.02) << name << ": an uncertainty this large says nothing";
  }
  EXPECT_TRUE(verify_case(dir / "case").ok());
}

}  // namespace
}  // namespace locard::forensics
