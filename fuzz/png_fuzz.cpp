// PNG through Locard's decoders: the fast path (libdeflate) and libpng behind it, as colour
// and as 16-bit depth, plus the header-only size probe.
#include "fuzz_util.hpp"

#include <locard/io/image_io.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto path = scratch().fresh() / "input.png";
  write_file(path, as_text(data, size));
  expect_documented_errors([&] { (void)locard::read_image_info(path); });
  expect_documented_errors([&] { (void)locard::read_color_image(path); });
  expect_documented_errors([&] { (void)locard::read_depth_image(path); });
  return 0;
}
