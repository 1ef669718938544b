// PCD (ascii, binary and binary_compressed / LZF): read_pcd.
#include "fuzz_util.hpp"

#include <locard/io/pcd.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto path = scratch().fresh() / "input.pcd";
  write_file(path, as_text(data, size));
  expect_documented_errors([&] { (void)locard::read_pcd(path); });
  return 0;
}
