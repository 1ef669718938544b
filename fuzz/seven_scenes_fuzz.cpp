// 7-Scenes layout: frame-00000{0,1}.pose.txt and camera-intrinsics.txt (a bundle, see
// fuzz_util.hpp) beside frame-00000{0,1}.{color,depth}.png, read by read_seven_scenes_sequence;
// the first frame is then loaded.
#include "fuzz_util.hpp"

#include <locard/io/rgbd_sequence.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto folder = scratch().fresh();
  for (const char* frame : {"frame-000000", "frame-000001"}) {
    write_file(folder / (std::string(frame) + ".color.png"), tiny_png(false));
    write_file(folder / (std::string(frame) + ".depth.png"), tiny_png(true));
  }
  write_bundle(folder, as_text(data, size),
               {"frame-000000.pose.txt", "frame-000001.pose.txt", "camera-intrinsics.txt"});
  expect_documented_errors([&] {
    const auto sequence = locard::read_seven_scenes_sequence(folder);
    if (!sequence.frames.empty()) (void)sequence.load_frame(0);
  });
  return 0;
}
