// E57 XML section helpers: typed element values (Float, Integer, ScaledInteger, String), the
// CompressedVector prototype, and the text forms the writer uses. E57 gives every element a
// `type` attribute; an empty numeric element means 0.

#include "io/e57_detail.hpp"

#include <locard/core/error.hpp>

#include <pugixml.hpp>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

namespace locard::e57_detail {
namespace {

std::string_view trimmed(const char* text) {
  std::string_view s(text);
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);  // from_chars takes no '+'
  return s;
}

template <typename T>
T parse_text(const std::filesystem::path& path, const pugi::xml_node& node, const char* text,
             const char* what) {
  const std::string_view s = trimmed(text);
  T v{};
  if (s.empty()) return v;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size())
    fail(path, "XML " + element_path(node),
         std::string(what) + " '" + std::string(s) + "' is not a valid number");
  return v;
}

std::int64_t int_attribute(const std::filesystem::path& path, const pugi::xml_node& node,
                           const char* name, std::int64_t fallback) {
  const pugi::xml_attribute a = node.attribute(name);
  if (!a) return fallback;
  return parse_text<std::int64_t>(path, node, a.value(), name);
}

double double_attribute(const std::filesystem::path& path, const pugi::xml_node& node,
                        const char* name, double fallback) {
  const pugi::xml_attribute a = node.attribute(name);
  if (!a) return fallback;
  return parse_text<double>(path, node, a.value(), name);
}

FieldSpec parse_field(const std::filesystem::path& path, const pugi::xml_node& node) {
  FieldSpec f;
  f.name = node.name();
  const std::string type = node.attribute("type").value();
  if (type == "Float") {
    const std::string precision = node.attribute("precision").value();
    if (precision != "" && precision != "single" && precision != "double")
      fail(path, "XML " + element_path(node), "unknown Float precision '" + precision + "'");
    f.type = precision == "single" ? FieldType::Float32 : FieldType::Float64;
    f.has_float_range = node.attribute("minimum") && node.attribute("maximum");
    f.float_minimum = double_attribute(path, node, "minimum", 0.0);
    f.float_maximum = double_attribute(path, node, "maximum", 0.0);
    return f;
  }
  if (type != "Integer" && type != "ScaledInteger")
    fail(path, "XML " + element_path(node),
         "prototype field of type '" + type + "' (only Float, Integer and ScaledInteger are read)");
  f.type = type == "Integer" ? FieldType::Integer : FieldType::ScaledInteger;
  f.minimum = int_attribute(path, node, "minimum", std::numeric_limits<std::int64_t>::min());
  f.maximum = int_attribute(path, node, "maximum", std::numeric_limits<std::int64_t>::max());
  f.scale = double_attribute(path, node, "scale", 1.0);
  f.offset = double_attribute(path, node, "offset", 0.0);
  if (f.minimum > f.maximum)
    fail(path, "XML " + element_path(node), "minimum " + std::to_string(f.minimum) +
                                                " is above maximum " + std::to_string(f.maximum));
  if (!std::isfinite(f.scale) || f.scale == 0.0 || !std::isfinite(f.offset))
    fail(path, "XML " + element_path(node), "scale must be finite and non-zero, offset finite");
  return f;
}

}  // namespace

unsigned FieldSpec::bits() const {
  switch (type) {
    case FieldType::Float32: return 32;
    case FieldType::Float64: return 64;
    case FieldType::Integer:
    case FieldType::ScaledInteger: break;
  }
  // Enough bits for maximum - minimum (0 when they are equal: the value is a constant).
  const std::uint64_t range = static_cast<std::uint64_t>(maximum) - static_cast<std::uint64_t>(minimum);
  return static_cast<unsigned>(std::bit_width(range));
}

std::string element_path(const pugi::xml_node& node) {
  std::string out;  // built from the leaf up: "e57Root/data3D[0]/points"
  for (pugi::xml_node n = node; n && n.type() == pugi::node_element; n = n.parent()) {
    std::string part = n.name();
    if (part == "vectorChild") {  // a vector's entry: its index
      int index = 0;
      for (pugi::xml_node s = n.previous_sibling("vectorChild"); s;
           s = s.previous_sibling("vectorChild"))
        ++index;
      part = "[" + std::to_string(index) + "]";
      out = part + (out.empty() ? "" : "/" + out);
      continue;
    }
    out = part + (out.empty() || out.front() == '[' ? "" : "/") + out;
  }
  return "<" + out + ">";
}

double number_value(const std::filesystem::path& path, const pugi::xml_node& node) {
  const std::string type = node.attribute("type").value();
  if (type == "Float") return parse_text<double>(path, node, node.text().get(), "value");
  if (type == "Integer")
    return static_cast<double>(parse_text<std::int64_t>(path, node, node.text().get(), "value"));
  if (type == "ScaledInteger") {
    const auto raw = parse_text<std::int64_t>(path, node, node.text().get(), "value");
    return static_cast<double>(raw) * double_attribute(path, node, "scale", 1.0) +
           double_attribute(path, node, "offset", 0.0);
  }
  fail(path, "XML " + element_path(node), "expected a Float, Integer or ScaledInteger element, "
                                          "found type '" + type + "'");
}

std::string string_value(const pugi::xml_node& node) { return node.text().get(); }

std::uint64_t unsigned_attribute(const std::filesystem::path& path, const pugi::xml_node& node,
                                 const char* name) {
  const pugi::xml_attribute a = node.attribute(name);
  if (!a) fail(path, "XML " + element_path(node), std::string("no '") + name + "' attribute");
  return parse_text<std::uint64_t>(path, node, a.value(), name);
}

std::vector<FieldSpec> parse_prototype(const std::filesystem::path& path,
                                       const pugi::xml_node& prototype) {
  std::vector<FieldSpec> fields;
  for (pugi::xml_node child : prototype.children())
    if (child.type() == pugi::node_element) fields.push_back(parse_field(path, child));
  return fields;
}

std::string format_double(double v) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, ec == std::errc() ? end : buf);
}

std::string random_guid() {
  std::random_device device;  // a guid must differ between files, so not seeded
  std::uniform_int_distribution<unsigned> byte(0, 255);
  unsigned char b[16];
  for (auto& x : b) x = static_cast<unsigned char>(byte(device));
  b[6] = static_cast<unsigned char>((b[6] & 0x0F) | 0x40);  // version 4 (random)
  b[8] = static_cast<unsigned char>((b[8] & 0x3F) | 0x80);  // RFC 4122 variant
  char out[40];
  std::snprintf(out, sizeof out,
                "{%02x%02x%02x%02x-%02x%02x-%02x%02x-%02x%02x-%02x%02x%02x%02x%02x%02x}", b[0],
                b[1], b[2], b[3], b[4], b[5], b[6], b[7], b[8], b[9], b[10], b[11], b[12], b[13],
                b[14], b[15]);
  return out;
}

}  // namespace locard::e57_detail
