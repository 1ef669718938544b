// Binary FBX 7.4 encoding; the layout is in fbx_binary.hpp.
#include "fbx_binary.hpp"

#include <locard/core/error.hpp>

#include <fmt/format.h>
#include <libdeflate.h>

#include <cstring>
#include <limits>
#include <memory>

namespace locard::detail {
namespace {

constexpr std::size_t kNullNodeBytes = 13;      // end offset, property count, bytes, name length
constexpr std::size_t kCompressAbove = 256;     // smaller arrays stay raw (encoding 0)
constexpr int kDeflateLevel = 6;

template <typename T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // x86-64 and ARM64 are little-endian, as FBX is
  out.append(bytes, sizeof(T));
}

void put_u32_at(std::string& out, std::size_t at, std::size_t value) {
  if (value > std::numeric_limits<std::uint32_t>::max())
    throw Error(fmt::format("FBX 7.4 offsets are 32-bit: the file would pass 4 GiB ({} bytes)",
                            value));
  const auto v = static_cast<std::uint32_t>(value);
  std::memcpy(out.data() + at, &v, sizeof(v));
}

struct CompressorDeleter {
  void operator()(libdeflate_compressor* c) const { libdeflate_free_compressor(c); }
};

// zlib stream (RFC 1950) of `data`, FBX's array encoding 1.
std::string zlib_compress(const void* data, std::size_t size) {
  std::unique_ptr<libdeflate_compressor, CompressorDeleter> c(
      libdeflate_alloc_compressor(kDeflateLevel));
  if (!c) throw Error("FBX: cannot allocate a deflate compressor");
  std::string out(libdeflate_zlib_compress_bound(c.get(), size), '\0');
  const std::size_t n = libdeflate_zlib_compress(c.get(), data, size, out.data(), out.size());
  if (n == 0) throw Error("FBX: deflate failed");
  out.resize(n);
  return out;
}

template <typename T>
void put_array(std::string& out, char type, const std::vector<T>& values) {
  if (values.size() > std::numeric_limits<std::uint32_t>::max())
    throw Error(fmt::format("FBX: an array of {} values is too long", values.size()));
  const std::size_t bytes = values.size() * sizeof(T);
  out.push_back(type);
  put<std::uint32_t>(out, static_cast<std::uint32_t>(values.size()));
  if (bytes <= kCompressAbove) {
    put<std::uint32_t>(out, 0);
    put<std::uint32_t>(out, static_cast<std::uint32_t>(bytes));
    out.append(reinterpret_cast<const char*>(values.data()), bytes);
    return;
  }
  const std::string z = zlib_compress(values.data(), bytes);
  put<std::uint32_t>(out, 1);
  put<std::uint32_t>(out, static_cast<std::uint32_t>(z.size()));
  out += z;
}

}  // namespace

FbxNode::FbxNode(std::string name) : name_(std::move(name)) {
  if (name_.size() > 255) throw Error("FBX: node name longer than 255 bytes: " + name_);
}

FbxNode& FbxNode::boolean(bool value) {
  properties_.push_back('C');
  properties_.push_back(value ? 1 : 0);
  ++property_count_;
  return *this;
}

FbxNode& FbxNode::i32(std::int32_t value) {
  properties_.push_back('I');
  put(properties_, value);
  ++property_count_;
  return *this;
}

FbxNode& FbxNode::i64(std::int64_t value) {
  properties_.push_back('L');
  put(properties_, value);
  ++property_count_;
  return *this;
}

FbxNode& FbxNode::f64(double value) {
  properties_.push_back('D');
  put(properties_, value);
  ++property_count_;
  return *this;
}

FbxNode& FbxNode::string(std::string_view value) {
  properties_.push_back('S');
  put<std::uint32_t>(properties_, static_cast<std::uint32_t>(value.size()));
  properties_ += value;
  ++property_count_;
  return *this;
}

FbxNode& FbxNode::raw(std::string_view bytes) {
  properties_.push_back('R');
  put<std::uint32_t>(properties_, static_cast<std::uint32_t>(bytes.size()));
  properties_ += bytes;
  ++property_count_;
  return *this;
}

FbxNode& FbxNode::i32_array(const std::vector<std::int32_t>& values) {
  put_array(properties_, 'i', values);
  ++property_count_;
  return *this;
}

FbxNode& FbxNode::f64_array(const std::vector<double>& values) {
  put_array(properties_, 'd', values);
  ++property_count_;
  return *this;
}

FbxNode& FbxNode::child(std::string name) {
  children_.push_back(std::make_unique<FbxNode>(std::move(name)));
  return *children_.back();
}

FbxNode& FbxNode::add(FbxNode node) {
  children_.push_back(std::make_unique<FbxNode>(std::move(node)));
  return *children_.back();
}

void FbxNode::encode(std::string& out) const {
  const std::size_t start = out.size();
  put<std::uint32_t>(out, 0);  // end offset, patched below
  put<std::uint32_t>(out, property_count_);
  put<std::uint32_t>(out, 0);  // property bytes, patched below
  out.push_back(static_cast<char>(name_.size()));
  out += name_;
  out += properties_;
  put_u32_at(out, start + 8, properties_.size());
  for (const auto& c : children_) c->encode(out);
  // Children end with a null node; so does an empty node, as the FBX SDK writes it.
  if (!children_.empty() || property_count_ == 0) out.append(kNullNodeBytes, '\0');
  put_u32_at(out, start, out.size());
}

FbxNode& fbx_property(FbxNode& properties70, std::string_view name, std::string_view type,
                      std::string_view label, std::string_view flags) {
  return properties70.child("P").string(name).string(type).string(label).string(flags);
}

std::string encode_fbx_file(const std::vector<FbxNode>& top_level, std::uint32_t version) {
  std::string out("Kaydara FBX Binary  \0\x1a\0", 23);
  put(out, version);
  for (const FbxNode& node : top_level) node.encode(out);
  out.append(kNullNodeBytes, '\0');
  // Footer as the FBX SDK writes it (Blender's exporter writes the same constants): an id,
  // padding to 16 bytes, the version, 120 zero bytes and a closing magic.
  static constexpr unsigned char kFooterId[16] = {0xfa, 0xbc, 0xab, 0x09, 0xd0, 0xc8, 0xd4, 0x66,
                                                  0xb1, 0x76, 0xfb, 0x83, 0x1c, 0xf7, 0x26, 0x7e};
  static constexpr unsigned char kFooterMagic[16] = {0xf8, 0x5a, 0x8c, 0x6a, 0xde, 0xf5,
                                                     0xd9, 0x7e, 0xec, 0xe9, 0x0c, 0xe3,
                                                     0x75, 0x8f, 0x29, 0x0b};
  out.append(reinterpret_cast<const char*>(kFooterId), sizeof(kFooterId));
  out.append(4, '\0');
  const std::size_t pad = 16 - out.size() % 16;  // 1..16: a full 16 when already aligned
  out.append(pad, '\0');
  put(out, version);
  out.append(120, '\0');
  out.append(reinterpret_cast<const char*>(kFooterMagic), sizeof(kFooterMagic));
  return out;
}

}  // namespace locard::detail
