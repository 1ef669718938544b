// Reference measurement files (measurements.json / reference.json), with markers that
// resolve ("marker:1", "door") and ones that do not.
#include "fuzz_util.hpp"

#include <locard/forensics/measurement.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto path = scratch().fresh() / "reference.json";
  write_file(path, as_text(data, size));
  const auto lookup = [](const std::string& name) -> std::optional<Eigen::Vector3d> {
    if (name == "marker:1" || name == "door") return Eigen::Vector3d(1.0, 2.0, 0.5);
    return std::nullopt;
  };
  expect_documented_errors([&] { (void)locard::forensics::read_reference_measurements(path, lookup); });
  expect_documented_errors([&] { (void)locard::forensics::read_reference_measurements(path); });
  return 0;
}
