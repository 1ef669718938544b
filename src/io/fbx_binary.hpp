#pragma once
// A small encoder for binary FBX 7.4 (the version every importer we checked reads: Blender's
// from 7.1, assimp's 7.1 to 7.4 and later). The layout, as Blender's and assimp's readers
// parse it:
//
//   file    "Kaydara FBX Binary  \0" 0x1A 0x00, uint32 version, nodes, a null node (13 zero
//           bytes), footer
//   node    uint32 end offset (absolute, in the file), uint32 property count, uint32 property
//           bytes, uint8 name length, name, properties, children, then 13 zero bytes when the
//           node has children (or nothing at all)
//   property one type byte then: 'C' bool byte, 'I' int32, 'L' int64, 'D' double,
//           'S'/'R' uint32 length + bytes, 'i'/'d' arrays: uint32 count, uint32 encoding
//           (0 raw, 1 zlib), uint32 byte length, data
// Little-endian throughout. Arrays over a few hundred bytes are zlib-compressed (libdeflate).
// Offsets are 32-bit in 7.4, so a file stops at 4 GiB (an Error beyond).

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace locard::detail {

class FbxNode {
 public:
  explicit FbxNode(std::string name);
  FbxNode(FbxNode&&) noexcept = default;
  FbxNode& operator=(FbxNode&&) noexcept = default;

  // Properties, in order; each returns *this for chaining.
  FbxNode& boolean(bool value);
  FbxNode& i32(std::int32_t value);
  FbxNode& i64(std::int64_t value);
  FbxNode& f64(double value);
  FbxNode& string(std::string_view value);  // may hold "\0\1" (FBX's name/class separator)
  FbxNode& raw(std::string_view bytes);
  FbxNode& i32_array(const std::vector<std::int32_t>& values);
  FbxNode& f64_array(const std::vector<double>& values);

  // A new child, appended; the reference stays valid while this node lives.
  FbxNode& child(std::string name);
  FbxNode& add(FbxNode node);  // appends a node built elsewhere

  // Appends the node at out.size(), which must be its offset in the file.
  void encode(std::string& out) const;

 private:
  std::string name_;
  std::uint32_t property_count_ = 0;
  std::string properties_;  // encoded
  std::vector<std::unique_ptr<FbxNode>> children_;
};

// A Properties70 "P" entry: name, type, label, flags, then the values (added by the caller).
FbxNode& fbx_property(FbxNode& properties70, std::string_view name, std::string_view type,
                      std::string_view label, std::string_view flags = "");

// The whole file: header, the top-level nodes, the closing null node and the footer.
std::string encode_fbx_file(const std::vector<FbxNode>& top_level, std::uint32_t version = 7400);

}  // namespace locard::detail
