// TUM RGB-D layout: rgb.txt, depth.txt, groundtruth.txt, associations.txt, intrinsics.json and
// capture.json (a bundle, see fuzz_util.hpp) beside rgb/1.png and depth/1.png, read by
// read_tum_sequence; the first listed frame is then loaded as the pipeline would.
#include "fuzz_util.hpp"

#include <locard/io/rgbd_sequence.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace locard_fuzz;
  const auto folder = scratch().fresh();
  write_file(folder / "rgb" / "1.png", tiny_png(false));
  write_file(folder / "depth" / "1.png", tiny_png(true));
  write_bundle(folder, as_text(data, size),
               {"rgb.txt", "depth.txt", "groundtruth.txt", "associations.txt", "intrinsics.json",
                "capture.json"});
  expect_documented_errors([&] {
    const auto sequence = locard::read_tum_sequence(folder);
    if (!sequence.frames.empty()) (void)sequence.load_frame(0);
  });
  return 0;
}
