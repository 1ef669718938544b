// PLY (ASCII and binary, point clouds and meshes): read_ply and read_ply_mesh.
#include "fuzz_util.hpp"

#include <locard/io/ply.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto path = scratch().fresh() / "input.ply";
  write_file(path, as_text(data, size));
  expect_documented_errors([&] { (void)locard::read_ply(path); });
  expect_documented_errors([&] { (void)locard::read_ply_mesh(path); });
  return 0;
}
