// The Stanford range-scan alignment file (bun.conf): read_stanford_conf, with two small scans
// beside it that `bmesh` lines may name.
#include "fuzz_util.hpp"

#include <locard/io/stanford_conf.hpp>

namespace {
constexpr std::string_view kScanPly =
    "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
    "property float z\nend_header\n0 0 0\n";
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto folder = scratch().fresh();
  write_file(folder / "bun000.ply", kScanPly);
  write_file(folder / "bun045.ply", kScanPly);
  write_file(folder / "bun.conf", as_text(data, size));
  expect_documented_errors([&] { (void)locard::read_stanford_conf(folder / "bun.conf"); });
  return 0;
}
