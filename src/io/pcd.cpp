// PCD reader and writer. The file is read into memory once. A binary body is an array of
// points (AoS, offsets summed from SIZE*COUNT); a binary_compressed body is
//   uint32 compressed size, uint32 uncompressed size, LZF data
// whose uncompressed bytes hold each field for all points in turn (SoA), as PCL writes it.
// Both are decoded column by column with the same loop: only base and stride differ.

#include "io/text_lines.hpp"
#include "io/lzf.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/pcd.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;

enum class PcdData { Ascii, Binary, BinaryCompressed };

struct PcdField {
  std::string name;
  char type = 'F';          // F float, I signed, U unsigned
  std::size_t size = 4;     // bytes per value
  std::size_t count = 1;    // values per point
  std::size_t offset = 0;   // byte offset inside a point (binary)
  std::size_t bytes() const { return size * count; }
};

struct PcdHeader {
  std::vector<PcdField> fields;
  std::size_t width = 0;
  std::size_t height = 1;
  std::size_t points = 0;
  PcdData data = PcdData::Binary;
  std::size_t point_size = 0;
  std::size_t body_offset = 0;
  long body_line = 0;
};

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

std::optional<std::size_t> to_size(std::string_view s) {
  std::size_t v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc{} || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

bool valid_size(char type, std::size_t size) {
  if (type == 'F') return size == 4 || size == 8;
  return (type == 'I' || type == 'U') && (size == 1 || size == 2 || size == 4 || size == 8);
}

// Multiplies two counts, failing instead of wrapping around.
std::optional<std::size_t> checked_mul(std::size_t a, std::size_t b) {
  if (a != 0 && b > std::numeric_limits<std::size_t>::max() / a) return std::nullopt;
  return a * b;
}

PcdHeader parse_header(const fs::path& path, std::string_view data) {
  PcdHeader h;
  std::vector<std::string_view> names, sizes, types, counts;
  long size_line = 0, type_line = 0, count_line = 0;
  std::optional<std::size_t> width, height, points;
  std::size_t pos = 0;
  long line_no = 0;
  bool have_data = false;
  while (!have_data) {
    if (pos >= data.size()) throw_input_error(path, "PCD header has no DATA line");
    std::size_t end = data.find('\n', pos);
    if (end == std::string_view::npos) end = data.size();
    std::string_view line = data.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = std::min(end + 1, data.size());
    ++line_no;
    const auto words = split_words(line);
    if (words.empty() || words[0].starts_with('#')) continue;
    const std::string_view key = words[0];
    const std::vector<std::string_view> values(words.begin() + 1, words.end());
    auto single_count = [&]() -> std::size_t {
      if (values.size() != 1 || !to_size(values[0]))
        throw_input_error(path, std::string(key) + " needs one non-negative integer", line_no);
      return *to_size(values[0]);
    };
    if (key == "VERSION") {
      if (values.size() != 1 || (values[0] != "0.7" && values[0] != ".7" && values[0] != "0.6" &&
                                 values[0] != ".6" && values[0] != "0.5" && values[0] != ".5"))
        throw_input_error(path, "unsupported PCD VERSION (expected 0.7, 0.6 or 0.5)", line_no);
    } else if (key == "FIELDS" || key == "COLUMNS") {
      names = values;
    } else if (key == "SIZE") {
      sizes = values;
      size_line = line_no;
    } else if (key == "TYPE") {
      types = values;
      type_line = line_no;
    } else if (key == "COUNT") {
      counts = values;
      count_line = line_no;
    } else if (key == "WIDTH") {
      width = single_count();
    } else if (key == "HEIGHT") {
      height = single_count();
    } else if (key == "POINTS") {
      points = single_count();
    } else if (key == "VIEWPOINT") {
      if (values.size() != 7) throw_input_error(path, "VIEWPOINT needs 7 numbers", line_no);
    } else if (key == "DATA") {
      if (values.size() != 1) throw_input_error(path, "expected 'DATA ascii|binary|binary_compressed'", line_no);
      if (values[0] == "ascii") h.data = PcdData::Ascii;
      else if (values[0] == "binary") h.data = PcdData::Binary;
      else if (values[0] == "binary_compressed") h.data = PcdData::BinaryCompressed;
      else throw_input_error(path, "unknown DATA encoding '" + std::string(values[0]) + "'", line_no);
      have_data = true;
    } else {
      throw_input_error(path, "unknown PCD header keyword '" + std::string(key) + "'", line_no);
    }
  }
  h.body_offset = pos;
  h.body_line = line_no + 1;

  if (names.empty()) throw_input_error(path, "PCD header has no FIELDS line");
  if (sizes.size() != names.size())
    throw_input_error(path, "SIZE lists " + std::to_string(sizes.size()) + " values for " +
                                std::to_string(names.size()) + " FIELDS", size_line);
  if (types.size() != names.size())
    throw_input_error(path, "TYPE lists " + std::to_string(types.size()) + " values for " +
                                std::to_string(names.size()) + " FIELDS", type_line);
  if (!counts.empty() && counts.size() != names.size())
    throw_input_error(path, "COUNT lists " + std::to_string(counts.size()) + " values for " +
                                std::to_string(names.size()) + " FIELDS", count_line);
  for (std::size_t i = 0; i < names.size(); ++i) {
    PcdField f;
    f.name = std::string(names[i]);
    const auto size = to_size(sizes[i]);
    if (types[i].size() != 1 || !size || !valid_size(types[i][0], *size))
      throw_input_error(path, "field '" + f.name + "' has TYPE " + std::string(types[i]) +
                                  " SIZE " + std::string(sizes[i]) +
                                  " (expected F 4|8, I or U 1|2|4|8)", type_line);
    f.type = types[i][0];
    f.size = *size;
    if (!counts.empty()) {
      const auto count = to_size(counts[i]);
      if (!count || *count == 0 || *count > (1u << 20))
        throw_input_error(path, "field '" + f.name + "' has bad COUNT " + std::string(counts[i]), count_line);
      f.count = *count;
    }
    f.offset = h.point_size;
    h.point_size += f.bytes();
    h.fields.push_back(std::move(f));
  }
  // PCL's rule: POINTS = WIDTH * HEIGHT. Older headers may omit POINTS or WIDTH.
  h.height = height.value_or(1);
  if (!width && !points) throw_input_error(path, "PCD header has neither WIDTH nor POINTS");
  h.width = width.value_or(h.height == 0 ? 0 : *points / std::max<std::size_t>(h.height, 1));
  const auto product = checked_mul(h.width, h.height);
  h.points = points.value_or(product.value_or(0));
  if (!product || *product != h.points)
    throw_input_error(path, "WIDTH " + std::to_string(h.width) + " x HEIGHT " +
                                std::to_string(h.height) + " does not match POINTS " +
                                std::to_string(h.points));
  return h;
}

// ---- mapping fields to point attributes -------------------------------------------------------

enum class Slot : std::uint8_t { Skip, Position, Normal, Rgb, Scalar };

struct Target {
  Slot slot = Slot::Skip;
  int index = 0;  // component or scalar field index
};

struct Layout {
  std::vector<Target> targets;  // one per field
  bool normals = false;
  bool colors = false;
  std::vector<std::string> scalar_names;
};

int find_field(const PcdHeader& h, std::string_view name) {
  for (std::size_t i = 0; i < h.fields.size(); ++i)
    if (h.fields[i].name == name) return static_cast<int>(i);
  return -1;
}

Layout make_layout(const fs::path& path, const PcdHeader& h) {
  Layout layout;
  layout.targets.resize(h.fields.size());
  const int xyz[3] = {find_field(h, "x"), find_field(h, "y"), find_field(h, "z")};
  if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) throw_input_error(path, "PCD has no x, y and z fields");
  for (int c = 0; c < 3; ++c) layout.targets[xyz[c]] = {Slot::Position, c};
  const int n[3] = {find_field(h, "normal_x"), find_field(h, "normal_y"), find_field(h, "normal_z")};
  if (n[0] >= 0 && n[1] >= 0 && n[2] >= 0) {
    layout.normals = true;
    for (int c = 0; c < 3; ++c) layout.targets[n[c]] = {Slot::Normal, c};
  }
  int rgb = find_field(h, "rgb");
  if (rgb < 0) rgb = find_field(h, "rgba");
  if (rgb >= 0) {
    if (h.fields[rgb].size != 4)
      throw_input_error(path, "field '" + h.fields[rgb].name + "' must have SIZE 4 (packed colour)");
    layout.colors = true;
    layout.targets[rgb] = {Slot::Rgb, 0};
  }
  for (std::size_t i = 0; i < h.fields.size(); ++i) {
    const PcdField& f = h.fields[i];
    // Padding ("_"), the other colour field and multi-value descriptors (FPFH, ...) are not
    // per-point scalars; known fields with COUNT > 1 use their first value.
    if (layout.targets[i].slot != Slot::Skip || f.name == "_" || f.name == "rgb" ||
        f.name == "rgba" || f.count != 1)
      continue;
    layout.targets[i] = {Slot::Scalar, static_cast<int>(layout.scalar_names.size())};
    layout.scalar_names.push_back(f.name);
  }
  return layout;
}

Rgb8 unpack_rgb(std::uint32_t packed) {
  return {static_cast<std::uint8_t>((packed >> 16) & 0xff),
          static_cast<std::uint8_t>((packed >> 8) & 0xff), static_cast<std::uint8_t>(packed & 0xff)};
}

template <typename T>
T load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

// Calls f(T{}) with the C++ type of a PCD field type and size.
template <typename F>
void visit_type(const PcdField& field, F&& f) {
  switch (field.type) {
    case 'F':
      if (field.size == 4) return f(float{});
      return f(double{});
    case 'I':
      if (field.size == 1) return f(std::int8_t{});
      if (field.size == 2) return f(std::int16_t{});
      if (field.size == 4) return f(std::int32_t{});
      return f(std::int64_t{});
    default:
      if (field.size == 1) return f(std::uint8_t{});
      if (field.size == 2) return f(std::uint16_t{});
      if (field.size == 4) return f(std::uint32_t{});
      return f(std::uint64_t{});
  }
}

class CloudStore {
 public:
  CloudStore(PointCloud& cloud, const Layout& layout, std::size_t n) : cloud_(cloud), layout_(layout) {
    // resize leaves Eigen vectors uninitialised: every x/y/z (normal_*) column overwrites them.
    cloud.positions.resize(n);
    if (layout.normals) cloud.normals.resize(n);
    if (layout.colors) cloud.colors.assign(n, Rgb8{});
    for (const auto& name : layout.scalar_names) cloud.scalars.push_back({name, std::vector<float>(n)});
  }

  // Field `f` of point i sits at base + i * stride (host byte order, as PCL writes); decodes
  // points [begin, end).
  void set_column(std::size_t f, const PcdField& field, const char* base, std::size_t stride,
                  std::size_t begin, std::size_t end) {
    const Target t = layout_.targets[f];
    if (t.slot == Slot::Skip) return;
    if (t.slot == Slot::Rgb) {
      for (std::size_t i = begin; i < end; ++i)
        cloud_.colors[i] = unpack_rgb(load<std::uint32_t>(base + i * stride));
      return;
    }
    visit_type(field, [&](auto tag) {
      using T = decltype(tag);
      if (t.slot == Slot::Position) {
        for (std::size_t i = begin; i < end; ++i)
          cloud_.positions[i][t.index] = static_cast<float>(load<T>(base + i * stride));
      } else if (t.slot == Slot::Normal) {
        for (std::size_t i = begin; i < end; ++i)
          cloud_.normals[i][t.index] = static_cast<float>(load<T>(base + i * stride));
      } else {
        float* out = cloud_.scalars[t.index].values.data();
        for (std::size_t i = begin; i < end; ++i) out[i] = static_cast<float>(load<T>(base + i * stride));
      }
    });
  }

  void set_value(std::size_t f, std::size_t i, double v) {
    const Target t = layout_.targets[f];
    switch (t.slot) {
      case Slot::Position: cloud_.positions[i][t.index] = static_cast<float>(v); break;
      case Slot::Normal: cloud_.normals[i][t.index] = static_cast<float>(v); break;
      case Slot::Scalar: cloud_.scalars[t.index].values[i] = static_cast<float>(v); break;
      default: break;
    }
  }
  void set_rgb(std::size_t i, std::uint32_t packed) { cloud_.colors[i] = unpack_rgb(packed); }
  Slot slot(std::size_t f) const { return layout_.targets[f].slot; }

 private:
  PointCloud& cloud_;
  const Layout& layout_;
};

// ---- bodies ---------------------------------------------------------------------------------

// Bytes the decoded cloud takes per point: positions, normals and colours as the cloud holds
// them, every other field a float (a 1-byte field takes 4).
std::size_t decoded_bytes_per_point(const Layout& layout) {
  return 3 * sizeof(float) + (layout.normals ? 3 * sizeof(float) : 0) +
         (layout.colors ? sizeof(Rgb8) : 0) + layout.scalar_names.size() * sizeof(float);
}

// A compressed body may expand 88-fold (a 3-byte LZF reference makes 264 bytes), and 1-byte
// fields four-fold again as floats: a 1 MB file could ask for 450 MB. So what decoding it
// allocates (the unpacked body and the cloud) must fit a budget that grows with the bytes the
// file really holds: 64 MiB, plus 32 times the compressed bytes (well above what LZF achieves
// on real clouds; a cloud that is nearly all NaN or zeros compresses more and is refused).
void check_decoded_budget(const fs::path& path, const PcdHeader& h, const Layout& layout,
                          std::uint64_t unpacked, std::uint64_t compressed) {
  constexpr std::uint64_t kFloor = std::uint64_t{64} << 20;
  constexpr std::uint64_t kRatio = 32;
  const auto cloud = checked_mul(h.points, decoded_bytes_per_point(layout));
  const std::uint64_t budget = kFloor + kRatio * compressed;
  if (!cloud || *cloud + unpacked > budget)
    throw_input_error(path, "binary_compressed body of " + std::to_string(compressed) +
                                " bytes would decode to " + std::to_string(unpacked) +
                                " bytes and a cloud of " +
                                (cloud ? std::to_string(*cloud) : std::string("too many")) +
                                " bytes, beyond the decoding budget of " + std::to_string(budget) +
                                " bytes (64 MiB + 32 x the compressed size)");
}

// Checks the body can hold what the header declares before anything is allocated for it.
void check_body_size(const fs::path& path, const PcdHeader& h, const Layout& layout,
                     std::string_view body) {
  const auto need = checked_mul(h.points, h.point_size);
  if (!need) throw_input_error(path, "POINTS " + std::to_string(h.points) + " is absurdly large");
  if (h.data == PcdData::Ascii) {
    if (h.points > body.size() / 2 + 1)  // every point takes at least "0\n"
      throw_input_error(path, "header declares " + std::to_string(h.points) +
                                  " points but the body has only " + std::to_string(body.size()) +
                                  " bytes (truncated file?)");
    return;
  }
  if (h.data == PcdData::Binary) {
    if (body.size() < *need)
      throw_input_error(path, "binary body is truncated: " + std::to_string(h.points) +
                                  " points of " + std::to_string(h.point_size) + " bytes need " +
                                  std::to_string(*need) + " bytes, the file has " +
                                  std::to_string(body.size()));
    if (body.size() > *need)
      throw_input_error(path, std::to_string(body.size() - *need) +
                                  " bytes follow the last point: POINTS does not match the body");
    return;
  }
  if (body.size() < 8) throw_input_error(path, "binary_compressed body is truncated (no size words)");
  const auto compressed = load<std::uint32_t>(body.data());
  if (compressed > body.size() - 8)
    throw_input_error(path, "binary_compressed body is truncated: " + std::to_string(compressed) +
                                " compressed bytes declared, " + std::to_string(body.size() - 8) +
                                " present");
  if (compressed < body.size() - 8)
    throw_input_error(path, std::to_string(body.size() - 8 - compressed) +
                                " bytes follow the compressed data");
  // One LZF instruction of at most 3 bytes expands to at most 264 bytes.
  if (*need / 88 > compressed + 1)
    throw_input_error(path, "binary_compressed body of " + std::to_string(compressed) +
                                " bytes cannot hold " + std::to_string(h.points) + " points");
  check_decoded_budget(path, h, layout, *need, compressed);
}

void read_binary(const PcdHeader& h, std::string_view body, CloudStore& store) {
  // Column by column within blocks that stay in cache: one pass over the file's bytes.
  constexpr std::size_t kBlock = 4096;
  for (std::size_t begin = 0; begin < h.points; begin += kBlock) {
    const std::size_t end = std::min(h.points, begin + kBlock);
    for (std::size_t f = 0; f < h.fields.size(); ++f)
      store.set_column(f, h.fields[f], body.data() + h.fields[f].offset, h.point_size, begin, end);
  }
}

void read_compressed(const fs::path& path, const PcdHeader& h, std::string_view body, CloudStore& store) {
  const auto compressed = load<std::uint32_t>(body.data());
  const auto uncompressed = load<std::uint32_t>(body.data() + 4);
  // PCL leaves padding fields ("_") out of the field-by-field layout.
  std::size_t packed_size = 0;
  for (const auto& f : h.fields)
    if (f.name != "_") packed_size += f.bytes();
  const std::size_t expected = h.points * packed_size;
  if (uncompressed != expected && uncompressed != h.points * h.point_size)
    throw_input_error(path, "binary_compressed body unpacks to " + std::to_string(uncompressed) +
                                " bytes but " + std::to_string(h.points) + " points of " +
                                std::to_string(packed_size) + " bytes need " + std::to_string(expected));
  const auto raw = lzf::decompress(reinterpret_cast<const std::uint8_t*>(body.data() + 8), compressed,
                                   uncompressed);
  if (!raw) throw_input_error(path, "binary_compressed body is corrupt (LZF data does not decode)");
  const char* base = reinterpret_cast<const char*>(raw->data());
  for (std::size_t f = 0; f < h.fields.size(); ++f) {
    if (h.fields[f].name == "_") continue;
    store.set_column(f, h.fields[f], base, h.fields[f].bytes(), 0, h.points);
    base += h.points * h.fields[f].bytes();
  }
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// An ascii rgb is PCL's unsigned integer, or (Open3D, older PCL) the float whose bits are the
// packed colour.
std::optional<std::uint32_t> parse_packed(std::string_view token) {
  std::uint32_t u = 0;
  auto r = std::from_chars(token.data(), token.data() + token.size(), u);
  if (r.ec == std::errc{} && r.ptr == token.data() + token.size()) return u;
  float f = 0.0f;
  r = std::from_chars(token.data(), token.data() + token.size(), f);
  if (r.ec == std::errc{} && r.ptr == token.data() + token.size()) return std::bit_cast<std::uint32_t>(f);
  return std::nullopt;
}

std::optional<double> parse_number(std::string_view token, const PcdField& field) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const char* last = token.data() + token.size();
  if (field.type == 'F' && field.size == 4) {
    float f = 0.0f;  // parse as float: double-then-float rounding could differ in the last bit
    const auto r = std::from_chars(token.data(), last, f);
    if (r.ec != std::errc{} || r.ptr != last) return std::nullopt;
    return f;
  }
  double d = 0.0;
  const auto r = std::from_chars(token.data(), last, d);
  if (r.ec != std::errc{} || r.ptr != last) return std::nullopt;
  return d;
}

void read_ascii(const fs::path& path, const PcdHeader& h, std::string_view body, CloudStore& store) {
  std::size_t values_per_point = 0;
  for (const auto& f : h.fields) values_per_point += f.count;
  std::size_t pos = 0;
  long line_no = h.body_line - 1;
  std::size_t point = 0;
  while (pos < body.size()) {
    std::size_t end = body.find('\n', pos);
    if (end == std::string_view::npos) end = body.size();
    const std::string_view line = body.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    std::size_t col = 0;
    auto next_token = [&]() -> std::string_view {
      while (col < line.size() && is_space(line[col])) ++col;
      const std::size_t start = col;
      while (col < line.size() && !is_space(line[col])) ++col;
      return line.substr(start, col - start);
    };
    std::string_view token = next_token();
    if (token.empty()) continue;  // blank line
    if (point == h.points)
      throw_input_error(path, "more than the " + std::to_string(h.points) + " points the header declares",
                        line_no);
    std::size_t value = 0;
    for (std::size_t f = 0; f < h.fields.size(); ++f) {
      const PcdField& field = h.fields[f];
      for (std::size_t c = 0; c < field.count; ++c, ++value, token = next_token()) {
        if (token.empty())
          throw_input_error(path, "point " + std::to_string(point) + " has " + std::to_string(value) +
                                      " values, expected " + std::to_string(values_per_point), line_no);
        if (c > 0 || store.slot(f) == Slot::Skip) continue;
        if (store.slot(f) == Slot::Rgb) {
          const auto packed = parse_packed(token);
          if (!packed) throw_input_error(path, "'" + std::string(token) + "' is not a packed colour", line_no);
          store.set_rgb(point, *packed);
          continue;
        }
        const auto v = parse_number(token, field);
        if (!v) throw_input_error(path, "'" + std::string(token) + "' is not a number (field '" +
                                            field.name + "')", line_no);
        store.set_value(f, point, *v);
      }
    }
    if (!token.empty())
      throw_input_error(path, "point " + std::to_string(point) + " has more than " +
                                  std::to_string(values_per_point) + " values", line_no);
    ++point;
  }
  if (point != h.points)
    throw_input_error(path, "file ends after " + std::to_string(point) + " of " +
                                std::to_string(h.points) + " points");
}

// ---- writing --------------------------------------------------------------------------------

struct OutField {
  std::string name;
  const float* values;  // strided source
  std::size_t stride;   // in floats
  bool packed_color = false;
};

std::string field_name(const std::string& name, std::size_t index) {
  std::string s = name.empty() ? "scalar_" + std::to_string(index) : name;
  for (char& c : s)
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') c = '_';
  return s;
}

// Colour packed as PCL's rgb: 0x00RRGGBB stored in a float's bits (alpha 0, as Open3D writes
// it, so the float is never a NaN).
std::uint32_t pack_rgb(const Rgb8& c) {
  return (std::uint32_t{c.r} << 16) | (std::uint32_t{c.g} << 8) | std::uint32_t{c.b};
}

// Every field is 4 bytes. PCL writes rgb as TYPE F in binary files and as TYPE U (an
// integer) in ascii files, where a float text could not carry every bit pattern; so do we.
std::string make_header(const std::vector<OutField>& fields, std::size_t n, bool ascii,
                        const char* data) {
  std::string h = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS";
  for (const auto& f : fields) h += " " + f.name;
  h += "\nSIZE";
  for (std::size_t i = 0; i < fields.size(); ++i) h += " 4";
  h += "\nTYPE";
  for (const auto& f : fields) h += f.packed_color && ascii ? " U" : " F";
  h += "\nCOUNT";
  for (std::size_t i = 0; i < fields.size(); ++i) h += " 1";
  h += "\nWIDTH " + std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
       std::to_string(n) + "\nDATA " + data + "\n";
  return h;
}

}  // namespace

PointCloud read_pcd(const fs::path& path) {
  const std::string data = io_detail::read_whole_file(path);
  const PcdHeader header = parse_header(path, data);
  const Layout layout = make_layout(path, header);
  const std::string_view body = std::string_view(data).substr(header.body_offset);
  check_body_size(path, header, layout, body);
  PointCloud cloud;
  CloudStore store(cloud, layout, header.points);
  switch (header.data) {
    case PcdData::Ascii: read_ascii(path, header, body, store); break;
    case PcdData::Binary: read_binary(header, body, store); break;
    case PcdData::BinaryCompressed: read_compressed(path, header, body, store); break;
  }
  return cloud;
}

void write_pcd(const fs::path& path, const PointCloud& cloud, PcdEncoding encoding) {
  try {
    cloud.check_consistent();
  } catch (const Error& e) {
    throw Error(path.string() + ": cannot write: " + e.what());
  }
  const std::size_t n = cloud.size();
  // Field order of PCL's PointXYZRGBNormal: x y z rgb normal_x normal_y normal_z, then extras.
  std::vector<float> rgb_bits;
  std::vector<OutField> fields;
  for (int c = 0; c < 3; ++c)
    fields.push_back({std::string(1, "xyz"[c]), n ? cloud.positions.data()->data() + c : nullptr, 3});
  if (cloud.has_colors()) {
    rgb_bits.resize(n);
    for (std::size_t i = 0; i < n; ++i) rgb_bits[i] = std::bit_cast<float>(pack_rgb(cloud.colors[i]));
    fields.push_back({"rgb", rgb_bits.data(), 1, true});
  }
  if (cloud.has_normals())
    for (int c = 0; c < 3; ++c)
      fields.push_back({std::string("normal_") + "xyz"[c], cloud.normals.data()->data() + c, 3});
  for (std::size_t s = 0; s < cloud.scalars.size(); ++s)
    fields.push_back({field_name(cloud.scalars[s].name, s), cloud.scalars[s].values.data(), 1});
  const std::size_t k = fields.size();
  if (encoding == PcdEncoding::BinaryCompressed && n * k * 4 > std::numeric_limits<std::uint32_t>::max())
    throw Error(path.string() + ": cannot write: " + std::to_string(n) +
                " points exceed the 4 GiB a binary_compressed PCD can hold");

  const char* data_name = encoding == PcdEncoding::Ascii    ? "ascii"
                          : encoding == PcdEncoding::Binary ? "binary"
                                                            : "binary_compressed";
  AtomicFile file(path, true);
  std::ofstream& out = file.stream();
  const std::string header = make_header(fields, n, encoding == PcdEncoding::Ascii, data_name);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  auto write = [&out](const void* p, std::size_t bytes) {
    out.write(static_cast<const char*>(p), static_cast<std::streamsize>(bytes));
  };

  if (encoding == PcdEncoding::BinaryCompressed) {
    std::vector<std::uint8_t> soa(n * k * 4);
    for (std::size_t f = 0; f < k; ++f) {
      float* dst = reinterpret_cast<float*>(soa.data()) + f * n;
      for (std::size_t i = 0; i < n; ++i) dst[i] = fields[f].values[i * fields[f].stride];
    }
    const auto packed = lzf::compress(soa.data(), soa.size());
    const auto sizes = std::array<std::uint32_t, 2>{static_cast<std::uint32_t>(packed.size()),
                                                    static_cast<std::uint32_t>(soa.size())};
    write(sizes.data(), sizeof(sizes));
    write(packed.data(), packed.size());
    file.commit();
    return;
  }
  // Binary and ascii are encoded in chunks of points: bulk writes, bounded extra memory.
  constexpr std::size_t kChunk = 1 << 16;
  std::string buf;
  for (std::size_t start = 0; start < n; start += kChunk) {
    const std::size_t end = std::min(n, start + kChunk);
    buf.clear();
    for (std::size_t i = start; i < end; ++i) {
      for (std::size_t f = 0; f < k; ++f) {
        const float v = fields[f].values[i * fields[f].stride];
        if (encoding == PcdEncoding::Binary) {
          char bytes[4];
          std::memcpy(bytes, &v, 4);
          buf.append(bytes, 4);
          continue;
        }
        if (f > 0) buf.push_back(' ');
        char tmp[32];
        // Shortest text that reads back to the same float (at most max_digits10 digits).
        const auto r = fields[f].packed_color
                           ? std::to_chars(tmp, tmp + sizeof(tmp), std::bit_cast<std::uint32_t>(v))
                           : std::to_chars(tmp, tmp + sizeof(tmp), v);
        buf.append(tmp, r.ptr);
      }
      if (encoding == PcdEncoding::Ascii) buf.push_back('\n');
    }
    write(buf.data(), buf.size());
  }
  file.commit();
}

}  // namespace locard
