#include <locard/io/image_io.hpp>

#include <locard/core/error.hpp>

#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <png.h>
#include <zlib.h>

#include <bit>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

fs::path seven_scenes(const std::string& name) {
  return test::shared_data() / "7scenes-tsdf-fusion" / "data" / name;
}
fs::path open3d_rgbd(const std::string& name) {
  return test::shared_data() / "open3d-testdata" / "RGBD" / name;
}

std::vector<char> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& path, const std::vector<char>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Pseudo-random depth so the PNG does not compress to a few bytes (truncation must hit IDAT).
DepthImage noisy_depth(int width, int height) {
  DepthImage depth(width, height);
  std::uint32_t state = 12345u;
  for (auto& d : depth.data()) {
    state = state * 1664525u + 1013904223u;
    d = static_cast<std::uint16_t>(state >> 16);
  }
  return depth;
}

// Adam7-interlaced 16-bit gray PNG written with libpng directly: write_png never interlaces,
// but other tools do. libpng's default error handling aborts, which fails the test loudly.
void write_interlaced_depth(const fs::path& path, const DepthImage& depth) {
  FILE* file = std::fopen(path.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(depth.width()),
               static_cast<png_uint_32>(depth.height()), 16, PNG_COLOR_TYPE_GRAY,
               PNG_INTERLACE_ADAM7, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (std::endian::native == std::endian::little) png_set_swap(png);
  std::vector<png_bytep> rows;
  for (int v = 0; v < depth.height(); ++v)
    rows.push_back(reinterpret_cast<png_bytep>(const_cast<std::uint16_t*>(depth.row(v))));
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(file);
}

TEST(ImageIo, ReadsSevenScenesDepthAtKnownPixels) {
  const fs::path path = seven_scenes("frame-000000.depth.png");
  const ImageFileInfo info = read_image_info(path);
  EXPECT_EQ(info.width, 640);
  EXPECT_EQ(info.height, 480);
  EXPECT_EQ(info.channels, 1);
  EXPECT_EQ(info.bit_depth, 16);
  const DepthImage depth = read_depth_image(path);
  ASSERT_EQ(depth.width(), 640);
  ASSERT_EQ(depth.height(), 480);
  // Values checked with an independent pure-Python PNG decoder.
  EXPECT_EQ(depth.at(320, 240), 1382);  // millimetres
  EXPECT_EQ(depth.at(100, 100), 2215);
  EXPECT_EQ(depth.at(0, 0), 0);
}

TEST(ImageIo, ReadsTumDepthWithScale5000Values) {
  const DepthImage depth = read_depth_image(open3d_rgbd("other_formats/TUM_depth.png"));
  ASSERT_EQ(depth.width(), 640);
  ASSERT_EQ(depth.height(), 480);
  EXPECT_EQ(depth.at(320, 240), 10920);  // 10920 / 5000 = 2.184 m
  EXPECT_EQ(depth.at(100, 100), 11205);
  EXPECT_DOUBLE_EQ(depth.at(320, 240) / 5000.0, 2.184);
}

TEST(ImageIo, ReadsJpegColour) {
  const fs::path path = seven_scenes("frame-000000.color.jpg");
  const ImageFileInfo info = read_image_info(path);
  EXPECT_EQ(info.width, 640);
  EXPECT_EQ(info.height, 480);
  EXPECT_EQ(info.channels, 3);
  EXPECT_EQ(info.bit_depth, 8);
  const ColorImage color = read_color_image(path);
  ASSERT_EQ(color.width(), 640);
  ASSERT_EQ(color.height(), 480);
  double sum[3] = {0, 0, 0};
  for (int v = 0; v < color.height(); ++v)
    for (int u = 0; u < color.width(); ++u)
      for (int c = 0; c < 3; ++c) sum[c] += color.at(u, v, c);
  const double n = static_cast<double>(color.pixel_count());
  // libjpeg-turbo, JDCT_ISLOW, fancy upsampling: R 126.78, G 107.16, B 104.43.
  EXPECT_NEAR(sum[0] / n, 126.78, 0.5);
  EXPECT_NEAR(sum[1] / n, 107.16, 0.5);
  EXPECT_NEAR(sum[2] / n, 104.43, 0.5);
}

TEST(ImageIo, ReadsPngColour) {
  const ColorImage color = read_color_image(open3d_rgbd("other_formats/TUM_color.png"));
  EXPECT_EQ(color.width(), 640);
  EXPECT_EQ(color.height(), 480);
  EXPECT_EQ(color.at(320, 240, 0), 252);
  EXPECT_EQ(color.at(320, 240, 1), 252);
  EXPECT_EQ(color.at(320, 240, 2), 250);
}

TEST(ImageIo, ColourPngRoundTripIsExact) {
  const fs::path path = test::scratch_dir() / "color.png";
  ColorImage image(37, 23);
  for (int v = 0; v < image.height(); ++v)
    for (int u = 0; u < image.width(); ++u)
      for (int c = 0; c < 3; ++c)
        image.at(u, v, c) = static_cast<std::uint8_t>(u * 7 + v * 13 + c * 101);
  write_png(path, image);
  const ImageFileInfo info = read_image_info(path);
  EXPECT_EQ(info.channels, 3);
  EXPECT_EQ(info.bit_depth, 8);
  EXPECT_EQ(read_color_image(path), image);
  EXPECT_EQ(test::list_folder(path.parent_path()), "color.png\n");  // no temporary left
}

TEST(ImageIo, DepthPngRoundTripIsExactOverFullRange) {
  const fs::path path = test::scratch_dir() / "depth.png";
  DepthImage image = noisy_depth(64, 48);
  image.at(0, 0) = 0;
  image.at(1, 0) = 1;
  image.at(2, 0) = 255;
  image.at(3, 0) = 256;
  image.at(4, 0) = 65535;
  write_png(path, image);
  const ImageFileInfo info = read_image_info(path);
  EXPECT_EQ(info.channels, 1);
  EXPECT_EQ(info.bit_depth, 16);
  EXPECT_EQ(read_depth_image(path), image);
}

TEST(ImageIo, DepthIsStoredBigEndianAsPngRequires) {
  // A 1x1 image: whatever filter libpng picks, the one filtered scanline equals the raw one
  // (all neighbours are zero), so the inflated IDAT is "<filter byte> 0x01 0x02".
  const fs::path path = test::scratch_dir() / "one.png";
  write_png(path, DepthImage(1, 1, 0x0102));
  const std::vector<char> bytes = read_bytes(path);
  std::vector<unsigned char> idat;
  for (std::size_t pos = 8; pos + 12 <= bytes.size();) {
    const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(bytes[i]); };
    const std::size_t length = (std::size_t{byte(pos)} << 24) | (std::size_t{byte(pos + 1)} << 16) |
                               (std::size_t{byte(pos + 2)} << 8) | byte(pos + 3);
    if (std::string(&bytes[pos + 4], 4) == "IDAT")
      idat.insert(idat.end(), bytes.begin() + static_cast<std::ptrdiff_t>(pos + 8),
                  bytes.begin() + static_cast<std::ptrdiff_t>(pos + 8 + length));
    pos += 12 + length;
  }
  unsigned char raw[16] = {};
  uLongf raw_size = sizeof raw;
  ASSERT_EQ(uncompress(raw, &raw_size, idat.data(), static_cast<uLong>(idat.size())), Z_OK);
  ASSERT_EQ(raw_size, 3u);
  EXPECT_EQ(raw[1], 0x01);
  EXPECT_EQ(raw[2], 0x02);
  EXPECT_EQ(read_depth_image(path).at(0, 0), 0x0102);
}

TEST(ImageIo, ReadsInterlacedPng) {
  const fs::path path = test::scratch_dir() / "adam7.png";
  const DepthImage depth = noisy_depth(33, 17);  // odd sizes exercise partial Adam7 passes
  write_interlaced_depth(path, depth);
  EXPECT_EQ(read_depth_image(path), depth);
}

TEST(ImageIo, GrayPngReadsAsReplicatedRgb) {
  const fs::path path = test::scratch_dir() / "gray.png";
  GrayImage gray(5, 4);
  for (int i = 0; i < 20; ++i)
    gray.data()[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(i * 12);
  write_png(path, gray);
  const ColorImage color = read_color_image(path);
  ASSERT_EQ(color.width(), 5);
  ASSERT_EQ(color.height(), 4);
  for (int v = 0; v < 4; ++v)
    for (int u = 0; u < 5; ++u)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(color.at(u, v, c), gray.at(u, v));
}

TEST(ImageIo, MissingFileNamesTheFile) {
  const fs::path path = test::scratch_dir() / "nothing-here.png";
  EXPECT_THAT(
      [&] { read_depth_image(path); },
      ThrowsMessage<InputError>(AllOf(HasSubstr("nothing-here.png"), HasSubstr("no such file"))));
  EXPECT_THAT([&] { read_color_image(path); },
              ThrowsMessage<InputError>(HasSubstr("nothing-here.png")));
  EXPECT_THAT([&] { read_image_info(path); },
              ThrowsMessage<InputError>(HasSubstr("nothing-here.png")));
}

TEST(ImageIo, TruncatedPngIsInputError) {
  const fs::path dir = test::scratch_dir();
  write_png(dir / "full.png", noisy_depth(128, 96));
  std::vector<char> bytes = read_bytes(dir / "full.png");
  bytes.resize(bytes.size() / 2);
  write_bytes(dir / "half.png", bytes);
  EXPECT_THAT([&] { read_depth_image(dir / "half.png"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("half.png"), HasSubstr("truncated"))));
  EXPECT_THAT([&] { read_color_image(dir / "half.png"); },
              ThrowsMessage<InputError>(HasSubstr("half.png")));
  // Cut inside the header: the error comes while the decoder is being set up.
  bytes.resize(20);
  write_bytes(dir / "header.png", bytes);
  EXPECT_THAT([&] { read_image_info(dir / "header.png"); },
              ThrowsMessage<InputError>(HasSubstr("header.png")));
}

TEST(ImageIo, CorruptPngDataIsInputError) {
  const fs::path dir = test::scratch_dir();
  write_png(dir / "full.png", noisy_depth(128, 96));
  std::vector<char> bytes = read_bytes(dir / "full.png");
  for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 16; ++i)
    bytes[i] = static_cast<char>(~bytes[i]);
  write_bytes(dir / "flipped.png", bytes);
  EXPECT_THAT([&] { read_depth_image(dir / "flipped.png"); },
              ThrowsMessage<InputError>(HasSubstr("flipped.png")));
}

TEST(ImageIo, TruncatedJpegIsInputError) {
  // libjpeg only warns about a truncated file and pads with gray; we refuse it.
  const fs::path dir = test::scratch_dir();
  std::vector<char> bytes = read_bytes(seven_scenes("frame-000000.color.jpg"));
  ASSERT_GT(bytes.size(), 1000u);
  bytes.resize(bytes.size() / 2);
  write_bytes(dir / "half.jpg", bytes);
  EXPECT_THAT([&] { read_color_image(dir / "half.jpg"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("half.jpg"), HasSubstr("JPEG"))));
  bytes.resize(100);  // inside the JPEG header
  write_bytes(dir / "header.jpg", bytes);
  EXPECT_THAT([&] { read_image_info(dir / "header.jpg"); },
              ThrowsMessage<InputError>(HasSubstr("header.jpg")));
}

TEST(ImageIo, EightBitDepthIsInputError) {
  const fs::path path = test::scratch_dir() / "depth8.png";
  write_png(path, GrayImage(8, 8, 100));
  EXPECT_THAT([&] { read_depth_image(path); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("depth8.png"),
                                              HasSubstr("depth image is 8-bit, expected 16-bit"))));
}

TEST(ImageIo, ColourOrJpegAsDepthIsInputError) {
  const fs::path path = test::scratch_dir() / "rgb.png";
  write_png(path, ColorImage(8, 8, 100));
  EXPECT_THAT([&] { read_depth_image(path); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("rgb.png"), HasSubstr("3 channels"))));
  EXPECT_THAT([&] { read_depth_image(seven_scenes("frame-000000.color.jpg")); },
              ThrowsMessage<InputError>(HasSubstr("frame-000000.color.jpg")));
}

TEST(ImageIo, NonImageAndEmptyFilesAreInputErrors) {
  const fs::path dir = test::scratch_dir();
  write_bytes(dir / "text.png", {'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd'});
  write_bytes(dir / "empty.png", {});
  EXPECT_THAT(
      [&] { read_color_image(dir / "text.png"); },
      ThrowsMessage<InputError>(AllOf(HasSubstr("text.png"), HasSubstr("not a PNG or JPEG"))));
  EXPECT_THAT([&] { read_depth_image(dir / "empty.png"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("empty.png"), HasSubstr("empty"))));
}

TEST(ImageIo, WriteIntoMissingFolderOrEmptyImageFails) {
  const fs::path dir = test::scratch_dir();
  EXPECT_THROW(write_png(dir / "no-such-folder" / "x.png", DepthImage(4, 4)), InputError);
  EXPECT_THAT([&] { write_png(dir / "empty.png", DepthImage()); },
              ThrowsMessage<InputError>(HasSubstr("empty.png")));
  EXPECT_EQ(test::list_folder(dir), "");
}

}  // namespace
}  // namespace locard

namespace locard {
namespace {

std::string fmt_name(std::uint32_t width, bool rgb, bool interlaced) {
  return "bomb-" + std::to_string(width) + (rgb ? "-rgb" : "-gray") + (interlaced ? "-adam7" : "") +
         ".png";
}

// A PNG of signature, IHDR (claimed size, 16-bit gray or 8-bit RGB, optionally interlaced so
// libpng decodes it), an empty IDAT and IEND: 69 bytes.
void write_png_bomb(const fs::path& path, std::uint32_t width, std::uint32_t height,
                    bool rgb, bool interlaced) {
  std::vector<unsigned char> bytes{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  const auto be32 = [&](std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) bytes.push_back(static_cast<unsigned char>(v >> s));
  };
  const auto chunk = [&](const char* type, const std::vector<unsigned char>& data) {
    be32(static_cast<std::uint32_t>(data.size()));
    const std::size_t start = bytes.size();
    bytes.insert(bytes.end(), type, type + 4);
    bytes.insert(bytes.end(), data.begin(), data.end());
    be32(static_cast<std::uint32_t>(
        crc32(0, bytes.data() + start, static_cast<uInt>(bytes.size() - start))));
  };
  std::vector<unsigned char> ihdr;
  for (std::uint32_t v : {width, height})
    for (int s = 24; s >= 0; s -= 8) ihdr.push_back(static_cast<unsigned char>(v >> s));
  ihdr.insert(ihdr.end(), {static_cast<unsigned char>(rgb ? 8 : 16),
                           static_cast<unsigned char>(rgb ? 2 : 0), 0, 0,
                           static_cast<unsigned char>(interlaced ? 1 : 0)});
  chunk("IHDR", ihdr);
  chunk("IDAT", {0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01});  // zlib of nothing
  chunk("IEND", {});
  write_bytes(path, std::vector<char>(bytes.begin(), bytes.end()));
}

// Issue 14: a 69-byte PNG claiming 30000 x 30000 made the fast path allocate 1.8 GB before
// inflating, and libpng (65535 x 65535) 8 GB. The header is now checked against a pixel
// budget and against what its compressed bytes can hold, before anything is allocated.
TEST(ImageIo, PngClaimingMorePixelsThanItHoldsIsRefusedBeforeAllocating) {
  const fs::path dir = test::scratch_dir();
  struct Case {
    std::uint32_t width, height;
    bool rgb, interlaced;
    const char* says;
  };
  for (const Case& c : {Case{30000, 30000, false, false, "at most"},
                        Case{65535, 65535, false, true, "at most"},
                        Case{8000, 8000, false, false, "more than its"},
                        Case{8000, 8000, true, true, "more than its"}}) {
    const fs::path path = dir / fmt_name(c.width, c.rgb, c.interlaced);
    write_png_bomb(path, c.width, c.height, c.rgb, c.interlaced);
    const auto read = [&] {
      if (c.rgb) read_color_image(path);
      else read_depth_image(path);
    };
    EXPECT_THAT(read, ThrowsMessage<InputError>(
                          AllOf(HasSubstr(path.filename().string()), HasSubstr(c.says))))
        << path;
  }
}

// Issue 14 (jpeg_fuzz, finding 4): a JPEG's header may claim up to 65535 x 65535 and its data
// be a few bytes (a flat image, long end-of-band runs: no useful compression bound), and
// read_color_image allocated the decoded size first - 5.5 GB for 55551 x 33023. The pixel
// budget PNG has now holds for JPEG too. Here a real 7-Scenes frame with its SOF0 size patched.
TEST(ImageIo, JpegClaimingAHugeSizeIsRefusedBeforeAllocating) {
  const fs::path dir = test::scratch_dir();
  std::vector<char> bytes = read_bytes(seven_scenes("frame-000000.color.jpg"));
  std::size_t sof = 2;
  while (sof + 9 < bytes.size() && !(static_cast<unsigned char>(bytes[sof]) == 0xFF &&
                                     static_cast<unsigned char>(bytes[sof + 1]) == 0xC0))
    ++sof;
  ASSERT_LT(sof + 9, bytes.size()) << "no SOF0 marker";
  const auto put16 = [&](std::size_t at, unsigned v) {
    bytes[at] = static_cast<char>(v >> 8);
    bytes[at + 1] = static_cast<char>(v & 0xFF);
  };
  put16(sof + 5, 33023);  // height
  put16(sof + 7, 55551);  // width
  write_bytes(dir / "huge.jpg", bytes);
  EXPECT_THAT([&] { read_color_image(dir / "huge.jpg"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("huge.jpg"), HasSubstr("at most 128 M pixels"))));
  EXPECT_THAT([&] { read_image_info(dir / "huge.jpg"); },
              ThrowsMessage<InputError>(HasSubstr("huge.jpg")));
  // The fuzzer's own input stays in the corpus (fuzz/corpus/jpeg/oom-55551x33023.jpg).
  EXPECT_THAT([] { read_color_image(fs::path(LOCARD_SOURCE_DIR) / "fuzz/corpus/jpeg/oom-55551x33023.jpg"); },
              ThrowsMessage<InputError>(HasSubstr("at most 128 M pixels")));
}

}  // namespace
}  // namespace locard
