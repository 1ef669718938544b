// E57 writer. The whole logical file is laid out in memory first (header, one CompressedVector
// section per scan, then the XML that points at them), then cut into CRC'd pages and written
// in one go through AtomicFile. Only byte-aligned fields are written (single floats, 8-bit
// colour), so packets are plain copies of the cloud's arrays.

#include "io/e57_detail.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/e57.hpp>

#include <pugixml.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace locard {
namespace {

using namespace e57_detail;
namespace fs = std::filesystem;

static_assert(sizeof(Rgb8) == 3 && sizeof(Eigen::Vector3f) == 12,
              "the writer reads colours and positions as packed arrays");

constexpr const char* kNamespace = "http://www.astm.org/COMMIT/E57/2010-e57-v1.0";
// GPS time starts 1980-01-06 (315964800 s after the Unix epoch) and has no leap seconds:
// 18 have been inserted since, the last at the end of 2016.
constexpr double kGpsMinusUnix = -315964800.0 + 18.0;

// What the writer needs of a scan, by reference (so a cloud is never copied to be written).
struct ScanInput {
  const std::string& name;
  const std::string& guid;
  const PointCloud& cloud;
  const Isometry3d& T_file_scan;
  bool has_pose;
};

struct ScanPlan {
  std::vector<Column> columns;
  std::size_t count = 0;
  std::uint64_t section = 0;  // logical offset of its CompressedVector section
  const ScalarField* intensity = nullptr;
  std::string guid;
};

void check_scan(const fs::path& path, const ScanInput& scan, std::size_t index) {
  const std::size_t n = scan.cloud.size();
  const std::string label = "scan " + std::to_string(index) + " ('" + scan.name + "')";
  if (scan.cloud.has_colors() && scan.cloud.colors.size() != n)
    throw_input_error(path, label + " has " + std::to_string(n) + " positions but " +
                                std::to_string(scan.cloud.colors.size()) + " colours");
  if (const ScalarField* s = scan.cloud.find_scalar("intensity"); s && s->values.size() != n)
    throw_input_error(path, label + " has " + std::to_string(n) + " positions but " +
                                std::to_string(s->values.size()) + " intensities");
  if (!scan.T_file_scan.matrix().allFinite())
    throw_input_error(path, label + " has a pose that is not finite");
}

ScanPlan plan_scan(const ScanInput& scan) {
  ScanPlan plan;
  const PointCloud& cloud = scan.cloud;
  plan.count = cloud.size();
  const auto* xyz = reinterpret_cast<const std::uint8_t*>(cloud.positions.data());
  for (std::size_t axis = 0; axis < 3; ++axis)
    plan.columns.push_back({xyz + 4 * axis, sizeof(Eigen::Vector3f), 4});
  if (cloud.has_colors()) {
    const auto* rgb = reinterpret_cast<const std::uint8_t*>(cloud.colors.data());
    for (std::size_t c = 0; c < 3; ++c) plan.columns.push_back({rgb + c, sizeof(Rgb8), 1});
  }
  plan.intensity = cloud.find_scalar("intensity");
  if (plan.intensity)
    plan.columns.push_back(
        {reinterpret_cast<const std::uint8_t*>(plan.intensity->values.data()), 4, 4});
  plan.guid = scan.guid.empty() ? random_guid() : scan.guid;
  return plan;
}

// ---- XML ----

pugi::xml_node add(pugi::xml_node parent, const char* name, const char* type) {
  pugi::xml_node n = parent.append_child(name);
  n.append_attribute("type") = type;
  return n;
}

void add_string(pugi::xml_node parent, const char* name, const std::string& value) {
  pugi::xml_node n = add(parent, name, "String");
  if (!value.empty()) n.append_child(pugi::node_cdata).set_value(value.c_str());
}

void add_float(pugi::xml_node parent, const char* name, double value) {
  add(parent, name, "Float").text().set(format_double(value).c_str());
}

void add_integer(pugi::xml_node parent, const char* name, long long value) {
  add(parent, name, "Integer").text().set(value);
}

pugi::xml_node add_vector(pugi::xml_node parent, const char* name) {
  pugi::xml_node n = add(parent, name, "Vector");
  n.append_attribute("allowHeterogeneousChildren") = 1;
  return n;
}

void add_pose(pugi::xml_node scan_node, const Isometry3d& T) {
  pugi::xml_node pose = add(scan_node, "pose", "Structure");
  const Eigen::Quaterniond q(T.linear());
  pugi::xml_node r = add(pose, "rotation", "Structure");
  add_float(r, "w", q.w());
  add_float(r, "x", q.x());
  add_float(r, "y", q.y());
  add_float(r, "z", q.z());
  pugi::xml_node t = add(pose, "translation", "Structure");
  add_float(t, "x", T.translation().x());
  add_float(t, "y", T.translation().y());
  add_float(t, "z", T.translation().z());
}

void add_bounds(pugi::xml_node scan_node, const PointCloud& cloud) {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f hi = -lo;
  for (const auto& p : cloud.positions)
    if (p.allFinite()) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  if (!(lo.x() <= hi.x())) return;  // no finite point
  pugi::xml_node b = add(scan_node, "cartesianBounds", "Structure");
  static constexpr const char* kNames[3][2] = {
      {"xMinimum", "xMaximum"}, {"yMinimum", "yMaximum"}, {"zMinimum", "zMaximum"}};
  for (int a = 0; a < 3; ++a) {
    add_float(b, kNames[a][0], lo[a]);
    add_float(b, kNames[a][1], hi[a]);
  }
}

// Intensities already in 0..1 get limits 0..1, so a reader's normalisation (v - min) / (max -
// min) returns them bit for bit; others get their own range.
std::pair<double, double> intensity_limits(const ScalarField& intensity) {
  double lo = 0.0, hi = 1.0;
  for (float v : intensity.values)
    if (std::isfinite(v)) {
      lo = std::min<double>(lo, v);
      hi = std::max<double>(hi, v);
    }
  return {lo, hi};
}

void add_limits(pugi::xml_node scan_node, const ScanInput& scan, const ScanPlan& plan) {
  if (plan.intensity) {
    const auto [lo, hi] = intensity_limits(*plan.intensity);
    pugi::xml_node l = add(scan_node, "intensityLimits", "Structure");
    add_float(l, "intensityMinimum", lo);
    add_float(l, "intensityMaximum", hi);
  }
  if (scan.cloud.has_colors()) {
    pugi::xml_node l = add(scan_node, "colorLimits", "Structure");
    for (const char* c : {"Red", "Green", "Blue"}) {
      add_integer(l, (std::string("color") + c + "Minimum").c_str(), 0);
      add_integer(l, (std::string("color") + c + "Maximum").c_str(), 255);
    }
  }
}

void add_points(pugi::xml_node scan_node, const ScanInput& scan, const ScanPlan& plan) {
  pugi::xml_node points = add(scan_node, "points", "CompressedVector");
  points.append_attribute("fileOffset") =
      static_cast<unsigned long long>(to_physical(plan.section));
  points.append_attribute("recordCount") = static_cast<unsigned long long>(plan.count);
  pugi::xml_node proto = add(points, "prototype", "Structure");
  for (const char* axis : {"cartesianX", "cartesianY", "cartesianZ"})
    add(proto, axis, "Float").append_attribute("precision") = "single";
  if (scan.cloud.has_colors())
    for (const char* c : {"colorRed", "colorGreen", "colorBlue"}) {
      pugi::xml_node f = add(proto, c, "Integer");
      f.append_attribute("minimum") = 0;
      f.append_attribute("maximum") = 255;
    }
  if (plan.intensity) add(proto, "intensity", "Float").append_attribute("precision") = "single";
  add_vector(points, "codecs");
}

void add_scan(pugi::xml_node data3d, const ScanInput& scan, const ScanPlan& plan) {
  pugi::xml_node node = add(data3d, "vectorChild", "Structure");
  add_string(node, "guid", plan.guid);
  add_string(node, "name", scan.name);
  if (scan.has_pose) add_pose(node, scan.T_file_scan);
  add_bounds(node, scan.cloud);
  add_limits(node, scan, plan);
  add_points(node, scan, plan);
}

struct StringWriter : pugi::xml_writer {
  std::string text;
  void write(const void* data, std::size_t size) override {
    text.append(static_cast<const char*>(data), size);
  }
};

std::string build_xml(const std::vector<ScanInput>& scans, const std::vector<ScanPlan>& plans,
                      const E57WriteOptions& options) {
  pugi::xml_document doc;
  pugi::xml_node decl = doc.append_child(pugi::node_declaration);
  decl.append_attribute("version") = "1.0";
  decl.append_attribute("encoding") = "UTF-8";
  pugi::xml_node root = add(doc, "e57Root", "Structure");
  root.append_attribute("xmlns") = kNamespace;
  add_string(root, "formatName", "ASTM E57 3D Imaging Data File");
  add_string(root, "guid", options.guid.empty() ? random_guid() : options.guid);
  add_integer(root, "versionMajor", 1);
  add_integer(root, "versionMinor", 0);
#ifdef LOCARD_VERSION
  add_string(root, "e57LibraryVersion", std::string("Locard ") + LOCARD_VERSION);
#else
  add_string(root, "e57LibraryVersion", "Locard");
#endif
  add_string(root, "coordinateMetadata", "");
  pugi::xml_node created = add(root, "creationDateTime", "Structure");
  const double now = std::chrono::duration<double>(
                         std::chrono::system_clock::now().time_since_epoch()).count();
  add_float(created, "dateTimeValue", options.creation_gps_time.value_or(now + kGpsMinusUnix));
  add_integer(created, "isAtomicClockReferenced", 0);
  pugi::xml_node data3d = add_vector(root, "data3D");
  for (std::size_t i = 0; i < scans.size(); ++i) add_scan(data3d, scans[i], plans[i]);
  add_vector(root, "images2D");
  StringWriter out;
  doc.save(out, "  ", pugi::format_default | pugi::format_no_declaration, pugi::encoding_utf8);
  return out.text;
}

std::uint64_t align8(std::uint64_t v) { return (v + 7) / 8 * 8; }

void write_scans(const fs::path& path, const std::vector<ScanInput>& scans,
                 const E57WriteOptions& options) {
  std::vector<ScanPlan> plans;
  std::uint64_t end = kHeaderSize;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    check_scan(path, scans[i], i);
    plans.push_back(plan_scan(scans[i]));
    plans.back().section = align8(end);
    end = plans.back().section + section_size(plans.back().columns, plans.back().count);
  }
  const std::string xml = build_xml(scans, plans, options);
  const std::uint64_t xml_begin = end;
  Bytes logical(xml_begin + xml.size());
  std::memset(logical.data(), 0, kHeaderSize);
  for (std::uint64_t gap = kHeaderSize; const ScanPlan& plan : plans) {  // alignment padding
    std::memset(logical.data() + gap, 0, plan.section - gap);
    write_section(logical.data(), plan.section, plan.columns, plan.count);
    gap = plan.section + section_size(plan.columns, plan.count);
  }
  std::memcpy(logical.data() + xml_begin, xml.data(), xml.size());

  FileHeader header;
  header.file_length = (logical.size() + kPagePayload - 1) / kPagePayload * kPageSize;
  header.xml_offset = to_physical(xml_begin);
  header.xml_length = xml.size();
  put_header(logical.data(), header);
  AtomicFile file(path);
  write_pages(file.stream(), logical.data(), logical.size());
  file.commit();
}

}  // namespace

void write_e57(const fs::path& path, const std::vector<E57Scan>& scans,
               const E57WriteOptions& options) {
  std::vector<ScanInput> inputs;
  for (const E57Scan& s : scans)
    inputs.push_back({s.name, s.guid, s.cloud, s.T_file_scan, s.has_pose});
  write_scans(path, inputs, options);
}

void write_e57(const fs::path& path, const PointCloud& cloud, const std::string& name,
               const E57WriteOptions& options) {
  static const std::string no_guid;
  static const Isometry3d identity = Isometry3d::Identity();
  write_scans(path, {{name, no_guid, cloud, identity, false}}, options);
}

}  // namespace locard
