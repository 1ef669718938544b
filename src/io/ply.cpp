// PLY reader and writer. The whole file is read into memory once; the header is parsed line
// by line, then binary bodies are decoded column by column straight from the buffer (no
// per-value stream calls) and ascii bodies are tokenised with std::from_chars.

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/ply.hpp>

#include "io/text_lines.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };
enum class PlyType : std::uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;  // item type for lists
  bool is_list = false;
  PlyType count_type = PlyType::UInt8;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;

  bool has_lists() const {
    return std::any_of(properties.begin(), properties.end(),
                       [](const PlyProperty& p) { return p.is_list; });
  }
};

struct PlyHeader {
  PlyFormat format = PlyFormat::Ascii;
  std::vector<PlyElement> elements;
  std::size_t body_offset = 0;  // first byte after the end_header line
  long body_line = 0;           // line number of the first body line (ascii)
};

std::optional<PlyType> parse_type(std::string_view s) {
  if (s == "char" || s == "int8") return PlyType::Int8;
  if (s == "uchar" || s == "uint8") return PlyType::UInt8;
  if (s == "short" || s == "int16") return PlyType::Int16;
  if (s == "ushort" || s == "uint16") return PlyType::UInt16;
  if (s == "int" || s == "int32") return PlyType::Int32;
  if (s == "uint" || s == "uint32") return PlyType::UInt32;
  if (s == "float" || s == "float32") return PlyType::Float32;
  if (s == "double" || s == "float64") return PlyType::Float64;
  return std::nullopt;
}

std::size_t type_size(PlyType t) {
  switch (t) {
    case PlyType::Int8: case PlyType::UInt8: return 1;
    case PlyType::Int16: case PlyType::UInt16: return 2;
    case PlyType::Int32: case PlyType::UInt32: case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
  }
  return 0;
}

// Calls f(T{}) with the C++ type that stores a PLY type, so loops are compiled per type.
template <typename F>
decltype(auto) visit_type(PlyType t, F&& f) {
  switch (t) {
    case PlyType::Int8: return f(std::int8_t{});
    case PlyType::UInt8: return f(std::uint8_t{});
    case PlyType::Int16: return f(std::int16_t{});
    case PlyType::UInt16: return f(std::uint16_t{});
    case PlyType::Int32: return f(std::int32_t{});
    case PlyType::UInt32: return f(std::uint32_t{});
    case PlyType::Float32: return f(float{});
    case PlyType::Float64: break;
  }
  return f(double{});
}

template <typename T>
T load(const char* p, bool swap) {
  if constexpr (sizeof(T) == 1) {
    T v;
    std::memcpy(&v, p, 1);
    return v;
  } else {
    using U = std::conditional_t<sizeof(T) == 2, std::uint16_t,
                                 std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>;
    U bits;
    std::memcpy(&bits, p, sizeof(U));
    if (swap) {
      if constexpr (sizeof(U) == 2) bits = __builtin_bswap16(bits);
      if constexpr (sizeof(U) == 4) bits = __builtin_bswap32(bits);
      if constexpr (sizeof(U) == 8) bits = __builtin_bswap64(bits);
    }
    return std::bit_cast<T>(bits);
  }
}

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

PlyHeader parse_header(const fs::path& path, std::string_view data) {
  PlyHeader header;
  std::size_t pos = 0;
  long line_no = 0;
  bool have_format = false;
  auto next_line = [&]() -> std::optional<std::string_view> {
    if (pos >= data.size()) return std::nullopt;
    std::size_t end = data.find('\n', pos);
    if (end == std::string_view::npos) end = data.size();
    std::string_view line = data.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = std::min(end + 1, data.size());
    ++line_no;
    return line;
  };
  const auto first = next_line();
  if (!first || *first != "ply") throw_input_error(path, "not a PLY file (first line is not 'ply')", 1);
  while (true) {
    const auto line = next_line();
    if (!line) throw_input_error(path, "header has no 'end_header' line");
    const auto words = split_words(*line);
    if (words.empty()) continue;
    const std::string_view key = words[0];
    if (key == "comment" || key == "obj_info") continue;
    if (key == "end_header") break;
    if (key == "format") {
      if (words.size() != 3) throw_input_error(path, "expected 'format <encoding> 1.0'", line_no);
      if (words[1] == "ascii") header.format = PlyFormat::Ascii;
      else if (words[1] == "binary_little_endian") header.format = PlyFormat::BinaryLittleEndian;
      else if (words[1] == "binary_big_endian") header.format = PlyFormat::BinaryBigEndian;
      else throw_input_error(path, "unknown PLY encoding '" + std::string(words[1]) + "'", line_no);
      have_format = true;
    } else if (key == "element") {
      std::size_t count = 0;
      if (words.size() != 3 ||
          std::from_chars(words[2].data(), words[2].data() + words[2].size(), count).ec != std::errc{})
        throw_input_error(path, "expected 'element <name> <count>'", line_no);
      header.elements.push_back({std::string(words[1]), count, {}});
    } else if (key == "property") {
      if (header.elements.empty())
        throw_input_error(path, "'property' before any 'element'", line_no);
      PlyProperty prop;
      if (words.size() == 5 && words[1] == "list") {
        const auto count_type = parse_type(words[2]);
        const auto item_type = parse_type(words[3]);
        if (!count_type || !item_type ||
            *count_type == PlyType::Float32 || *count_type == PlyType::Float64)
          throw_input_error(path, "bad list property types", line_no);
        prop = {std::string(words[4]), *item_type, true, *count_type};
      } else if (words.size() == 3) {
        const auto type = parse_type(words[1]);
        if (!type) throw_input_error(path, "unknown property type '" + std::string(words[1]) + "'", line_no);
        prop = {std::string(words[2]), *type, false, PlyType::UInt8};
      } else {
        throw_input_error(path, "expected 'property <type> <name>' or "
                                "'property list <count type> <item type> <name>'", line_no);
      }
      header.elements.back().properties.push_back(std::move(prop));
    } else {
      throw_input_error(path, "unknown header keyword '" + std::string(key) + "'", line_no);
    }
  }
  if (!have_format) throw_input_error(path, "header has no 'format' line");
  header.body_offset = pos;
  header.body_line = line_no + 1;
  return header;
}

// ---- where each vertex property goes -------------------------------------------------------

enum class Slot : std::uint8_t { Skip, Position, Normal, Color, Scalar };

struct Target {
  Slot slot = Slot::Skip;
  int index = 0;  // component (0..2) or scalar field index
};

struct VertexLayout {
  std::vector<Target> targets;  // one per vertex property
  bool normals = false;
  bool colors = false;
  std::vector<std::string> scalar_names;
};

int find_property(const PlyElement& e, std::string_view name) {
  for (std::size_t i = 0; i < e.properties.size(); ++i)
    if (!e.properties[i].is_list && e.properties[i].name == name) return static_cast<int>(i);
  return -1;
}

// Finds the first of `choices` whose three properties all exist; returns their indices.
std::optional<std::array<int, 3>> find_triple(const PlyElement& e,
                                              std::initializer_list<std::array<const char*, 3>> choices) {
  for (const auto& names : choices) {
    const std::array<int, 3> idx{find_property(e, names[0]), find_property(e, names[1]),
                                 find_property(e, names[2])};
    if (idx[0] >= 0 && idx[1] >= 0 && idx[2] >= 0) return idx;
  }
  return std::nullopt;
}

VertexLayout vertex_layout(const fs::path& path, const PlyElement& vertex) {
  VertexLayout layout;
  layout.targets.resize(vertex.properties.size());
  const auto pos = find_triple(vertex, {{"x", "y", "z"}});
  if (!pos) throw_input_error(path, "element 'vertex' lacks float properties x, y and z");
  for (int c = 0; c < 3; ++c) layout.targets[(*pos)[c]] = {Slot::Position, c};
  if (const auto n = find_triple(vertex, {{"nx", "ny", "nz"}, {"normal_x", "normal_y", "normal_z"}})) {
    layout.normals = true;
    for (int c = 0; c < 3; ++c) layout.targets[(*n)[c]] = {Slot::Normal, c};
  }
  if (const auto rgb = find_triple(vertex, {{"red", "green", "blue"},
                                            {"diffuse_red", "diffuse_green", "diffuse_blue"}})) {
    layout.colors = true;
    for (int c = 0; c < 3; ++c) layout.targets[(*rgb)[c]] = {Slot::Color, c};
  }
  for (std::size_t i = 0; i < vertex.properties.size(); ++i) {
    const auto& p = vertex.properties[i];
    // Alpha has no home in Rgb8; list properties on vertices are not point attributes.
    if (layout.targets[i].slot != Slot::Skip || p.is_list || p.name == "alpha" ||
        p.name == "diffuse_alpha")
      continue;
    layout.targets[i] = {Slot::Scalar, static_cast<int>(layout.scalar_names.size())};
    layout.scalar_names.push_back(p.name);
  }
  return layout;
}

// uchar colours as they are, ushort scaled down, float/double colours are 0..1.
std::uint8_t to_channel(double v, PlyType t) {
  switch (t) {
    case PlyType::Int8:
    case PlyType::UInt8: return static_cast<std::uint8_t>(static_cast<int>(v) & 0xff);
    case PlyType::Int16:
    case PlyType::UInt16: v /= 257.0; break;
    case PlyType::Float32:
    case PlyType::Float64: v *= 255.0; break;
    default: break;
  }
  if (!(v > 0.0)) return 0;  // also NaN
  return static_cast<std::uint8_t>(std::min(255.0, std::round(v)));
}

class VertexStore {
 public:
  VertexStore(PointCloud& cloud, const VertexLayout& layout, const PlyElement& vertex)
      : cloud_(cloud), layout_(layout), vertex_(vertex) {
    const std::size_t n = vertex.count;
    // resize leaves Eigen vectors uninitialised: every x/y/z (nx/ny/nz) column overwrites them.
    cloud.positions.resize(n);
    if (layout.normals) cloud.normals.resize(n);
    if (layout.colors) cloud.colors.assign(n, Rgb8{});
    for (const auto& name : layout.scalar_names)
      cloud.scalars.push_back({name, std::vector<float>(n, 0.0f)});
  }

  void set(std::size_t prop, std::size_t i, double v) {
    const Target t = layout_.targets[prop];
    switch (t.slot) {
      case Slot::Position: cloud_.positions[i][t.index] = static_cast<float>(v); break;
      case Slot::Normal: cloud_.normals[i][t.index] = static_cast<float>(v); break;
      case Slot::Color: channel(cloud_.colors[i], t.index) = to_channel(v, vertex_.properties[prop].type); break;
      case Slot::Scalar: cloud_.scalars[t.index].values[i] = static_cast<float>(v); break;
      case Slot::Skip: break;
    }
  }

  // Decodes one fixed-offset binary column for vertices [begin, end); base addresses vertex 0.
  // The loop is compiled per type.
  void set_column(std::size_t prop, const char* base, std::size_t stride, bool swap,
                  std::size_t begin, std::size_t end) {
    const Target t = layout_.targets[prop];
    const PlyType type = vertex_.properties[prop].type;
    visit_type(type, [&](auto tag) {
      using T = decltype(tag);
      switch (t.slot) {
        case Slot::Position:
          for (std::size_t i = begin; i < end; ++i)
            cloud_.positions[i][t.index] = static_cast<float>(load<T>(base + i * stride, swap));
          break;
        case Slot::Normal:
          for (std::size_t i = begin; i < end; ++i)
            cloud_.normals[i][t.index] = static_cast<float>(load<T>(base + i * stride, swap));
          break;
        case Slot::Color:
          for (std::size_t i = begin; i < end; ++i)
            channel(cloud_.colors[i], t.index) =
                to_channel(static_cast<double>(load<T>(base + i * stride, swap)), type);
          break;
        case Slot::Scalar: {
          float* out = cloud_.scalars[t.index].values.data();
          for (std::size_t i = begin; i < end; ++i)
            out[i] = static_cast<float>(load<T>(base + i * stride, swap));
          break;
        }
        case Slot::Skip: break;
      }
    });
  }

 private:
  static std::uint8_t& channel(Rgb8& c, int index) { return index == 0 ? c.r : index == 1 ? c.g : c.b; }

  PointCloud& cloud_;
  const VertexLayout& layout_;
  const PlyElement& vertex_;
};

// ---- body cursors: one interface, binary and ascii implementations ---------------------------

class BinaryCursor {
 public:
  BinaryCursor(const fs::path& path, std::string_view body, std::size_t body_offset, bool swap)
      : path_(path), body_(body), base_offset_(body_offset), swap_(swap) {}

  void begin_row(const PlyElement& e, std::size_t i) {
    element_ = &e;
    row_ = i;
  }
  double read(PlyType t) {
    const std::size_t size = type_size(t);
    need(size);
    const double v = visit_type(t, [&](auto tag) {
      return static_cast<double>(load<decltype(tag)>(body_.data() + pos_, swap_));
    });
    pos_ += size;
    return v;
  }
  void skip(PlyType t, std::size_t count) {
    const std::size_t bytes = type_size(t) * count;
    need(bytes);
    pos_ += bytes;
  }
  void end_row() {}
  long line() const { return 0; }

  // Fixed-stride element: returns the start of `count * stride` bytes and moves past them.
  const char* take_block(const PlyElement& e, std::size_t stride) {
    element_ = &e;
    row_ = 0;
    if (stride != 0 && e.count > (body_.size() - pos_) / stride) {
      row_ = (body_.size() - pos_) / stride;
      truncated();
    }
    const char* p = body_.data() + pos_;
    pos_ += e.count * stride;
    return p;
  }

  void finish() const {
    if (pos_ != body_.size())
      throw_input_error(path_, std::to_string(body_.size() - pos_) +
                                   " bytes follow the last element: the header's element "
                                   "counts do not match the body");
  }

 private:
  void need(std::size_t bytes) {
    if (bytes > body_.size() - pos_) truncated();
  }
  [[noreturn]] void truncated() const {
    throw_input_error(path_, "binary body is truncated: it ends inside " + element_->name + " " +
                                 std::to_string(row_) + " of " + std::to_string(element_->count) +
                                 " (file size " + std::to_string(base_offset_ + body_.size()) +
                                 " bytes)");
  }

  const fs::path& path_;
  std::string_view body_;
  std::size_t base_offset_;
  bool swap_;
  std::size_t pos_ = 0;
  const PlyElement* element_ = nullptr;
  std::size_t row_ = 0;
};

class AsciiCursor {
 public:
  AsciiCursor(const fs::path& path, std::string_view body, long first_line)
      : path_(path), body_(body), next_line_no_(first_line) {}

  // Each element instance is one line; blank lines are skipped.
  void begin_row(const PlyElement& e, std::size_t i) {
    element_ = &e;
    row_ = i;
    while (true) {
      if (pos_ >= body_.size())
        throw_input_error(path_, "file ends after " + std::to_string(i) + " of " +
                                     std::to_string(e.count) + " " + e.name + " lines");
      std::size_t end = body_.find('\n', pos_);
      if (end == std::string_view::npos) end = body_.size();
      line_ = body_.substr(pos_, end - pos_);
      line_no_ = next_line_no_++;
      pos_ = end + 1;
      col_ = 0;
      skip_space();
      if (col_ < line_.size()) return;
    }
  }

  double read(PlyType t) {
    skip_space();
    if (col_ >= line_.size())
      throw_input_error(path_, "too few values for " + element_->name + " " +
                                   std::to_string(row_) + " (" +
                                   std::to_string(element_->properties.size()) + " properties)",
                        line_no_);
    const char* first = line_.data() + col_;
    const char* last = line_.data() + line_.size();
    if (*first == '+') ++first;  // from_chars does not take a leading plus
    double v = 0.0;
    std::from_chars_result r{};
    if (t == PlyType::Float32) {
      // Parse floats as float: double-then-float rounding could differ in the last bit.
      float f = 0.0f;
      r = std::from_chars(first, last, f);
      v = f;
    } else {
      r = std::from_chars(first, last, v);
    }
    if (r.ec != std::errc{} || (r.ptr != last && !is_space(*r.ptr))) {
      const std::size_t start = col_;
      while (col_ < line_.size() && !is_space(line_[col_])) ++col_;
      throw_input_error(path_, "'" + std::string(line_.substr(start, col_ - start)) +
                                   "' is not a number (" + element_->name + " " +
                                   std::to_string(row_) + ")", line_no_);
    }
    col_ = static_cast<std::size_t>(r.ptr - line_.data());
    return v;
  }

  void skip(PlyType t, std::size_t count) {
    for (std::size_t k = 0; k < count; ++k) read(t);
  }

  long line() const { return line_no_; }

  void end_row() {
    skip_space();
    if (col_ < line_.size())
      throw_input_error(path_, "more values than the " +
                                   std::to_string(element_->properties.size()) +
                                   " properties of element '" + element_->name + "'", line_no_);
  }

  void finish() {
    while (pos_ < body_.size()) {
      std::size_t end = body_.find('\n', pos_);
      if (end == std::string_view::npos) end = body_.size();
      line_ = body_.substr(pos_, end - pos_);
      line_no_ = next_line_no_++;
      pos_ = end + 1;
      col_ = 0;
      skip_space();
      if (col_ < line_.size())
        throw_input_error(path_, "data after the last element: the header's element counts "
                                 "do not match the body", line_no_);
    }
  }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }
  void skip_space() {
    while (col_ < line_.size() && is_space(line_[col_])) ++col_;
  }

  const fs::path& path_;
  std::string_view body_;
  std::size_t pos_ = 0;
  long next_line_no_;
  long line_no_ = 0;
  std::string_view line_;
  std::size_t col_ = 0;
  const PlyElement* element_ = nullptr;
  std::size_t row_ = 0;
};

std::size_t list_count(const fs::path& path, double v, long line) {
  if (!(v >= 0.0) || v != std::floor(v)) throw_input_error(path, "negative or fractional list length", line);
  return static_cast<std::size_t>(v);
}

std::string number_text(double v) {
  char tmp[32];
  return {tmp, std::to_chars(tmp, tmp + sizeof(tmp), v).ptr};
}

struct PlyData {
  PointCloud cloud;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

bool is_face_index_list(const PlyElement& e, const PlyProperty& p) {
  return e.name == "face" && p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index");
}

// Reads the elements row by row; used for every ascii element and for binary elements with
// list properties (their row size varies).
template <typename Cursor>
void read_rows(const fs::path& path, Cursor& cur, const PlyElement& e, VertexStore* vertices,
               std::vector<std::array<std::uint32_t, 3>>* triangles, std::size_t vertex_count) {
  std::vector<std::uint32_t> polygon;
  for (std::size_t i = 0; i < e.count; ++i) {
    cur.begin_row(e, i);
    for (std::size_t p = 0; p < e.properties.size(); ++p) {
      const PlyProperty& prop = e.properties[p];
      if (!prop.is_list) {
        const double v = cur.read(prop.type);
        if (vertices) vertices->set(p, i, v);
        continue;
      }
      const std::size_t n = list_count(path, cur.read(prop.count_type), cur.line());
      if (!triangles || !is_face_index_list(e, prop)) {
        cur.skip(prop.type, n);
        continue;
      }
      polygon.clear();
      for (std::size_t k = 0; k < n; ++k) {
        const double v = cur.read(prop.type);
        if (!(v >= 0.0) || v >= static_cast<double>(vertex_count) || v != std::floor(v))
          throw_input_error(path, "face " + std::to_string(i) + " refers to vertex " +
                                      number_text(v) + " but there are " +
                                      std::to_string(vertex_count) + " vertices", cur.line());
        polygon.push_back(static_cast<std::uint32_t>(v));
      }
      // Polygons become triangle fans; fewer than three corners carry no surface.
      for (std::size_t k = 1; k + 1 < polygon.size(); ++k)
        triangles->push_back({polygon[0], polygon[k], polygon[k + 1]});
    }
    cur.end_row();
  }
}

PlyData read_ply_data(const fs::path& path, bool want_faces) {
  const std::string data = io_detail::read_whole_file(path);
  const PlyHeader header = parse_header(path, data);
  const auto vertex_it = std::find_if(header.elements.begin(), header.elements.end(),
                                      [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertex_it == header.elements.end()) throw_input_error(path, "header has no 'element vertex'");
  const VertexLayout layout = vertex_layout(path, *vertex_it);
  const std::size_t vertex_count = vertex_it->count;

  PlyData out;
  const std::string_view body = std::string_view(data).substr(header.body_offset);
  // Guard the allocation against a corrupt count: every vertex takes at least 2 bytes in
  // ascii ("0 ") and its full stride in binary.
  std::size_t min_vertex_bytes = 2;
  if (header.format != PlyFormat::Ascii) {
    min_vertex_bytes = 0;
    for (const auto& p : vertex_it->properties) min_vertex_bytes += type_size(p.is_list ? p.count_type : p.type);
  }
  if (min_vertex_bytes > 0 && vertex_count > body.size() / min_vertex_bytes + 1)
    throw_input_error(path, "header declares " + std::to_string(vertex_count) +
                                " vertices but the body has only " + std::to_string(body.size()) +
                                " bytes (truncated file?)");
  VertexStore store(out.cloud, layout, *vertex_it);
  auto* triangles = want_faces ? &out.triangles : nullptr;

  if (header.format == PlyFormat::Ascii) {
    AsciiCursor cur(path, body, header.body_line);
    for (const auto& e : header.elements)
      read_rows(path, cur, e, &e == &*vertex_it ? &store : nullptr, triangles, vertex_count);
    cur.finish();
  } else {
    const bool swap = (header.format == PlyFormat::BinaryBigEndian) !=
                      (std::endian::native == std::endian::big);
    BinaryCursor cur(path, body, header.body_offset, swap);
    for (const auto& e : header.elements) {
      const bool is_vertex = &e == &*vertex_it;
      if (e.has_lists()) {
        read_rows(path, cur, e, is_vertex ? &store : nullptr, triangles, vertex_count);
        continue;
      }
      std::size_t stride = 0;
      for (const auto& p : e.properties) stride += type_size(p.type);
      const char* block = cur.take_block(e, stride);
      if (!is_vertex) continue;
      // Column by column within blocks that stay in cache: one pass over the file's bytes.
      constexpr std::size_t kBlock = 4096;
      for (std::size_t begin = 0; begin < e.count; begin += kBlock) {
        const std::size_t end = std::min(e.count, begin + kBlock);
        std::size_t offset = 0;
        for (std::size_t p = 0; p < e.properties.size(); ++p) {
          store.set_column(p, block + offset, stride, swap, begin, end);
          offset += type_size(e.properties[p].type);
        }
      }
    }
    cur.finish();
  }
  return out;
}

// ---- writing --------------------------------------------------------------------------------

std::string header_name(const std::string& name, std::size_t index) {
  // PLY names are single words; keep the field readable rather than breaking the header.
  std::string s = name.empty() ? "scalar_" + std::to_string(index) : name;
  for (char& c : s)
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') c = '_';
  return s;
}

struct VertexAttributes {
  std::span<const Eigen::Vector3f> positions;
  std::span<const Eigen::Vector3f> normals;
  std::span<const Rgb8> colors;
  std::span<const ScalarField> scalars;
};

std::string make_header(const VertexAttributes& v, std::size_t face_count, bool with_faces,
                        PlyEncoding encoding) {
  std::string h = "ply\n";
  h += encoding == PlyEncoding::Ascii ? "format ascii 1.0\n" : "format binary_little_endian 1.0\n";
  h += "comment written by Locard " LOCARD_VERSION "\n";
  h += "element vertex " + std::to_string(v.positions.size()) + "\n";
  h += "property float x\nproperty float y\nproperty float z\n";
  if (!v.normals.empty()) h += "property float nx\nproperty float ny\nproperty float nz\n";
  if (!v.colors.empty()) h += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (std::size_t s = 0; s < v.scalars.size(); ++s)
    h += "property float " + header_name(v.scalars[s].name, s) + "\n";
  if (with_faces) {
    h += "element face " + std::to_string(face_count) + "\n";
    h += "property list uchar int vertex_indices\n";
  }
  h += "end_header\n";
  return h;
}

template <typename T>
void put_le(std::string& buf, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  buf.append(bytes, sizeof(T));
}

void put_text(std::string& buf, float v) {
  char tmp[32];
  // Shortest text that reads back to the same float (at most max_digits10 digits).
  const auto r = std::to_chars(tmp, tmp + sizeof(tmp), v);
  buf.append(tmp, r.ptr);
}

void put_text(std::string& buf, long v) {
  char tmp[24];
  const auto r = std::to_chars(tmp, tmp + sizeof(tmp), v);
  buf.append(tmp, r.ptr);
}

// Appends vertex i in the chosen encoding.
void put_vertex(std::string& buf, const VertexAttributes& v, std::size_t i, bool ascii) {
  if (ascii) {
    auto sep = [&buf] { buf.push_back(' '); };
    put_text(buf, v.positions[i].x()); sep();
    put_text(buf, v.positions[i].y()); sep();
    put_text(buf, v.positions[i].z());
    if (!v.normals.empty())
      for (int c = 0; c < 3; ++c) { sep(); put_text(buf, v.normals[i][c]); }
    if (!v.colors.empty()) {
      sep(); put_text(buf, long{v.colors[i].r});
      sep(); put_text(buf, long{v.colors[i].g});
      sep(); put_text(buf, long{v.colors[i].b});
    }
    for (const auto& s : v.scalars) { sep(); put_text(buf, s.values[i]); }
    buf.push_back('\n');
    return;
  }
  for (int c = 0; c < 3; ++c) put_le(buf, v.positions[i][c]);
  if (!v.normals.empty())
    for (int c = 0; c < 3; ++c) put_le(buf, v.normals[i][c]);
  if (!v.colors.empty()) {
    buf.push_back(static_cast<char>(v.colors[i].r));
    buf.push_back(static_cast<char>(v.colors[i].g));
    buf.push_back(static_cast<char>(v.colors[i].b));
  }
  for (const auto& s : v.scalars) put_le(buf, s.values[i]);
}

void put_face(std::string& buf, const std::array<std::uint32_t, 3>& t, bool ascii) {
  if (ascii) {
    buf += "3";
    for (std::uint32_t k : t) {
      buf.push_back(' ');
      put_text(buf, static_cast<long>(k));
    }
    buf.push_back('\n');
    return;
  }
  buf.push_back(3);
  for (std::uint32_t k : t) put_le(buf, static_cast<std::int32_t>(k));
}

void write_ply_file(const fs::path& path, const VertexAttributes& v,
                    std::span<const std::array<std::uint32_t, 3>> faces, bool with_faces,
                    PlyEncoding encoding) {
  const bool ascii = encoding == PlyEncoding::Ascii;
  AtomicFile file(path, true);
  std::ofstream& out = file.stream();
  const std::string header = make_header(v, faces.size(), with_faces, encoding);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  // Encode in chunks: bulk writes without holding a second copy of a large cloud in memory.
  constexpr std::size_t kChunk = 1 << 16;
  std::string buf;
  auto flush = [&] {
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
    buf.clear();
  };
  for (std::size_t i = 0; i < v.positions.size(); ++i) {
    put_vertex(buf, v, i, ascii);
    if ((i + 1) % kChunk == 0) flush();
  }
  for (std::size_t i = 0; i < faces.size(); ++i) {
    put_face(buf, faces[i], ascii);
    if ((i + 1) % kChunk == 0) flush();
  }
  flush();
  file.commit();
}

void check_count(const fs::path& path, std::size_t n, std::size_t found, const char* what) {
  if (found != 0 && found != n)
    throw Error(path.string() + ": cannot write: " + std::to_string(n) + " vertices but " +
                std::to_string(found) + " " + what);
}

}  // namespace

PointCloud read_ply(const fs::path& path) { return read_ply_data(path, false).cloud; }

TriangleMesh read_ply_mesh(const fs::path& path) {
  PlyData data = read_ply_data(path, true);
  TriangleMesh mesh;
  mesh.vertices = std::move(data.cloud.positions);
  mesh.vertex_normals = std::move(data.cloud.normals);
  mesh.vertex_colors = std::move(data.cloud.colors);
  mesh.triangles = std::move(data.triangles);
  return mesh;
}

void write_ply(const fs::path& path, const PointCloud& cloud, PlyEncoding encoding) {
  try {
    cloud.check_consistent();
  } catch (const Error& e) {
    throw Error(path.string() + ": cannot write: " + e.what());
  }
  write_ply_file(path, {cloud.positions, cloud.normals, cloud.colors, cloud.scalars}, {}, false,
                 encoding);
}

void write_ply(const fs::path& path, const TriangleMesh& mesh, PlyEncoding encoding) {
  const std::size_t n = mesh.vertices.size();
  check_count(path, n, mesh.vertex_normals.size(), "normals");
  check_count(path, n, mesh.vertex_colors.size(), "colours");
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (std::uint32_t k : mesh.triangles[i])
      if (k >= n)
        throw Error(path.string() + ": cannot write: triangle " + std::to_string(i) +
                    " refers to vertex " + std::to_string(k) + " but there are " +
                    std::to_string(n) + " vertices");
  write_ply_file(path, {mesh.vertices, mesh.vertex_normals, mesh.vertex_colors, {}},
                 mesh.triangles, true, encoding);
}

}  // namespace locard
