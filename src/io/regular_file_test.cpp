// Issue 14: readers open regular files only. A FIFO named in a TUM depth list blocked
// `locard info` forever; a JSON number beyond double range escaped as nlohmann's raw
// out_of_range. Both are now InputErrors naming the file.
#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/rgbd_sequence.hpp>

#include "io/json_file.hpp"
#include "io/text_lines.hpp"
#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>

namespace locard {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

fs::path make_fifo(const fs::path& path) {
  fs::create_directories(path.parent_path());
  if (::mkfifo(path.c_str(), 0600) != 0) ADD_FAILURE() << "mkfifo " << path;
  return path;
}

std::string message_of(const auto& call) {
  try {
    call();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no InputError";
}

TEST(RegularFiles, AFifoIsRefusedByEveryReader) {
  const fs::path dir = test::scratch_dir();
  const fs::path fifo = make_fifo(dir / "pipe.ply");
  for (const std::string& m :
       {message_of([&] { read_ply(fifo); }), message_of([&] { read_depth_image(fifo); }),
        message_of([&] { io_detail::read_json_file(fifo); }),
        message_of([&] { io_detail::read_text_file(fifo); })}) {
    EXPECT_THAT(m, HasSubstr("pipe.ply"));
    EXPECT_THAT(m, HasSubstr("not a regular file"));
  }
  EXPECT_THAT(message_of([&] { io_detail::read_text_file(dir); }), HasSubstr("is a folder"));
  EXPECT_THAT(message_of([&] { io_detail::read_text_file(dir / "missing.txt"); }),
              HasSubstr("no such file"));
}

TEST(RegularFiles, AFifoInADepthListIsAnErrorNotAHang) {
  const fs::path dir = test::scratch_dir() / "tum-with-fifo";
  const fs::path office = test::shared_data() / "tum-fr3-office-16";
  fs::create_directories(dir / "rgb");
  std::string rgb_name;
  for (const auto& e : fs::directory_iterator(office / "rgb")) {
    rgb_name = e.path().filename().string();
    break;
  }
  fs::copy_file(office / "rgb" / rgb_name, dir / "rgb" / rgb_name);
  make_fifo(dir / "depth" / "0.png");
  std::ofstream(dir / "rgb.txt") << "1.0 rgb/" << rgb_name << "\n";
  std::ofstream(dir / "depth.txt") << "1.0 depth/0.png\n";
  const std::string m = message_of([&] {
    const RgbdSequence seq = open_rgbd_sequence(dir);
    seq.load_depth(0);
  });
  EXPECT_THAT(m, HasSubstr("0.png"));
  EXPECT_THAT(m, HasSubstr("not a regular file"));
}

TEST(RegularFiles, ANumberBeyondDoubleRangeIsAnInputError) {
  const fs::path file = test::scratch_dir() / "huge.json";
  std::ofstream(file) << "{\"fx\": 1e400}";
  const std::string m = message_of([&] { io_detail::read_json_file(file); });
  EXPECT_THAT(m, HasSubstr("huge.json"));
  EXPECT_THAT(m, HasSubstr("1e400"));
}

}  // namespace
}  // namespace locard
