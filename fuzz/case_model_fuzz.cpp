// What a measuring command reads of a case besides its integrity files: CaseModel::load over
// case.json ("sensor"), alignment/pose_covariance.json and mesh/mesh.json (a bundle, see
// fuzz_util.hpp), beside a small mesh/mesh.ply and a manifest.json so the folder opens.
#include "fuzz_util.hpp"

#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_model.hpp>

namespace {
constexpr std::string_view kMeshPly =
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
    "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  namespace fx = locard::forensics;
  const auto folder = scratch().fresh("case");
  write_file(folder / "mesh" / "mesh.ply", kMeshPly);
  write_file(folder / "manifest.json", R"({"files": {}})");
  write_bundle(folder, as_text(data, size),
               {"case.json", "alignment/pose_covariance.json", "mesh/mesh.json"});
  expect_documented_errors([&] {
    const auto opened = fx::CaseFolder::open(folder, fx::CaseAccess::Read);
    (void)fx::CaseModel::load(opened);
  });
  return 0;
}
