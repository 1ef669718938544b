#include <locard/io/image_io.hpp>

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>

#include "io/text_lines.hpp"
#include "png_fast.hpp"

#include <bit>
#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <new>
#include <string>
#include <system_error>
#include <vector>

// jpeglib.h needs FILE and size_t declared first.
#include <jerror.h>
#include <jpeglib.h>
#include <png.h>

// libpng and libjpeg report errors through callbacks that must not return. We longjmp from the
// callback back to a setjmp in guarded() below, whose frame and the lambda it runs hold no
// objects with destructors, so no C++ cleanup is skipped; the C++ caller then throws normally.
// Exceptions never cross the C libraries' frames.

namespace locard {
namespace {

constexpr bool kLittleEndian = std::endian::native == std::endian::little;
// A corrupt header can claim any size; refuse absurd ones before allocating.
constexpr int kMaxSide = 1 << 16;

enum class FileKind { Png, Jpeg };

template <typename Step>
bool guarded(std::jmp_buf& jump, Step& step) {
  if (setjmp(jump)) return false;
  step();
  return true;
}

class CFile {
 public:
  CFile(const std::filesystem::path& path, const char* mode)
      : file_((io_detail::require_regular_file(path), std::fopen(path.c_str(), mode))) {
    if (!file_) {
      const std::string reason = std::error_code(errno, std::generic_category()).message();
      throw_input_error(path, "cannot open image file (" + reason + ")");
    }
    // One 64 KiB buffer: a frame is read in a handful of system calls.
    std::setvbuf(file_, nullptr, _IOFBF, 1 << 16);
  }
  ~CFile() { std::fclose(file_); }
  CFile(const CFile&) = delete;
  CFile& operator=(const CFile&) = delete;
  FILE* get() const { return file_; }

 private:
  FILE* file_;
};

// Reads the signature; leaves a PNG positioned after its 8 signature bytes, a JPEG rewound.
FileKind sniff(const std::filesystem::path& path, FILE* file) {
  unsigned char magic[8] = {};
  const std::size_t n = std::fread(magic, 1, sizeof magic, file);
  if (n == 0 && std::ferror(file)) throw_input_error(path, "cannot read image file");
  if (n == 0) throw_input_error(path, "image file is empty");
  if (n == 8 && png_sig_cmp(magic, 0, 8) == 0) return FileKind::Png;
  if (n >= 3 && magic[0] == 0xFF && magic[1] == 0xD8 && magic[2] == 0xFF) {
    std::rewind(file);
    return FileKind::Jpeg;
  }
  throw_input_error(path, "not a PNG or JPEG file (unrecognised signature)");
}

// ---------------------------------------------------------------- libpng
struct PngErrorState {
  std::jmp_buf jump;
  char message[256];
};

void on_png_error(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof state->message, "%s", message);
  std::longjmp(state->jump, 1);
}

// Warnings concern ancillary chunks (colour profiles, text); pixels are unaffected.
void on_png_warning(png_structp, png_const_charp) {}

// The C libraries' decoder state lives in small owners held as members, so a constructor
// that throws half-way still releases it.
struct PngReadHandle {
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngReadHandle() = default;
  PngReadHandle(const PngReadHandle&) = delete;
  PngReadHandle& operator=(const PngReadHandle&) = delete;
  ~PngReadHandle() { png_destroy_read_struct(&png, &info, nullptr); }
};

class PngReader {
 public:
  PngReader(const std::filesystem::path& path, FILE* file) : path_(path) {
    run([&] {
      h_.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state_, on_png_error, on_png_warning);
      if (h_.png) h_.info = png_create_info_struct(h_.png);
    });
    if (!h_.png || !h_.info) throw std::bad_alloc();
    run([&] {
      png_init_io(h_.png, file);
      png_set_sig_bytes(h_.png, 8);
      png_set_user_limits(h_.png, kMaxSide, kMaxSide);
      // Each chunk's CRC-32 already covers every compressed byte; zlib's Adler-32 over the
      // inflated data is a second, redundant pass (about 5% of a depth frame's decode).
      png_set_option(h_.png, PNG_IGNORE_ADLER32, PNG_OPTION_ON);
      png_read_info(h_.png, h_.info);
    });
    width_ = static_cast<int>(png_get_image_width(h_.png, h_.info));
    height_ = static_cast<int>(png_get_image_height(h_.png, h_.info));
    bit_depth_ = png_get_bit_depth(h_.png, h_.info);
    color_type_ = png_get_color_type(h_.png, h_.info);
    std::error_code ec;
    const auto file_bytes = std::filesystem::file_size(path, ec);
    const int channels = png_get_channels(h_.png, h_.info);
    detail::check_image_budget(path, static_cast<std::uint64_t>(width_),
                               static_cast<std::uint64_t>(height_),
                               static_cast<std::uint64_t>(std::max(1, channels * bit_depth_ / 8)),
                               ec ? 0 : file_bytes);
  }
  PngReader(const PngReader&) = delete;
  PngReader& operator=(const PngReader&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }
  int bit_depth() const { return bit_depth_; }
  int color_type() const { return color_type_; }
  bool has_trns() const { return png_get_valid(h_.png, h_.info, PNG_INFO_tRNS) != 0; }

  ImageFileInfo info() const {
    ImageFileInfo out;
    out.width = width_;
    out.height = height_;
    out.bit_depth = bit_depth_ == 16 ? 16 : 8;
    switch (color_type_) {
      case PNG_COLOR_TYPE_GRAY: out.channels = 1; break;
      case PNG_COLOR_TYPE_GRAY_ALPHA: out.channels = 2; break;
      case PNG_COLOR_TYPE_PALETTE: out.channels = has_trns() ? 4 : 3; break;
      case PNG_COLOR_TYPE_RGB: out.channels = 3; break;
      default: out.channels = 4; break;
    }
    return out;
  }

  // Transforms to RGB8: palette expanded, gray replicated, alpha dropped, 16-bit scaled down.
  void set_rgb8_transforms() {
    run([&] {
      if (color_type_ == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(h_.png);
      if (color_type_ == PNG_COLOR_TYPE_GRAY && bit_depth_ < 8)
        png_set_expand_gray_1_2_4_to_8(h_.png);
      if (bit_depth_ == 16) png_set_scale_16(h_.png);
      if ((color_type_ & PNG_COLOR_MASK_COLOR) == 0) png_set_gray_to_rgb(h_.png);
      if ((color_type_ & PNG_COLOR_MASK_ALPHA) != 0 || has_trns()) png_set_strip_alpha(h_.png);
      png_set_interlace_handling(h_.png);
      png_read_update_info(h_.png, h_.info);
    });
    check_row_bytes(3);
  }

  // 16-bit gray: the file stores big-endian samples, we want native ones.
  void set_depth_transforms() {
    run([&] {
      if (kLittleEndian) png_set_swap(h_.png);
      png_set_interlace_handling(h_.png);
      png_read_update_info(h_.png, h_.info);
    });
    check_row_bytes(2);
  }

  // Decodes straight into the caller's buffer, row by row at `stride` bytes.
  void read_pixels(std::uint8_t* data, std::size_t stride) {
    std::vector<png_bytep> rows(static_cast<std::size_t>(height_));
    for (std::size_t v = 0; v < rows.size(); ++v) rows[v] = data + v * stride;
    run([&] {
      png_read_image(h_.png, rows.data());
      png_read_end(h_.png, nullptr);
    });
  }

 private:
  template <typename Step>
  void run(Step&& step) {
    if (!guarded(state_.jump, step))
      throw_input_error(path_,
                        std::string("corrupt or truncated PNG (libpng: ") + state_.message + ")");
  }

  void check_row_bytes(std::size_t bytes_per_pixel) const {
    if (png_get_rowbytes(h_.png, h_.info) != bytes_per_pixel * static_cast<std::size_t>(width_))
      throw_input_error(path_, "unsupported PNG pixel layout (colour type " +
                                   std::to_string(color_type_) + ", " + std::to_string(bit_depth_) +
                                   "-bit)");
  }

  const std::filesystem::path& path_;
  PngErrorState state_{};
  PngReadHandle h_;
  int width_ = 0;
  int height_ = 0;
  int bit_depth_ = 0;
  int color_type_ = 0;
};

// ---------------------------------------------------------------- libjpeg
struct JpegErrorState {
  jpeg_error_mgr manager;  // first member: libjpeg hands back a pointer to it
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

void on_jpeg_error(j_common_ptr cinfo) {
  auto* state = reinterpret_cast<JpegErrorState*>(cinfo->err);
  cinfo->err->format_message(cinfo, state->message);
  std::longjmp(state->jump, 1);
}

// libjpeg only *warns* about corrupt or truncated data (it pads the image with gray). A
// forensic reconstruction must not use such pixels, so every data warning is an error.
void on_jpeg_message(j_common_ptr cinfo, int level) {
  if (level >= 0) return;  // trace output, not a problem
  const int code = cinfo->err->msg_code;
  if (code == JWRN_JFIF_MAJOR || code == JWRN_ADOBE_XFORM) return;  // metadata oddities only
  on_jpeg_error(cinfo);
}

// jpeg_destroy is safe on a zeroed or partly created struct: it frees what was allocated.
struct JpegHandle {
  jpeg_decompress_struct cinfo{};
  JpegHandle() = default;
  JpegHandle(const JpegHandle&) = delete;
  JpegHandle& operator=(const JpegHandle&) = delete;
  ~JpegHandle() { jpeg_destroy_decompress(&cinfo); }
};

class JpegReader {
 public:
  JpegReader(const std::filesystem::path& path, FILE* file) : path_(path) {
    h_.cinfo.err = jpeg_std_error(&state_.manager);
    state_.manager.error_exit = on_jpeg_error;
    state_.manager.emit_message = on_jpeg_message;
    run([&] {
      jpeg_create_decompress(&h_.cinfo);
      jpeg_stdio_src(&h_.cinfo, file);
      jpeg_read_header(&h_.cinfo, TRUE);
    });
    if (h_.cinfo.image_width > static_cast<unsigned>(kMaxSide) ||
        h_.cinfo.image_height > static_cast<unsigned>(kMaxSide))
      throw_input_error(path_, "JPEG claims an implausible size");
    detail::check_image_pixels(path_, h_.cinfo.image_width, h_.cinfo.image_height);
  }
  JpegReader(const JpegReader&) = delete;
  JpegReader& operator=(const JpegReader&) = delete;

  ImageFileInfo info() const {
    ImageFileInfo out;
    out.width = static_cast<int>(h_.cinfo.image_width);
    out.height = static_cast<int>(h_.cinfo.image_height);
    out.channels = h_.cinfo.num_components;
    out.bit_depth = 8;
    return out;
  }

  ColorImage read_rgb8() {
    if (h_.cinfo.jpeg_color_space == JCS_CMYK || h_.cinfo.jpeg_color_space == JCS_YCCK)
      throw_input_error(path_, "CMYK JPEG is not supported, expected RGB or gray");
    h_.cinfo.out_color_space = JCS_RGB;  // gray is replicated by libjpeg
    run([&] { jpeg_start_decompress(&h_.cinfo); });
    if (h_.cinfo.output_components != 3) throw_input_error(path_, "unsupported JPEG colour layout");
    ColorImage image(static_cast<int>(h_.cinfo.output_width),
                     static_cast<int>(h_.cinfo.output_height));
    std::vector<JSAMPROW> rows(static_cast<std::size_t>(image.height()));
    for (int v = 0; v < image.height(); ++v) rows[static_cast<std::size_t>(v)] = image.row(v);
    run([&] {
      while (h_.cinfo.output_scanline < h_.cinfo.output_height)
        jpeg_read_scanlines(&h_.cinfo, rows.data() + h_.cinfo.output_scanline,
                            h_.cinfo.output_height - h_.cinfo.output_scanline);
      jpeg_finish_decompress(&h_.cinfo);
    });
    return image;
  }

 private:
  template <typename Step>
  void run(Step&& step) {
    if (!guarded(state_.jump, step))
      throw_input_error(path_,
                        std::string("corrupt or truncated JPEG (libjpeg: ") + state_.message + ")");
  }

  const std::filesystem::path& path_;
  JpegErrorState state_{};
  JpegHandle h_;
};

// ---------------------------------------------------------------- PNG writing
void on_png_write(png_structp png, png_bytep data, png_size_t size) {
  auto* out = static_cast<std::ofstream*>(png_get_io_ptr(png));
  out->write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!*out) png_error(png, "write failed (disk full?)");
}

void on_png_flush(png_structp png) { static_cast<std::ofstream*>(png_get_io_ptr(png))->flush(); }

struct PngWriteHandle {
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngWriteHandle() = default;
  PngWriteHandle(const PngWriteHandle&) = delete;
  PngWriteHandle& operator=(const PngWriteHandle&) = delete;
  ~PngWriteHandle() { png_destroy_write_struct(&png, &info); }
};

class PngWriter {
 public:
  explicit PngWriter(const std::filesystem::path& path) : path_(path) {
    run([&] {
      h_.png =
          png_create_write_struct(PNG_LIBPNG_VER_STRING, &state_, on_png_error, on_png_warning);
      if (h_.png) h_.info = png_create_info_struct(h_.png);
    });
    if (!h_.png || !h_.info) throw std::bad_alloc();
  }
  PngWriter(const PngWriter&) = delete;
  PngWriter& operator=(const PngWriter&) = delete;

  void write(std::ofstream& out, int width, int height, int bit_depth, int color_type,
             const std::uint8_t* data, std::size_t stride) {
    // libpng copies each row before transforming it, so the input is never written to.
    std::vector<png_bytep> rows(static_cast<std::size_t>(height));
    for (std::size_t v = 0; v < rows.size(); ++v)
      rows[v] = const_cast<png_bytep>(data + v * stride);
    run([&] {
      png_set_write_fn(h_.png, &out, on_png_write, on_png_flush);
      // Speed over size: level 1 costs a few percent of size on depth maps, and writing is on
      // the simulator's and exporters' path.
      png_set_compression_level(h_.png, 1);
      png_set_IHDR(h_.png, h_.info, static_cast<png_uint_32>(width),
                   static_cast<png_uint_32>(height), bit_depth, color_type, PNG_INTERLACE_NONE,
                   PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
      png_write_info(h_.png, h_.info);
      if (bit_depth == 16 && kLittleEndian) png_set_swap(h_.png);
      png_write_image(h_.png, rows.data());
      png_write_end(h_.png, nullptr);
    });
  }

 private:
  template <typename Step>
  void run(Step&& step) {
    if (!guarded(state_.jump, step))
      throw Error(path_.string() + ": cannot write PNG (libpng: " + state_.message + ")");
  }

  const std::filesystem::path& path_;
  PngErrorState state_{};
  PngWriteHandle h_;
};

template <typename T, int C>
void write_png_image(const std::filesystem::path& path, const Image<T, C>& image, int color_type) {
  if (image.empty() || image.width() <= 0 || image.height() <= 0)
    throw_input_error(path, "cannot write an empty image as PNG");
  if (image.width() > kMaxSide || image.height() > kMaxSide)
    throw_input_error(path, "image too large for PNG output");
  AtomicFile file(path);
  PngWriter writer(path);
  writer.write(file.stream(), image.width(), image.height(), 8 * static_cast<int>(sizeof(T)),
               color_type, reinterpret_cast<const std::uint8_t*>(image.data().data()),
               static_cast<std::size_t>(image.width()) * C * sizeof(T));
  file.commit();
}

}  // namespace

ImageFileInfo read_image_info(const std::filesystem::path& path) {
  CFile file(path, "rb");
  if (sniff(path, file.get()) == FileKind::Png) return PngReader(path, file.get()).info();
  return JpegReader(path, file.get()).info();
}

ColorImage read_color_image(const std::filesystem::path& path) {
  CFile file(path, "rb");
  if (sniff(path, file.get()) == FileKind::Jpeg) return JpegReader(path, file.get()).read_rgb8();
  detail::PngFastImage fast;
  if (detail::decode_png_fast(path, detail::read_whole_file(path), detail::PngFastLayout::Rgb8,
                              fast)) {
    ColorImage image(fast.width, fast.height);
    std::memcpy(image.data().data(), fast.pixels.data(), fast.pixels.size());
    return image;
  }
  return detail::read_color_image_libpng(path);
}

ColorImage detail::read_color_image_libpng(const std::filesystem::path& path) {
  CFile file(path, "rb");
  if (sniff(path, file.get()) == FileKind::Jpeg) return JpegReader(path, file.get()).read_rgb8();
  PngReader png(path, file.get());
  png.set_rgb8_transforms();
  ColorImage image(png.width(), png.height());
  png.read_pixels(image.data().data(), static_cast<std::size_t>(image.width()) * 3);
  return image;
}

DepthImage read_depth_image(const std::filesystem::path& path) {
  CFile file(path, "rb");
  if (sniff(path, file.get()) == FileKind::Jpeg)
    throw_input_error(path, "depth image is a JPEG, expected a 16-bit single-channel PNG");
  detail::PngFastImage fast;
  if (detail::decode_png_fast(path, detail::read_whole_file(path), detail::PngFastLayout::Gray16,
                              fast)) {
    DepthImage image(fast.width, fast.height);
    std::memcpy(image.data().data(), fast.pixels.data(), fast.pixels.size());
    return image;
  }
  return detail::read_depth_image_libpng(path);
}

DepthImage detail::read_depth_image_libpng(const std::filesystem::path& path) {
  CFile file(path, "rb");
  if (sniff(path, file.get()) == FileKind::Jpeg)
    throw_input_error(path, "depth image is a JPEG, expected a 16-bit single-channel PNG");
  PngReader png(path, file.get());
  const ImageFileInfo info = png.info();
  if (info.channels != 1 || png.color_type() != PNG_COLOR_TYPE_GRAY)
    throw_input_error(path, "depth image has " + std::to_string(info.channels) +
                                " channels, expected one 16-bit channel");
  if (png.bit_depth() != 16)
    throw_input_error(
        path, "depth image is " + std::to_string(png.bit_depth()) + "-bit, expected 16-bit");
  png.set_depth_transforms();
  DepthImage image(png.width(), png.height());
  png.read_pixels(reinterpret_cast<std::uint8_t*>(image.data().data()),
                  static_cast<std::size_t>(image.width()) * 2);
  return image;
}

void write_png(const std::filesystem::path& path, const ColorImage& image) {
  write_png_image(path, image, PNG_COLOR_TYPE_RGB);
}

void write_png(const std::filesystem::path& path, const GrayImage& image) {
  write_png_image(path, image, PNG_COLOR_TYPE_GRAY);
}

void write_png(const std::filesystem::path& path, const DepthImage& image) {
  write_png_image(path, image, PNG_COLOR_TYPE_GRAY);
}

}  // namespace locard
