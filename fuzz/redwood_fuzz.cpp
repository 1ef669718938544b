// Redwood / Open3D layout: rgbd.match, odometry.log, pose.txt, camera_intrinsic.json and
// capture.json (a bundle, see fuzz_util.hpp) beside color/00000{0,1}.png and
// depth/00000{0,1}.png, read by read_redwood_sequence; the first frame is then loaded.
#include "fuzz_util.hpp"

#include <locard/io/rgbd_sequence.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto folder = scratch().fresh();
  for (const char* frame : {"000000.png", "000001.png"}) {
    write_file(folder / "color" / frame, tiny_png(false));
    write_file(folder / "depth" / frame, tiny_png(true));
  }
  write_bundle(folder, as_text(data, size),
               {"rgbd.match", "odometry.log", "pose.txt", "camera_intrinsic.json", "capture.json"});
  expect_documented_errors([&] {
    const auto sequence = locard::read_redwood_sequence(folder);
    if (!sequence.frames.empty()) (void)sequence.load_frame(0);
  });
  return 0;
}
