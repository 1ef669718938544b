// E57 (ASTM E2807): read_e57 and merge_scans. Every 1024-byte page ends with a CRC-32C of its
// bytes; a mutation would almost always break it and stop the reader at the page check, so the
// harness rewrites each whole page's checksum before reading (the check itself is pinned by
// e57_test's damaged-file tests) and the mutations reach the header, the XML section and the
// compressed-vector packets behind it.
#include "fuzz_util.hpp"

#include "io/e57_detail.hpp"

#include <locard/io/e57.hpp>

#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  namespace e57 = locard::e57_detail;
  std::string bytes(as_text(data, size));
  auto* pages = reinterpret_cast<std::uint8_t*>(bytes.data());
  for (std::size_t at = 0; at + e57::kPageSize <= bytes.size(); at += e57::kPageSize)
    e57::seal_page(pages + at);
  const auto path = scratch().fresh() / "input.e57";
  write_file(path, bytes);
  expect_documented_errors([&] { (void)locard::merge_scans(locard::read_e57(path).scans); });
  return 0;
}
