// E57 compressed vectors: the CompressedVector binary section (a 32-byte header, then data,
// index and empty packets) and the bytestreams its data packets carry, one per prototype field.
// A bit-packed value may straddle two packets, so the reader concatenates each field's buffers
// over all packets before unpacking (decode_field in e57_detail.hpp). The writer only writes
// byte-aligned fields (single floats, 8-bit integers), so its packets split cleanly.

#include "io/e57_detail.hpp"

#include <algorithm>

namespace locard::e57_detail {
namespace {

enum PacketType : std::uint8_t { kIndexPacket = 0, kDataPacket = 1, kEmptyPacket = 2 };

struct SectionHeader {
  std::uint64_t begin = 0;  // logical
  std::uint64_t end = 0;    // logical, one past the last byte
  std::uint64_t data_begin = 0;  // logical offset of the first packet
};

std::string at_byte(std::uint64_t logical) {
  return "byte " + std::to_string(to_physical(logical));
}

SectionHeader read_section_header(const LogicalFile& file, std::uint64_t physical_offset,
                                  const std::string& where) {
  const auto* data = reinterpret_cast<const std::uint8_t*>(file.bytes.data());
  const std::uint64_t size = file.bytes.size();
  SectionHeader s;
  s.begin = to_logical(file, physical_offset, where + " fileOffset");
  if (size - s.begin < kSectionHeaderSize)
    fail(file.path, where, "its section header at " + at_byte(s.begin) + " runs past the end");
  const std::uint8_t* p = data + s.begin;
  if (p[0] != 1)
    fail(file.path, where, "the binary section at " + at_byte(s.begin) + " has id " +
                               std::to_string(p[0]) + ", a CompressedVector's is 1");
  const auto length = load_le<std::uint64_t>(p + 8);
  if (length < kSectionHeaderSize || length > size - s.begin)
    fail(file.path, where, "the section at " + at_byte(s.begin) + " claims " +
                               std::to_string(length) + " bytes, past the end of the file");
  s.end = s.begin + length;
  const auto data_physical = load_le<std::uint64_t>(p + 16);
  s.data_begin = to_logical(file, data_physical, where + " dataPhysicalOffset");
  if (s.data_begin < s.begin + kSectionHeaderSize || s.data_begin > s.end)
    fail(file.path, where, "dataPhysicalOffset " + std::to_string(data_physical) +
                               " lies outside its section");
  return s;
}

// Appends the data packet's buffers at `p` (`length` bytes) to the streams.
void take_data_packet(const LogicalFile& file, const std::uint8_t* p, std::size_t length,
                      std::uint64_t pos, std::vector<Bytestream>& streams,
                      const std::string& where) {
  if (length < 6) fail(file.path, where, "data packet at " + at_byte(pos) + " is too short");
  const auto count = load_le<std::uint16_t>(p + 4);
  if (count != streams.size())
    fail(file.path, where, "data packet at " + at_byte(pos) + " has " + std::to_string(count) +
                               " bytestreams, the prototype has " +
                               std::to_string(streams.size()) + " fields");
  std::size_t offset = 6 + 2 * std::size_t{count};
  if (offset > length)
    fail(file.path, where, "data packet at " + at_byte(pos) + " is too short for its header");
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t n = load_le<std::uint16_t>(p + 6 + 2 * k);
    if (n > length - offset)
      fail(file.path, where, "data packet at " + at_byte(pos) + ": its bytestream buffers add " +
                                 "up to more than the packet's " + std::to_string(length) +
                                 " bytes");
    streams[k].bytes.insert(streams[k].bytes.end(), p + offset, p + offset + n);
    offset += n;
  }
}

std::size_t round_up4(std::size_t n) { return (n + 3) / 4 * 4; }

std::size_t packet_header_size(const std::vector<Column>& columns) {
  return 6 + 2 * columns.size();
}

std::size_t record_bytes(const std::vector<Column>& columns) {
  std::size_t n = 0;
  for (const Column& c : columns) n += c.width;
  return n;
}

template <std::size_t W>
void copy_column(std::uint8_t* out, const Column& c, std::size_t first, std::size_t m) {
  const std::uint8_t* in = c.base + first * c.stride;
  if (c.stride == W) {
    std::memcpy(out, in, m * W);
    return;
  }
  for (std::size_t i = 0; i < m; ++i) std::memcpy(out + i * W, in + i * c.stride, W);
}

// One data packet holding records first..first+m-1; returns its (padded) size.
std::size_t write_packet(std::uint8_t* out, const std::vector<Column>& columns,
                         std::size_t first, std::size_t m) {
  const std::size_t header = packet_header_size(columns);
  const std::size_t size = round_up4(header + m * record_bytes(columns));
  out[0] = kDataPacket;
  out[1] = 0;  // flags: no compressor restart
  store_le(out + 2, static_cast<std::uint16_t>(size - 1));
  store_le(out + 4, static_cast<std::uint16_t>(columns.size()));
  std::uint8_t* body = out + header;
  for (std::size_t k = 0; k < columns.size(); ++k) {
    const Column& c = columns[k];
    store_le(out + 6 + 2 * k, static_cast<std::uint16_t>(m * c.width));
    switch (c.width) {
      case 1: copy_column<1>(body, c, first, m); break;
      case 4: copy_column<4>(body, c, first, m); break;
      default: copy_column<8>(body, c, first, m); break;
    }
    body += m * c.width;
  }
  std::memset(body, 0, out + size - body);
  return size;
}

}  // namespace

std::vector<Bytestream> read_bytestreams(const LogicalFile& file, std::uint64_t physical_offset,
                                         const std::vector<FieldSpec>& fields,
                                         std::uint64_t record_count, const std::string& where) {
  const SectionHeader section = read_section_header(file, physical_offset, where);
  const std::uint64_t section_bytes = section.end - section.begin;
  std::vector<Bytestream> streams(fields.size());
  std::vector<std::uint64_t> needed(fields.size());
  // A count the section cannot hold is refused before anything is sized from it.
  for (std::size_t k = 0; k < fields.size(); ++k) {
    const unsigned bits = fields[k].bits();
    if (bits > 0 && record_count > section_bytes * 8 / bits)
      fail(file.path, where, "recordCount " + std::to_string(record_count) + " records of field '" +
                                 fields[k].name + "' cannot fit in its " +
                                 std::to_string(section_bytes) + "-byte section");
    needed[k] = (record_count * bits + 7) / 8;
    streams[k].bytes.reserve(needed[k] + kStreamPadding);
  }
  if (record_count > section_bytes * 8)
    fail(file.path, where, "recordCount " + std::to_string(record_count) +
                               " is more than its section could hold");
  const auto complete = [&] {
    for (std::size_t k = 0; k < streams.size(); ++k)
      if (streams[k].bytes.size() < needed[k]) return false;
    return true;
  };
  const auto* data = reinterpret_cast<const std::uint8_t*>(file.bytes.data());
  std::uint64_t pos = section.data_begin;
  while (!complete()) {
    if (section.end - pos < 4) {
      std::size_t k = 0;
      while (streams[k].bytes.size() >= needed[k]) ++k;
      fail(file.path, where, "the section ends before the data of recordCount " +
                                 std::to_string(record_count) + ": field '" + fields[k].name +
                                 "' has " + std::to_string(streams[k].bytes.size()) + " of the " +
                                 std::to_string(needed[k]) + " bytes it needs");
    }
    const std::uint8_t* p = data + pos;
    const std::size_t length = std::size_t{load_le<std::uint16_t>(p + 2)} + 1;
    if (length > section.end - pos)
      fail(file.path, where, "packet at " + at_byte(pos) + " (" + std::to_string(length) +
                                 " bytes) runs past the end of its section");
    if (p[0] == kDataPacket)
      take_data_packet(file, p, length, pos, streams, where);
    else if (p[0] != kIndexPacket && p[0] != kEmptyPacket)
      fail(file.path, where, "packet at " + at_byte(pos) + " has unknown type " +
                                 std::to_string(p[0]));
    pos += length;
  }
  for (Bytestream& s : streams) {
    s.size = s.bytes.size();
    s.bytes.resize(s.size + kStreamPadding, 0);
  }
  return streams;
}

std::size_t records_per_packet(const std::vector<Column>& columns) {
  return (kMaxPacketSize - packet_header_size(columns)) / record_bytes(columns);
}

std::size_t section_size(const std::vector<Column>& columns, std::size_t n) {
  const std::size_t per = records_per_packet(columns);
  const std::size_t header = packet_header_size(columns);
  const std::size_t full = n / per;
  const std::size_t rest = n % per;
  std::size_t size = kSectionHeaderSize + full * round_up4(header + per * record_bytes(columns));
  if (rest > 0) size += round_up4(header + rest * record_bytes(columns));
  return size;
}

void write_section(std::uint8_t* out, std::uint64_t at, const std::vector<Column>& columns,
                   std::size_t n) {
  std::uint8_t* p = out + at;
  const std::size_t length = section_size(columns, n);
  std::memset(p, 0, kSectionHeaderSize);
  p[0] = 1;  // CompressedVector
  store_le(p + 8, static_cast<std::uint64_t>(length));
  store_le(p + 16, to_physical(at + kSectionHeaderSize));
  store_le(p + 24, std::uint64_t{0});  // no index packets
  std::uint8_t* packet = p + kSectionHeaderSize;
  const std::size_t per = records_per_packet(columns);
  for (std::size_t first = 0; first < n; first += per)
    packet += write_packet(packet, columns, first, std::min(per, n - first));
}

}  // namespace locard::e57_detail
