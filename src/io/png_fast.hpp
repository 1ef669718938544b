#pragma once
// A fast decoder for the two PNG layouts RGB-D sequences are made of: 16-bit gray depth and
// 8-bit RGB colour, non-interlaced. Inflate is libdeflate's (about twice zlib's speed, and the
// whole stream is inflated in one call instead of libpng's row-by-row pulls); row filters are
// undone in place. Anything else (palettes, alpha, interlacing, other bit depths) is left to
// libpng: decode_png_fast() then returns false and touches nothing.
//
// Error behaviour follows libpng's: a bad signature, a critical chunk with a wrong CRC, a
// truncated file or a stream that inflates to the wrong size is an InputError naming the file.

#include <locard/core/image.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace locard::detail {

enum class PngFastLayout { Gray16, Rgb8 };

struct PngFastImage {
  int width = 0;
  int height = 0;
  // Native-endian samples for Gray16, interleaved RGB for Rgb8, rows packed.
  std::vector<std::uint8_t> pixels;
};

// Decodes `bytes` (a whole PNG file read from `path`) when its layout is `want`; returns false
// (and leaves `out` alone) when the file has another layout, so the caller can use libpng.
bool decode_png_fast(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes,
                     PngFastLayout want, PngFastImage& out);

// The budget an image header must fit before anything is allocated for it: at most
// kMaxImagePixels pixels (134 M: 11585 x 11585, far beyond any depth or colour frame), and
// no more decoded bytes than the compressed data can hold (deflate expands at most 1032:1).
// A 69-byte PNG claiming 65535 x 65535 once made both decoders allocate gigabytes. InputError
// naming the file otherwise.
// The pixel budget alone (at most 2^27 pixels, 128 M), for decoders whose compression has no
// useful bound (a JPEG of one flat colour, or with long end-of-band runs, is tiny): a 382-byte
// JPEG claiming 65500 x 28000 made read_color_image allocate 5.5 GB (jpeg_fuzz).
void check_image_pixels(const std::filesystem::path& path, std::uint64_t width,
                        std::uint64_t height);
void check_image_budget(const std::filesystem::path& path, std::uint64_t width,
                        std::uint64_t height, std::uint64_t bytes_per_pixel,
                        std::uint64_t compressed_bytes);

// Reads a whole file; InputError naming the file when it cannot be read.
std::vector<std::uint8_t> read_whole_file(const std::filesystem::path& path);

// The libpng decoders behind read_color_image/read_depth_image, for every other layout; tests
// compare the fast path with them.
ColorImage read_color_image_libpng(const std::filesystem::path& path);
DepthImage read_depth_image_libpng(const std::filesystem::path& path);

}  // namespace locard::detail
