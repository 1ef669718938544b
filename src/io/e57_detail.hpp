#pragma once
// Internals of the E57 reader and writer (src/io/e57_*.cpp), not installed.
// Layers, bottom up: pages and CRC (e57_pages.cpp), the XML helpers (e57_xml.cpp), the
// bytestream codec of compressed vectors (e57_codec.cpp), then e57_reader.cpp / e57_writer.cpp.

#include "core/huge_page_allocator.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <iosfwd>
#include <new>
#include <string>
#include <utility>
#include <vector>

namespace pugi {
class xml_node;
}

namespace locard::e57_detail {

inline constexpr std::uint64_t kPageSize = 1024;
inline constexpr std::uint64_t kPagePayload = 1020;  // the last 4 bytes hold the CRC
inline constexpr std::size_t kHeaderSize = 48;
inline constexpr std::size_t kSectionHeaderSize = 32;   // CompressedVector section header
inline constexpr std::size_t kMaxPacketSize = 65536;   // a packet's length is a uint16 minus 1
inline constexpr char kSignature[8] = {'A', 'S', 'T', 'M', '-', 'E', '5', '7'};

// The big byte buffers (a whole file, a bytestream): on huge pages, since on the 2-core VM
// first-touch page faults cost more than the codec itself, and not zero-filled by resize(),
// since every byte is written before it is read.
template <typename T>
struct BufferAllocator {
  using value_type = T;
  BufferAllocator() = default;
  template <typename U>
  BufferAllocator(const BufferAllocator<U>&) {}
  T* allocate(std::size_t n) { return static_cast<T*>(detail::allocate_large(n * sizeof(T))); }
  void deallocate(T* p, std::size_t n) noexcept { detail::deallocate_large(p, n * sizeof(T)); }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    if constexpr (sizeof...(Args) == 0)
      ::new (static_cast<void*>(p)) U;  // default-initialised: left as it is
    else
      ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  bool operator==(const BufferAllocator&) const { return true; }
};
using Bytes = std::vector<std::uint8_t, BufferAllocator<std::uint8_t>>;

// Reserves `n` elements of a result vector and asks for huge pages under them before the
// first touch (the same reason as BufferAllocator, for PointCloud's std::vectors).
void reserve_huge(void* data, std::size_t bytes);
template <typename T>
void resize_huge(std::vector<T>& v, std::size_t n) {
  v.reserve(n);
  reserve_huge(v.data(), n * sizeof(T));
  v.resize(n);
}

// ---- pages (e57_pages.cpp) ----

// CRC-32C (Castagnoli), as E57 pages store it (big-endian in the page's last 4 bytes).
std::uint32_t crc32c(const std::uint8_t* data, std::size_t size);
// Writes a whole page's CRC-32C of its payload into its last 4 bytes.
void seal_page(std::uint8_t* page);

struct FileHeader {
  std::uint32_t major = 1;
  std::uint32_t minor = 0;
  std::uint64_t file_length = 0;  // physical bytes
  std::uint64_t xml_offset = 0;   // physical
  std::uint64_t xml_length = 0;   // logical bytes
  std::uint64_t page_size = kPageSize;
};

// The file with every page's CRC checked and stripped: offsets in `bytes` are logical.
struct LogicalFile {
  std::filesystem::path path;
  FileHeader header;
  Bytes bytes;
};

LogicalFile load_logical_file(const std::filesystem::path& path);
// Physical offset (as the XML and section headers give them) to logical; InputError naming
// `where` when the offset points into a CRC or past the end.
std::uint64_t to_logical(const LogicalFile& file, std::uint64_t physical, const std::string& where);
inline std::uint64_t to_physical(std::uint64_t logical) {
  return logical / kPagePayload * kPageSize + logical % kPagePayload;
}
// Logical bytes -> whole pages with CRCs (zero padding in the last page), written to `out`
// a few hundred pages at a time (no second copy of the file in memory).
void write_pages(std::ostream& out, const std::uint8_t* logical, std::size_t size);
// The same, as one buffer (tests damage files this way).
std::vector<std::uint8_t> paginate(const std::uint8_t* logical, std::size_t size);
void put_header(std::uint8_t* at, const FileHeader& header);

// "<path>: <where>: <what>" as an InputError.
[[noreturn]] void fail(const std::filesystem::path& path, const std::string& where,
                       const std::string& what);

template <typename T>
T load_le(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));  // E57 is little-endian, like every machine Locard builds on
  return v;
}
template <typename T>
void store_le(std::uint8_t* p, T v) {
  std::memcpy(p, &v, sizeof(T));
}

// ---- fields and the bytestream codec (e57_codec.cpp) ----

enum class FieldType { Float32, Float64, Integer, ScaledInteger };

// One terminal of a CompressedVector's prototype; its bytestream has the same index.
struct FieldSpec {
  std::string name;
  FieldType type = FieldType::Float64;
  std::int64_t minimum = 0;  // Integer/ScaledInteger raw range
  std::int64_t maximum = 0;
  double scale = 1.0;
  double offset = 0.0;
  // Float: the prototype's minimum/maximum attributes where given (used as colour/intensity
  // limits when the scan has none).
  double float_minimum = 0.0;
  double float_maximum = 0.0;
  bool has_float_range = false;

  unsigned bits() const;  // per record in the bytestream
};

// One field's bytes, concatenated over all data packets, with zero padding after `size` so the
// bit unpacker may load whole 64-bit words past the last value.
struct Bytestream {
  Bytes bytes;
  std::size_t size = 0;
};

inline constexpr std::size_t kStreamPadding = 16;

// Reads the CompressedVector section at `physical_offset` and gathers each field's bytestream
// until it holds `record_count` records. `where` names the XML element for errors.
std::vector<Bytestream> read_bytestreams(const LogicalFile& file, std::uint64_t physical_offset,
                                         const std::vector<FieldSpec>& fields,
                                         std::uint64_t record_count, const std::string& where);

// Calls sink(i, value) for records 0..n-1 of `field`, value as double (a ScaledInteger scaled,
// a float widened exactly). The stream must hold n records (read_bytestreams checks).
template <typename Sink>
void decode_field(const FieldSpec& field, const Bytestream& stream, std::size_t n, Sink&& sink) {
  const std::uint8_t* p = stream.bytes.data();
  switch (field.type) {
    case FieldType::Float32:
      for (std::size_t i = 0; i < n; ++i) sink(i, static_cast<double>(load_le<float>(p + 4 * i)));
      return;
    case FieldType::Float64:
      for (std::size_t i = 0; i < n; ++i) sink(i, load_le<double>(p + 8 * i));
      return;
    case FieldType::Integer:
    case FieldType::ScaledInteger: break;
  }
  const unsigned bits = field.bits();
  const bool scaled = field.type == FieldType::ScaledInteger;
  const auto base = static_cast<std::uint64_t>(field.minimum);
  const std::uint64_t mask = bits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
  for (std::size_t i = 0; i < n; ++i) {
    // Records are packed LSB first, back to back: record i is bits [i*bits, (i+1)*bits).
    const std::uint64_t bit = static_cast<std::uint64_t>(i) * bits;
    const std::uint8_t* word = p + bit / 8;
    const unsigned shift = bit % 8;
    std::uint64_t v = load_le<std::uint64_t>(word) >> shift;
    if (shift + bits > 64) v |= load_le<std::uint64_t>(word + 8) << (64 - shift);
    const auto raw = static_cast<std::int64_t>(base + (v & mask));
    sink(i, scaled ? static_cast<double>(raw) * field.scale + field.offset
                   : static_cast<double>(raw));
  }
}

// A byte-aligned column the writer packs: record i's `width` bytes are at base + i * stride.
struct Column {
  const std::uint8_t* base = nullptr;
  std::size_t stride = 0;
  std::size_t width = 0;
};

// Records per data packet for these columns (each packet at most kMaxPacketSize bytes).
std::size_t records_per_packet(const std::vector<Column>& columns);
// Bytes the section (header + packets) takes for `n` records.
std::size_t section_size(const std::vector<Column>& columns, std::size_t n);
// Writes the CompressedVector section (header and data packets) for records 0..n-1 at logical
// offset `at` of `out` (which must hold section_size bytes from there).
void write_section(std::uint8_t* out, std::uint64_t at, const std::vector<Column>& columns,
                   std::size_t n);

// ---- XML helpers (e57_xml.cpp) ----

// "a/b[2]/c" style names for errors.
std::string element_path(const pugi::xml_node& node);
// The value of a Float, Integer or ScaledInteger element (an empty element is 0).
double number_value(const std::filesystem::path& path, const pugi::xml_node& node);
// The text of a String element ("" when absent).
std::string string_value(const pugi::xml_node& node);
std::uint64_t unsigned_attribute(const std::filesystem::path& path, const pugi::xml_node& node,
                                 const char* name);
// The prototype's terminals, in order.
std::vector<FieldSpec> parse_prototype(const std::filesystem::path& path,
                                       const pugi::xml_node& prototype);
// Shortest text that reads back as the same double.
std::string format_double(double v);
// "{8-4-4-4-12}" random (version 4) guid.
std::string random_guid();

}  // namespace locard::e57_detail
