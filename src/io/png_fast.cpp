#include "io/text_lines.hpp"
#include "png_fast.hpp"

#include <locard/core/error.hpp>

#include <fmt/format.h>
#include <libdeflate.h>

#include <bit>
#include <cstdio>
#include <cstdlib>
#include <cerrno>
#include <cstring>
#include <memory>
#include <string>

namespace locard::detail {
namespace {

constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
// Same cap as the libpng path: a corrupt header can claim any size.
constexpr std::uint32_t kMaxSide = 1u << 16;

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

[[noreturn]] void corrupt(const std::filesystem::path& path, const std::string& what) {
  throw_input_error(path, "corrupt or truncated PNG (" + what + ")");
}

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

// One decompressor per thread: its tables are built per call anyway, the object only saves
// an allocation.
libdeflate_decompressor* thread_decompressor() {
  thread_local std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> d(
      libdeflate_alloc_decompressor());
  if (!d) throw std::bad_alloc();
  return d.get();
}

inline std::uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return static_cast<std::uint8_t>(a);
  return static_cast<std::uint8_t>(pb <= pc ? b : c);
}

// Undoes the row filter (PNG spec section 9) of one row of `n` bytes, `bpp` bytes per pixel,
// writing into `out`; `prev` is the previous unfiltered row (all zero for the first).
template <int Bpp>
void unfilter_row(int type, const std::uint8_t* in, const std::uint8_t* prev, std::uint8_t* out,
                  std::size_t n) {
  switch (type) {
    case 0: std::memcpy(out, in, n); return;
    case 1:
      for (std::size_t i = 0; i < Bpp && i < n; ++i) out[i] = in[i];
      for (std::size_t i = Bpp; i < n; ++i) out[i] = static_cast<std::uint8_t>(in[i] + out[i - Bpp]);
      return;
    case 2:
      for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<std::uint8_t>(in[i] + prev[i]);
      return;
    case 3:
      for (std::size_t i = 0; i < Bpp && i < n; ++i)
        out[i] = static_cast<std::uint8_t>(in[i] + (prev[i] >> 1));
      for (std::size_t i = Bpp; i < n; ++i)
        out[i] = static_cast<std::uint8_t>(in[i] + ((out[i - Bpp] + prev[i]) >> 1));
      return;
    case 4:
      for (std::size_t i = 0; i < Bpp && i < n; ++i)
        out[i] = static_cast<std::uint8_t>(in[i] + prev[i]);  // paeth(0, b, 0) == b
      for (std::size_t i = Bpp; i < n; ++i)
        out[i] = static_cast<std::uint8_t>(in[i] + paeth(out[i - Bpp], prev[i], prev[i - Bpp]));
      return;
    default: break;
  }
}

}  // namespace

void check_image_pixels(const std::filesystem::path& path, std::uint64_t width,
                        std::uint64_t height) {
  constexpr std::uint64_t kMaxImagePixels = std::uint64_t{1} << 27;
  if (width * height > kMaxImagePixels)  // both < 2^32: no overflow
    throw_input_error(path, fmt::format("the header claims {} x {} pixels (at most {} M pixels "
                                        "are read)", width, height, kMaxImagePixels >> 20));
}

void check_image_budget(const std::filesystem::path& path, std::uint64_t width,
                        std::uint64_t height, std::uint64_t bytes_per_pixel,
                        std::uint64_t compressed_bytes) {
  constexpr std::uint64_t kMaxDeflateRatio = 1032;
  check_image_pixels(path, width, height);
  const std::uint64_t pixels = width * height;
  const std::uint64_t decoded = pixels * bytes_per_pixel + height;  // a filter byte per row
  if (decoded > kMaxDeflateRatio * compressed_bytes + 1024)
    throw_input_error(path, fmt::format("corrupt or truncated PNG: the header claims {} x {} "
                                        "pixels, more than its {} bytes of data can hold",
                                        width, height, compressed_bytes));
}

std::vector<std::uint8_t> read_whole_file(const std::filesystem::path& path) {
  return io_detail::read_file_into<std::vector<std::uint8_t>>(path);
}

bool decode_png_fast(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes,
                     PngFastLayout want, PngFastImage& out) {
  const std::size_t size = bytes.size();
  const std::uint8_t* data = bytes.data();
  if (size < 8 || std::memcmp(data, kSignature, 8) != 0) return false;  // libpng says why
  // IHDR must come first: 13 bytes of header data.
  if (size < 8 + 8 + 13 + 4 || be32(data + 8) != 13 || std::memcmp(data + 12, "IHDR", 4) != 0)
    return false;
  const std::uint8_t* ihdr = data + 16;
  const std::uint32_t width = be32(ihdr), height = be32(ihdr + 4);
  const int bit_depth = ihdr[8], color_type = ihdr[9], interlace = ihdr[12];
  const bool layout_ok = want == PngFastLayout::Gray16 ? (bit_depth == 16 && color_type == 0)
                                                       : (bit_depth == 8 && color_type == 2);
  if (!layout_ok || interlace != 0 || ihdr[10] != 0 || ihdr[11] != 0) return false;
  if (width == 0 || height == 0 || width > kMaxSide || height > kMaxSide) return false;
  if (libdeflate_crc32(0, data + 12, 4 + 13) != be32(data + 29)) corrupt(path, "IHDR CRC");

  // Walk the chunks, checking CRCs as libpng does (critical chunks: error; ancillary: the
  // chunk is ignored), and gather the IDAT payloads.
  std::vector<std::uint8_t> joined;
  const std::uint8_t* idat = nullptr;
  std::size_t idat_size = 0, idat_chunks = 0;
  bool seen_iend = false;
  for (std::size_t pos = 33; !seen_iend;) {
    if (pos + 12 > size) corrupt(path, "file ends inside a chunk header");
    const std::uint32_t length = be32(data + pos);
    const std::uint8_t* type = data + pos + 4;
    if (length > size - pos - 12) corrupt(path, "file ends inside a chunk");
    const std::uint8_t* payload = data + pos + 8;
    const bool critical = (type[0] & 0x20) == 0;
    const bool crc_ok = libdeflate_crc32(0, type, 4 + length) == be32(payload + length);
    if (!crc_ok && critical)
      corrupt(path, std::string(reinterpret_cast<const char*>(type), 4) + " CRC");
    if (std::memcmp(type, "IDAT", 4) == 0) {
      if (idat_chunks == 1) joined.assign(idat, idat + idat_size);
      if (idat_chunks >= 1) joined.insert(joined.end(), payload, payload + length);
      idat = payload;
      idat_size = idat_chunks == 0 ? length : joined.size();
      ++idat_chunks;
    } else if (std::memcmp(type, "IEND", 4) == 0) {
      seen_iend = true;
    } else if (std::memcmp(type, "PLTE", 4) == 0 || std::memcmp(type, "tRNS", 4) == 0) {
      return false;  // colour handling beyond this fast path: libpng decides
    } else if (critical) {
      return false;  // an unknown critical chunk: let libpng report it
    }
    pos += 12 + std::size_t{length};
  }
  if (idat_chunks == 0) corrupt(path, "no image data");
  if (idat_chunks > 1) {
    idat = joined.data();
    idat_size = joined.size();
  }

  const std::size_t bpp = want == PngFastLayout::Gray16 ? 2 : 3;
  const std::size_t row_bytes = bpp * width;
  const std::size_t expected = std::size_t{height} * (1 + row_bytes);
  check_image_budget(path, width, height, bpp, idat_size);
  std::vector<std::uint8_t> filtered(expected);
  std::size_t produced = 0;
  const libdeflate_result r = libdeflate_zlib_decompress(thread_decompressor(), idat, idat_size,
                                                         filtered.data(), expected, &produced);
  if (r != LIBDEFLATE_SUCCESS || produced != expected)
    corrupt(path, r == LIBDEFLATE_SUCCESS ? "image data has the wrong size"
                                          : "compressed image data does not inflate");

  std::vector<std::uint8_t> pixels(std::size_t{height} * row_bytes);
  const std::vector<std::uint8_t> zero_row(row_bytes, 0);
  for (std::size_t v = 0; v < height; ++v) {
    const std::uint8_t* in = filtered.data() + v * (1 + row_bytes);
    const std::uint8_t* prev = v == 0 ? zero_row.data() : pixels.data() + (v - 1) * row_bytes;
    std::uint8_t* row = pixels.data() + v * row_bytes;
    if (in[0] > 4) corrupt(path, "unknown row filter " + std::to_string(in[0]) + " in row " +
                                     std::to_string(v));
    if (bpp == 2) unfilter_row<2>(in[0], in + 1, prev, row, row_bytes);
    else unfilter_row<3>(in[0], in + 1, prev, row, row_bytes);
  }
  if (bpp == 2 && std::endian::native == std::endian::little) {
    // PNG samples are big-endian.
    for (std::size_t i = 0; i < pixels.size(); i += 2) std::swap(pixels[i], pixels[i + 1]);
  }
  out.width = static_cast<int>(width);
  out.height = static_cast<int>(height);
  out.pixels = std::move(pixels);
  return true;
}

}  // namespace locard::detail
