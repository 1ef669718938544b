#pragma once
// PNG / JPEG reading and PNG writing (libpng, libjpeg-turbo). Errors name the file.

#include <locard/core/image.hpp>

#include <filesystem>

namespace locard {

struct ImageFileInfo {
  int width = 0;
  int height = 0;
  int channels = 0;   // 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA
  int bit_depth = 0;  // 8 or 16
};

// Header only (cheap): size, channels, bit depth. PNG and JPEG.
ImageFileInfo read_image_info(const std::filesystem::path& path);

// 8-bit colour from PNG or JPEG. Gray is replicated to RGB, alpha dropped, 16-bit scaled down.
ColorImage read_color_image(const std::filesystem::path& path);

// 16-bit single-channel PNG depth. An 8-bit, multi-channel or truncated file is an InputError.
DepthImage read_depth_image(const std::filesystem::path& path);

// PNG writers (atomic: temp file + rename). Depth is written as 16-bit big-endian per the PNG
// standard, so every tool reads the same values back.
void write_png(const std::filesystem::path& path, const ColorImage& image);
void write_png(const std::filesystem::path& path, const GrayImage& image);
void write_png(const std::filesystem::path& path, const DepthImage& image);

}  // namespace locard
