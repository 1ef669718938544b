// Scene files (locard scan-sim): read_scene, with a small mesh.ply beside it that objects may
// name as their "file".
#include "fuzz_util.hpp"

#include <locard/sim/scene.hpp>

namespace {
constexpr std::string_view kMeshPly =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto folder = scratch().fresh();
  write_file(folder / "mesh.ply", kMeshPly);
  write_file(folder / "scene.json", as_text(data, size));
  expect_documented_errors([&] { (void)locard::sim::read_scene(folder / "scene.json"); });
  return 0;
}
