// Intrinsics: Locard's / Open3D's intrinsics JSON and a plain 3x3 K text file, same bytes.
#include "fuzz_util.hpp"

#include <locard/io/rgbd_sequence.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto folder = scratch().fresh();
  write_file(folder / "intrinsics.json", as_text(data, size));
  write_file(folder / "camera-intrinsics.txt", as_text(data, size));
  expect_documented_errors(
      [&] { (void)locard::read_intrinsics_json_with_scale(folder / "intrinsics.json"); });
  expect_documented_errors(
      [&] { (void)locard::read_intrinsics_matrix_txt(folder / "camera-intrinsics.txt", 640, 480); });
  return 0;
}
