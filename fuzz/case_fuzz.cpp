// A case folder's own files: case.json, manifest.json and log.jsonl (a bundle, see
// fuzz_util.hpp) beside a small cloud/registered.ply, read by verify_case, the log-head
// readers and CaseFolder::open for reading.
#include "fuzz_util.hpp"

#include <locard/forensics/case_folder.hpp>

namespace {
constexpr std::string_view kCloudPly =
    "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
    "property float z\nend_header\n0 0 0\n";
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto folder = scratch().fresh("case");
  write_file(folder / "cloud" / "registered.ply", kCloudPly);
  write_bundle(folder, as_text(data, size), {"case.json", "manifest.json", "log.jsonl"});
  expect_documented_errors([&] { (void)locard::forensics::verify_case(folder, false); });
  expect_documented_errors([&] {
    const std::string head = locard::forensics::log_head_sha256(folder);
    (void)locard::forensics::find_log_line(folder, head);
  });
  expect_documented_errors([&] {
    const auto opened = locard::forensics::CaseFolder::open(folder, locard::forensics::CaseAccess::Read);
    (void)opened.case_json_text();
  });
  return 0;
}
