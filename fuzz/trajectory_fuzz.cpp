// Pose files: a TUM trajectory (groundtruth.txt) and a Redwood/Open3D .log, from the same bytes.
#include "fuzz_util.hpp"

#include <locard/io/trajectory_io.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto folder = scratch().fresh();
  write_file(folder / "groundtruth.txt", as_text(data, size));
  write_file(folder / "trajectory.log", as_text(data, size));
  expect_documented_errors([&] { (void)locard::read_tum_trajectory(folder / "groundtruth.txt"); });
  expect_documented_errors([&] { (void)locard::read_redwood_log(folder / "trajectory.log"); });
  return 0;
}
