// The PNG fast path (libdeflate + own unfiltering) against libpng and against PNGs built here
// with every row filter, split image data and damaged bytes.
#include "io/png_fast.hpp"

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <libdeflate.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;

void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<std::uint8_t>(v >> s));
}

void put_chunk(std::vector<std::uint8_t>& out, const char* type,
               const std::vector<std::uint8_t>& payload) {
  put32(out, static_cast<std::uint32_t>(payload.size()));
  std::vector<std::uint8_t> typed(type, type + 4);
  typed.insert(typed.end(), payload.begin(), payload.end());
  out.insert(out.end(), typed.begin(), typed.end());
  put32(out, libdeflate_crc32(0, typed.data(), typed.size()));
}

std::uint8_t paeth_ref(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return static_cast<std::uint8_t>(pa <= pb && pa <= pc ? a : pb <= pc ? b : c);
}

// An encoder written from the PNG specification: row v uses filter filters[v % size], the
// zlib stream is cut into `idat_parts` IDAT chunks.
std::vector<std::uint8_t> encode_png(const std::vector<std::uint8_t>& raw, int width, int height,
                                     int bpp, int bit_depth, int color_type,
                                     const std::vector<int>& filters, int idat_parts) {
  const std::size_t row = static_cast<std::size_t>(width) * bpp;
  std::vector<std::uint8_t> filtered;
  for (int v = 0; v < height; ++v) {
    const int f = filters[v % filters.size()];
    filtered.push_back(static_cast<std::uint8_t>(f));
    const std::uint8_t* cur = raw.data() + v * row;
    for (std::size_t i = 0; i < row; ++i) {
      const int a = i >= static_cast<std::size_t>(bpp) ? cur[i - bpp] : 0;
      const int b = v > 0 ? cur[i - row] : 0;
      const int c = v > 0 && i >= static_cast<std::size_t>(bpp) ? cur[i - row - bpp] : 0;
      const int pred = f == 0 ? 0 : f == 1 ? a : f == 2 ? b : f == 3 ? (a + b) / 2 : paeth_ref(a, b, c);
      filtered.push_back(static_cast<std::uint8_t>(cur[i] - pred));
    }
  }
  libdeflate_compressor* c = libdeflate_alloc_compressor(6);
  std::vector<std::uint8_t> z(libdeflate_zlib_compress_bound(c, filtered.size()));
  z.resize(libdeflate_zlib_compress(c, filtered.data(), filtered.size(), z.data(), z.size()));
  libdeflate_free_compressor(c);

  std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<std::uint8_t> ihdr;
  put32(ihdr, static_cast<std::uint32_t>(width));
  put32(ihdr, static_cast<std::uint32_t>(height));
  ihdr.insert(ihdr.end(), {static_cast<std::uint8_t>(bit_depth),
                           static_cast<std::uint8_t>(color_type), 0, 0, 0});
  put_chunk(png, "IHDR", ihdr);
  put_chunk(png, "tEXt", {'C', 'o', 'm', 'm', 'e', 'n', 't', 0, 'x'});
  const std::size_t part = z.size() / idat_parts + 1;
  for (std::size_t at = 0; at < z.size(); at += part)
    put_chunk(png, "IDAT", std::vector<std::uint8_t>(z.begin() + at,
                                                     z.begin() + std::min(z.size(), at + part)));
  put_chunk(png, "IEND", {});
  return png;
}

fs::path write_file(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return path;
}

std::vector<std::uint8_t> random_bytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::uint8_t> out(n);
  // Smooth-ish data (as depth is) with noise, so that every filter predicts something.
  for (std::size_t i = 0; i < n; ++i)
    out[i] = static_cast<std::uint8_t>((i * 7 / 5) + (rng() % 9));
  return out;
}

TEST(PngFast, SevenScenesDepthEqualsLibpng) {
  const fs::path data = test::shared_data() / "7scenes-tsdf-fusion" / "data";
  std::vector<fs::path> depth_files;
  for (const auto& entry : fs::directory_iterator(data))
    if (entry.path().string().ends_with(".depth.png")) depth_files.push_back(entry.path());
  std::sort(depth_files.begin(), depth_files.end());
  ASSERT_EQ(depth_files.size(), 374u);
  for (std::size_t i = 0; i < depth_files.size(); i += 37) {
    const fs::path& path = depth_files[i];
    detail::PngFastImage fast;
    ASSERT_TRUE(detail::decode_png_fast(path, detail::read_whole_file(path),
                                        detail::PngFastLayout::Gray16, fast));
    const DepthImage reference = detail::read_depth_image_libpng(path);
    ASSERT_EQ(fast.width, 640);
    ASSERT_EQ(fast.height, 480);
    ASSERT_EQ(0, std::memcmp(fast.pixels.data(), reference.data().data(), fast.pixels.size()))
        << path;
    const DepthImage public_path = read_depth_image(path);
    EXPECT_EQ(0, std::memcmp(public_path.data().data(), reference.data().data(),
                             fast.pixels.size()));
  }
}

TEST(PngFast, OpenThreeDColourPngEqualsLibpng) {
  const fs::path color = test::shared_data() / "open3d-testdata";
  int checked = 0;
  for (const auto& entry : fs::recursive_directory_iterator(color)) {
    if (entry.path().extension() != ".png") continue;
    const ImageFileInfo info = read_image_info(entry.path());
    if (info.channels != 3 || info.bit_depth != 8) continue;
    const ColorImage a = read_color_image(entry.path());
    const ColorImage b = detail::read_color_image_libpng(entry.path());
    ASSERT_EQ(a.width(), b.width());
    ASSERT_EQ(a.height(), b.height());
    EXPECT_EQ(0, std::memcmp(a.data().data(), b.data().data(), a.data().size())) << entry.path();
    ++checked;
  }
  if (checked == 0) GTEST_SKIP() << "no 8-bit RGB PNG in " << color;
}

TEST(PngFast, EveryRowFilterAndSplitImageData) {
  const fs::path dir = test::scratch_dir();
  const int w = 37, h = 23;
  for (const std::vector<int>& filters :
       {std::vector<int>{0}, {1}, {2}, {3}, {4}, {4, 2, 0, 3, 1}}) {
    for (int parts : {1, 3}) {
      const std::string tag = std::to_string(filters[0]) + "-" + std::to_string(filters.size()) +
                              "-" + std::to_string(parts);
      // 16-bit gray
      const auto raw16 = random_bytes(static_cast<std::size_t>(w) * h * 2, 1);
      const fs::path p16 = write_file(dir / ("g16-" + tag + ".png"),
                                      encode_png(raw16, w, h, 2, 16, 0, filters, parts));
      const DepthImage depth = read_depth_image(p16);
      for (int v = 0; v < h; ++v)
        for (int u = 0; u < w; ++u) {
          const std::size_t i = (static_cast<std::size_t>(v) * w + u) * 2;
          ASSERT_EQ(depth.at(u, v), (raw16[i] << 8) | raw16[i + 1]) << tag << " " << u << "," << v;
        }
      const DepthImage ref = detail::read_depth_image_libpng(p16);
      EXPECT_EQ(0, std::memcmp(depth.data().data(), ref.data().data(), raw16.size()));
      // 8-bit RGB
      const auto raw8 = random_bytes(static_cast<std::size_t>(w) * h * 3, 2);
      const fs::path p8 = write_file(dir / ("rgb-" + tag + ".png"),
                                     encode_png(raw8, w, h, 3, 8, 2, filters, parts));
      const ColorImage rgb = read_color_image(p8);
      EXPECT_EQ(0, std::memcmp(rgb.data().data(), raw8.data(), raw8.size())) << tag;
    }
  }
}

TEST(PngFast, DamageIsAnErrorNamingTheFile) {
  const fs::path dir = test::scratch_dir();
  const auto raw = random_bytes(20 * 10 * 2, 3);
  const auto good = encode_png(raw, 20, 10, 2, 16, 0, {4}, 1);
  // A flipped byte inside the image data: the chunk CRC no longer matches.
  auto flipped = good;
  flipped[flipped.size() - 30] ^= 0x40;
  // Cut short: the file ends inside a chunk.
  const std::vector<std::uint8_t> cut(good.begin(), good.begin() + good.size() / 2);
  for (const auto& [name, bytes] : {std::pair{"flipped.png", flipped}, std::pair{"cut.png", cut}}) {
    const fs::path p = write_file(dir / name, bytes);
    try {
      (void)read_depth_image(p);
      FAIL() << name << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("PNG"), std::string::npos) << e.what();
    }
  }
}

TEST(PngFast, OtherLayoutsAreLeftToLibpng) {
  const fs::path dir = test::scratch_dir();
  const auto raw = random_bytes(12 * 8, 4);
  const auto gray8 = encode_png(raw, 12, 8, 1, 8, 0, {1}, 1);
  const fs::path p = write_file(dir / "gray8.png", gray8);
  detail::PngFastImage out;
  EXPECT_FALSE(detail::decode_png_fast(p, gray8, detail::PngFastLayout::Gray16, out));
  EXPECT_FALSE(detail::decode_png_fast(p, gray8, detail::PngFastLayout::Rgb8, out));
  EXPECT_EQ(out.width, 0);
  // libpng then handles it: gray replicated to RGB, and an 8-bit depth image refused.
  const ColorImage rgb = read_color_image(p);
  EXPECT_EQ(rgb.at(3, 2, 1), raw[2 * 12 + 3]);
  EXPECT_THROW((void)read_depth_image(p), InputError);
}

}  // namespace
}  // namespace locard
