#include "io/lzf.hpp"

#include <algorithm>
#include <cstring>
#include <limits>

namespace locard::lzf {
namespace {

constexpr std::size_t kMaxLiteral = 32;          // 5-bit run length + 1
constexpr std::size_t kMaxOffset = 1u << 13;     // 13-bit offset + 1
constexpr std::size_t kMaxMatch = 7 + 255 + 2;   // long form: 7 + extra byte, + 2
constexpr int kHashBits = 14;
constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

std::uint32_t triple(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 16) | (std::uint32_t{p[1]} << 8) | p[2];
}

std::size_t hash3(std::uint32_t v) {
  // Multiplicative hash: the top bits of v * golden ratio spread neighbouring triples apart.
  return (v * 2654435761u) >> (32 - kHashBits);
}

// Output cursor into a buffer sized for the worst case, so emitting never reallocates.
struct Out {
  std::uint8_t* p;
};

void emit_literals(Out& out, const std::uint8_t* from, std::size_t n) {
  while (n > 0) {
    const std::size_t run = std::min(n, kMaxLiteral);
    *out.p++ = static_cast<std::uint8_t>(run - 1);
    std::memcpy(out.p, from, run);
    out.p += run;
    from += run;
    n -= run;
  }
}

void emit_match(Out& out, std::size_t length, std::size_t offset) {
  const std::size_t len_code = length - 2;  // 1..262
  const std::size_t off_code = offset - 1;  // 0..8191
  const auto off_high = static_cast<std::uint8_t>(off_code >> 8);
  if (len_code < 7) {
    *out.p++ = static_cast<std::uint8_t>((len_code << 5) | off_high);
  } else {
    *out.p++ = static_cast<std::uint8_t>((7u << 5) | off_high);
    *out.p++ = static_cast<std::uint8_t>(len_code - 7);
  }
  *out.p++ = static_cast<std::uint8_t>(off_code & 0xff);
}

}  // namespace

std::vector<std::uint8_t> compress(const std::uint8_t* data, std::size_t size) {
  // Worst case: all literals, one control byte per 32.
  std::vector<std::uint8_t> buffer(size + size / kMaxLiteral + 16);
  Out out{buffer.data()};
  std::vector<std::size_t> table(std::size_t{1} << kHashBits, kNone);
  std::size_t literal_start = 0;
  std::size_t i = 0;
  while (i + 3 <= size) {
    const std::uint32_t v = triple(data + i);
    const std::size_t h = hash3(v);
    const std::size_t ref = table[h];
    table[h] = i;
    if (ref == kNone || i - ref > kMaxOffset || triple(data + ref) != v) {
      ++i;
      continue;
    }
    // Greedy: take the longest match at this position; overlap with i is allowed.
    const std::size_t limit = std::min(kMaxMatch, size - i);
    std::size_t length = 3;
    while (length < limit && data[ref + length] == data[i + length]) ++length;
    emit_literals(out, data + literal_start, i - literal_start);
    emit_match(out, length, i - ref);
    // Index the positions the match covers so later data can refer to them.
    const std::size_t end = i + length;
    for (++i; i < end && i + 3 <= size; ++i) table[hash3(triple(data + i))] = i;
    i = end;
    literal_start = end;
  }
  emit_literals(out, data + literal_start, size - literal_start);
  buffer.resize(static_cast<std::size_t>(out.p - buffer.data()));
  return buffer;
}

std::optional<std::vector<std::uint8_t>> decompress(const std::uint8_t* data, std::size_t size,
                                                    std::size_t expected) {
  std::vector<std::uint8_t> out(expected);
  std::size_t in = 0;
  std::size_t pos = 0;
  while (in < size) {
    const std::size_t ctrl = data[in++];
    if (ctrl < 32) {
      const std::size_t run = ctrl + 1;
      if (run > size - in || run > expected - pos) return std::nullopt;
      std::memcpy(out.data() + pos, data + in, run);
      in += run;
      pos += run;
      continue;
    }
    std::size_t length = ctrl >> 5;
    if (length == 7) {
      if (in >= size) return std::nullopt;
      length += data[in++];
    }
    length += 2;
    if (in >= size) return std::nullopt;
    const std::size_t offset = ((ctrl & 0x1f) << 8) + data[in++] + 1;
    if (offset > pos || length > expected - pos) return std::nullopt;
    std::uint8_t* dst = out.data() + pos;
    const std::uint8_t* src = dst - offset;
    if (offset >= length) {
      std::memcpy(dst, src, length);
    } else {
      for (std::size_t k = 0; k < length; ++k) dst[k] = src[k];  // overlapping run
    }
    pos += length;
  }
  if (pos != expected) return std::nullopt;
  return out;
}

}  // namespace locard::lzf
