// Physics scenarios (locard simulate): read_scenario with a case folder beside it, and the
// trajectory analyses file it may point at (read_trajectory_analyses), from the same bytes.
#include "fuzz_util.hpp"

#include <locard/sim/physics_scenario.hpp>

namespace {
constexpr std::string_view kMeshPly =  // a tetrahedron: objects need a solid hull
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
    "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0\n0.1 0 0\n0 0.1 0\n0 0 0.1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
constexpr std::string_view kAnalyses =
    R"({"analyses": [{"name": "rod 1", "points": [[0, 0, 1], [1, 0, 1]]}]})";
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto folder = scratch().fresh();
  write_file(folder / "mesh.ply", kMeshPly);
  write_file(folder / "case" / "trajectories" / "analyses.json", kAnalyses);
  write_file(folder / "scenario.json", as_text(data, size));
  write_file(folder / "analyses.json", as_text(data, size));
  expect_documented_errors(
      [&] { (void)locard::sim::read_scenario(folder / "scenario.json", folder / "case"); });
  expect_documented_errors(
      [&] { (void)locard::sim::read_trajectory_analyses(folder / "analyses.json"); });
  return 0;
}
