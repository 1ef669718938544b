// E57 reader: the XML section names the scans (data3D) and where their points are; each
// scan's compressed vector is decoded field by field into a PointCloud. Records whose invalid
// state is not 0 are dropped; colour and intensity are scaled by the scan's limits.

#include "io/e57_detail.hpp"

#include <locard/io/e57.hpp>

#include <pugixml.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

namespace locard {
namespace {

using namespace e57_detail;
namespace fs = std::filesystem;

// Indices into the prototype of the fields Locard reads (absent: nullopt).
struct FieldLayout {
  std::array<std::optional<std::size_t>, 3> cartesian, spherical, color;
  std::optional<std::size_t> cartesian_invalid, spherical_invalid, intensity;
  std::optional<std::size_t> color_invalid, intensity_invalid;
  std::vector<std::string> unread;  // present but not read
  bool row_column = false;
};

bool all_present(const std::array<std::optional<std::size_t>, 3>& a) {
  return a[0] && a[1] && a[2];
}

FieldLayout layout_of(const std::vector<FieldSpec>& fields) {
  FieldLayout l;
  const std::array<std::pair<const char*, std::optional<std::size_t>*>, 13> known = {{
      {"cartesianX", &l.cartesian[0]},
      {"cartesianY", &l.cartesian[1]},
      {"cartesianZ", &l.cartesian[2]},
      {"sphericalRange", &l.spherical[0]},
      {"sphericalAzimuth", &l.spherical[1]},
      {"sphericalElevation", &l.spherical[2]},
      {"colorRed", &l.color[0]},
      {"colorGreen", &l.color[1]},
      {"colorBlue", &l.color[2]},
      {"cartesianInvalidState", &l.cartesian_invalid},
      {"sphericalInvalidState", &l.spherical_invalid},
      {"intensity", &l.intensity},
      {"isColorInvalid", &l.color_invalid},
  }};
  for (std::size_t k = 0; k < fields.size(); ++k) {
    const std::string& name = fields[k].name;
    const auto it = std::find_if(known.begin(), known.end(),
                                 [&](const auto& e) { return name == e.first; });
    if (it != known.end())
      *it->second = k;
    else if (name == "isIntensityInvalid")
      l.intensity_invalid = k;
    else if (name == "rowIndex" || name == "columnIndex")
      l.row_column = true;
    else
      l.unread.push_back(name);
  }
  return l;
}

// The [lo, hi] that maps a colour or intensity field onto 0..1: the scan's limits element
// where it has one, else the prototype field's own range.
struct Limits {
  double lo = 0.0;
  double hi = 1.0;
};

Limits field_limits(const fs::path& path, const pugi::xml_node& scan, const char* limits_name,
                    const std::string& min_name, const std::string& max_name,
                    const FieldSpec& field) {
  const pugi::xml_node limits = scan.child(limits_name);
  const pugi::xml_node lo = limits.child(min_name.c_str());
  const pugi::xml_node hi = limits.child(max_name.c_str());
  if (lo && hi) return {number_value(path, lo), number_value(path, hi)};
  switch (field.type) {
    case FieldType::Integer:
      return {static_cast<double>(field.minimum), static_cast<double>(field.maximum)};
    case FieldType::ScaledInteger:
      return {static_cast<double>(field.minimum) * field.scale + field.offset,
              static_cast<double>(field.maximum) * field.scale + field.offset};
    case FieldType::Float32:
    case FieldType::Float64: break;
  }
  if (field.has_float_range) return {field.float_minimum, field.float_maximum};
  fail(path, "XML " + element_path(scan),
       "field '" + field.name + "' is a Float with no " + limits_name + " and no minimum/maximum, "
       "so its scale is unknown");
}

Isometry3d read_pose(const fs::path& path, const pugi::xml_node& pose,
                     std::vector<std::string>& notes, const std::string& scan_label) {
  Isometry3d T = Isometry3d::Identity();
  if (const pugi::xml_node r = pose.child("rotation")) {
    Eigen::Quaterniond q(number_value(path, r.child("w")), number_value(path, r.child("x")),
                         number_value(path, r.child("y")), number_value(path, r.child("z")));
    if (!(q.norm() > 1e-9) || !q.coeffs().allFinite())
      fail(path, "XML " + element_path(r), "the rotation quaternion is zero or not finite");
    if (std::abs(q.norm() - 1.0) > 1e-6)
      notes.push_back(scan_label + ": pose rotation quaternion of norm " +
                      format_double(q.norm()) + " normalised");
    T.linear() = q.normalized().toRotationMatrix();
  }
  if (const pugi::xml_node t = pose.child("translation"))
    T.translation() = Eigen::Vector3d(number_value(path, t.child("x")),
                                      number_value(path, t.child("y")),
                                      number_value(path, t.child("z")));
  if (!T.matrix().allFinite())
    fail(path, "XML " + element_path(pose), "the pose is not finite");
  return T;
}

// Decoded columns of one scan, before the invalid records are dropped.
struct ScanColumns {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Rgb8> colors;
  std::vector<float> intensity;
  std::vector<std::uint8_t> valid;
};

void decode_positions(const std::vector<FieldSpec>& fields, const std::vector<Bytestream>& s,
                      const FieldLayout& l, bool spherical, std::size_t n, ScanColumns& out) {
  resize_huge(out.positions, n);
  if (!spherical) {
    for (int axis = 0; axis < 3; ++axis) {
      const std::size_t k = *l.cartesian[axis];
      decode_field(fields[k], s[k], n, [&](std::size_t i, double v) {
        out.positions[i][axis] = static_cast<float>(v);
      });
    }
    return;
  }
  // x = r cos(elevation) cos(azimuth), y = r cos(elevation) sin(azimuth), z = r sin(elevation)
  std::array<std::vector<double>, 3> rae;
  for (int j = 0; j < 3; ++j) {
    const std::size_t k = *l.spherical[j];
    rae[j].resize(n);
    decode_field(fields[k], s[k], n, [&](std::size_t i, double v) { rae[j][i] = v; });
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double r = rae[0][i], az = rae[1][i], el = rae[2][i];
    out.positions[i] = Eigen::Vector3d(r * std::cos(el) * std::cos(az),
                                       r * std::cos(el) * std::sin(az), r * std::sin(el))
                           .cast<float>();
  }
}

void decode_validity(const std::vector<FieldSpec>& fields, const std::vector<Bytestream>& s,
                     std::optional<std::size_t> state, std::size_t n, ScanColumns& out) {
  if (!state) return;  // no state field: every record is a point (`valid` stays empty)
  out.valid.assign(n, 1);
  // 0 valid, 1 direction only (no range), 2 invalid: only 0 is a point.
  decode_field(fields[*state], s[*state], n,
               [&](std::size_t i, double v) { out.valid[i] = v == 0.0; });
}

std::uint8_t to_byte(double v, const Limits& lim) {
  const double unit = lim.hi > lim.lo ? (v - lim.lo) / (lim.hi - lim.lo) : 0.0;
  return static_cast<std::uint8_t>(std::clamp(std::lround(unit * 255.0), 0L, 255L));
}

void decode_colors(const fs::path& path, const pugi::xml_node& scan,
                   const std::vector<FieldSpec>& fields, const std::vector<Bytestream>& s,
                   const FieldLayout& l, std::size_t n, ScanColumns& out) {
  static constexpr std::array<const char*, 3> kChannel = {"Red", "Green", "Blue"};
  static constexpr std::array<std::uint8_t Rgb8::*, 3> kMember = {&Rgb8::r, &Rgb8::g, &Rgb8::b};
  resize_huge(out.colors, n);
  for (int c = 0; c < 3; ++c) {
    const std::size_t k = *l.color[c];
    const Limits lim = field_limits(path, scan, "colorLimits",
                                    std::string("color") + kChannel[c] + "Minimum",
                                    std::string("color") + kChannel[c] + "Maximum", fields[k]);
    if (lim.lo == 0.0 && lim.hi == 255.0)  // already 8-bit: no scaling (the usual case)
      decode_field(fields[k], s[k], n, [&](std::size_t i, double v) {
        out.colors[i].*kMember[c] = static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0) + 0.5);
      });
    else
      decode_field(fields[k], s[k], n, [&](std::size_t i, double v) {
        out.colors[i].*kMember[c] = to_byte(v, lim);
      });
  }
  if (l.color_invalid)  // a point without colour is kept, black
    decode_field(fields[*l.color_invalid], s[*l.color_invalid], n, [&](std::size_t i, double v) {
      if (v != 0.0) out.colors[i] = Rgb8{};
    });
}

void decode_intensity(const fs::path& path, const pugi::xml_node& scan,
                      const std::vector<FieldSpec>& fields, const std::vector<Bytestream>& s,
                      const FieldLayout& l, std::size_t n, ScanColumns& out) {
  const std::size_t k = *l.intensity;
  const Limits lim = field_limits(path, scan, "intensityLimits", "intensityMinimum",
                                  "intensityMaximum", fields[k]);
  const double span = lim.hi > lim.lo ? lim.hi - lim.lo : 1.0;
  resize_huge(out.intensity, n);
  decode_field(fields[k], s[k], n, [&](std::size_t i, double v) {
    out.intensity[i] = static_cast<float>((v - lim.lo) / span);
  });
  if (l.intensity_invalid)
    decode_field(fields[*l.intensity_invalid], s[*l.intensity_invalid], n,
                 [&](std::size_t i, double v) {
                   if (v != 0.0) out.intensity[i] = 0.0f;
                 });
}

template <typename T>
void keep_valid(std::vector<T>& values, const std::vector<std::uint8_t>& valid) {
  if (values.empty() || valid.empty()) return;
  std::size_t w = 0;
  for (std::size_t i = 0; i < values.size(); ++i)
    if (valid[i]) values[w++] = values[i];
  values.resize(w);
}

PointCloud to_cloud(ScanColumns&& c, bool has_intensity) {
  if (std::find(c.valid.begin(), c.valid.end(), 0) == c.valid.end()) c.valid.clear();
  keep_valid(c.positions, c.valid);
  keep_valid(c.colors, c.valid);
  keep_valid(c.intensity, c.valid);
  PointCloud cloud;
  cloud.positions = std::move(c.positions);
  cloud.colors = std::move(c.colors);
  if (has_intensity) cloud.scalars.push_back({"intensity", std::move(c.intensity)});
  return cloud;
}

void check_codecs(const fs::path& path, const pugi::xml_node& points) {
  for (pugi::xml_node codec : points.child("codecs").children("vectorChild"))
    if (!codec.child("bitPackCodec"))
      fail(path, "XML " + element_path(codec),
           "only the bitPack codec is read (the file names another)");
}

E57Scan read_scan(const LogicalFile& file, const pugi::xml_node& node,
                  std::vector<std::string>& notes) {
  const fs::path& path = file.path;
  E57Scan scan;
  scan.name = string_value(node.child("name"));
  scan.guid = string_value(node.child("guid"));
  const std::string scan_label = "scan '" + scan.name + "'";
  if (const pugi::xml_node pose = node.child("pose")) {
    scan.T_file_scan = read_pose(path, pose, notes, scan_label);
    scan.has_pose = true;
  }
  const pugi::xml_node points = node.child("points");
  if (!points || std::string(points.attribute("type").value()) != "CompressedVector")
    fail(path, "XML " + element_path(node), "no 'points' CompressedVector");
  check_codecs(path, points);
  const std::uint64_t offset = unsigned_attribute(path, points, "fileOffset");
  const std::uint64_t count = unsigned_attribute(path, points, "recordCount");
  const std::vector<FieldSpec> fields = parse_prototype(path, points.child("prototype"));
  const FieldLayout layout = layout_of(fields);
  const bool spherical = !all_present(layout.cartesian);
  if (spherical && !all_present(layout.spherical))
    fail(path, "XML " + element_path(points.child("prototype")),
         "neither cartesianX/Y/Z nor sphericalRange/Azimuth/Elevation");
  const bool color = all_present(layout.color);
  scan.fields = {spherical ? E57Coordinates::Spherical : E57Coordinates::Cartesian, color,
                 layout.intensity.has_value(), layout.row_column,
                 (spherical ? layout.spherical_invalid : layout.cartesian_invalid).has_value()};
  scan.record_count = count;
  if (!layout.unread.empty()) {
    std::string list;
    for (const auto& n : layout.unread) list += (list.empty() ? "" : ", ") + n;
    notes.push_back(scan_label + ": fields not read: " + list);
  }

  const std::vector<Bytestream> streams =
      read_bytestreams(file, offset, fields, count, "XML " + element_path(points));
  const auto n = static_cast<std::size_t>(count);
  ScanColumns columns;
  decode_positions(fields, streams, layout, spherical, n, columns);
  decode_validity(fields, streams, spherical ? layout.spherical_invalid : layout.cartesian_invalid,
                  n, columns);
  if (color) decode_colors(path, node, fields, streams, layout, n, columns);
  if (layout.intensity) decode_intensity(path, node, fields, streams, layout, n, columns);
  scan.cloud = to_cloud(std::move(columns), layout.intensity.has_value());
  return scan;
}

std::string image_summary(const pugi::xml_node& image) {
  static constexpr std::array<const char*, 4> kRepresentations = {
      "visualReferenceRepresentation", "pinholeRepresentation", "sphericalRepresentation",
      "cylindricalRepresentation"};
  for (const char* name : kRepresentations)
    if (const pugi::xml_node r = image.child(name)) {
      const std::string kind = r.child("jpegImage") ? "JPEG" : r.child("pngImage") ? "PNG" : "no image data";
      return std::string(r.child("imageWidth").text().get()) + "x" +
             r.child("imageHeight").text().get() + " " + kind;
    }
  return "unknown representation";
}

void note_images(const pugi::xml_node& images, std::vector<std::string>& notes) {
  std::vector<std::string> summaries;
  for (pugi::xml_node image : images.children("vectorChild"))
    summaries.push_back(image_summary(image));
  if (summaries.empty()) return;
  std::string list;
  for (const auto& s : summaries) list += (list.empty() ? "" : ", ") + s;
  notes.push_back("images2D: " + std::to_string(summaries.size()) +
                  (summaries.size() == 1 ? " image (" : " images (") + list + ") not read");
}

pugi::xml_document parse_xml(const LogicalFile& file) {
  const FileHeader& h = file.header;
  const std::uint64_t begin = to_logical(file, h.xml_offset, "header xmlPhysicalOffset");
  if (h.xml_length > file.bytes.size() - begin)
    fail(file.path, "header", "the XML section (" + std::to_string(h.xml_length) +
                                  " bytes from byte " + std::to_string(h.xml_offset) +
                                  ") runs past the end of the file");
  pugi::xml_document doc;
  const pugi::xml_parse_result result =
      doc.load_buffer(file.bytes.data() + begin, h.xml_length, pugi::parse_default,
                      pugi::encoding_utf8);
  if (!result)
    fail(file.path, "XML section, character " + std::to_string(result.offset),
         std::string("not well-formed XML: ") + result.description());
  if (!doc.child("e57Root"))
    fail(file.path, "XML section", "no <e57Root> element");
  return doc;
}

}  // namespace

E57File read_e57(const fs::path& path) {
  const LogicalFile file = load_logical_file(path);
  const pugi::xml_document doc = parse_xml(file);
  const pugi::xml_node root = doc.child("e57Root");
  E57File out;
  out.guid = string_value(root.child("guid"));
  for (pugi::xml_node scan : root.child("data3D").children("vectorChild"))
    out.scans.push_back(read_scan(file, scan, out.notes));
  note_images(root.child("images2D"), out.notes);
  return out;
}

PointCloud merge_scans(std::vector<E57Scan> scans) {
  PointCloud merged;
  for (E57Scan& scan : scans) {
    if (scan.cloud.empty()) continue;  // append() would drop the others' colours
    PointCloud part = scan.T_file_scan.matrix().isIdentity(0.0)
                          ? std::move(scan.cloud)
                          : transformed(scan.cloud, scan.T_file_scan);
    if (merged.empty())
      merged = std::move(part);
    else
      merged.append(part);
  }
  return merged;
}

PointCloud read_e57_merged(const fs::path& path) { return merge_scans(read_e57(path).scans); }

}  // namespace locard
