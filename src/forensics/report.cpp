#include <locard/forensics/report.hpp>

#include "forensics/json_util.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/core/raycaster.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_measurements.hpp>
#include <locard/forensics/case_metadata.hpp>
#include <locard/forensics/evidence_markers.hpp>
#include <locard/forensics/integrity.hpp>
#include <locard/forensics/revisions.hpp>
#include <locard/forensics/trajectory_analysis.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/trajectory_io.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <unistd.h>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;
using nlohmann::json;

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

json read_json_or_null(const fs::path& p) {
  if (!fs::exists(p)) return nullptr;
  std::ifstream in(p);
  try {
    return json::parse(in);
  } catch (const json::exception&) {
    return nullptr;
  }
}

std::string esc(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// A recorded object's revisions (revisions.hpp) in the report: a withdrawn row is struck
// through and grey but kept, an earlier name is shown beside the current one.
std::string revision_class(const Revisions& r) { return r.withdrawn() ? " class=\"withdrawn\"" : ""; }

std::string revised_name(const std::string& name, const Revisions& r) {
  std::string out = esc(name);
  if (r.previous_names.empty()) return out;
  std::string was;
  for (const std::string& n : r.previous_names) was += (was.empty() ? "" : ", ") + esc(n);
  return out + " <span class=\"note\">(was " + was + ")</span>";
}

std::string revision_status(const Revisions& r) {
  if (!r.withdrawn()) return "current";
  return "withdrawn " + esc(r.withdrawn_at) + ": " + esc(r.withdrawn_reason);
}

std::string base64(const std::vector<std::uint8_t>& data) {
  static constexpr char k[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < data.size(); i += 3) {
    const std::uint32_t b0 = data[i], b1 = i + 1 < data.size() ? data[i + 1] : 0,
                        b2 = i + 2 < data.size() ? data[i + 2] : 0;
    const std::uint32_t v = (b0 << 16) | (b1 << 8) | b2;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < data.size() ? k[(v >> 6) & 63] : '=';
    out += i + 2 < data.size() ? k[v & 63] : '=';
  }
  return out;
}

std::string mm(double m, int digits = 1) { return fmt::format("{:.{}f}", 1000.0 * m, digits); }
std::string cm(double m, int digits = 1) { return fmt::format("{:.{}f}", 100.0 * m, digits); }
std::string v3(const Eigen::Vector3d& v, int digits = 3) {
  return fmt::format("({:.{}f}, {:.{}f}, {:.{}f})", v.x(), digits, v.y(), digits, v.z(), digits);
}
std::string v3(const json& j, int digits = 3) {
  if (!j.is_array() || j.size() != 3) return "";
  return fmt::format("({:.{}f}, {:.{}f}, {:.{}f})", j[0].get<double>(), digits,
                     j[1].get<double>(), digits, j[2].get<double>(), digits);
}

// Shades a hit: headlight Lambert times the interpolated vertex colour.
void shade(const TriangleMesh& mesh, const RayHit& hit, const Vector3d& dir, std::uint8_t* px) {
  const auto& t = mesh.triangles[hit.triangle];
  const Vector3d a = mesh.vertices[t[0]].cast<double>(), b = mesh.vertices[t[1]].cast<double>(),
                 c = mesh.vertices[t[2]].cast<double>();
  const Vector3d n = (b - a).cross(c - a).normalized();
  const double lambert = 0.35 + 0.65 * std::abs(n.dot(dir.normalized()));
  double rgb[3] = {180, 180, 180};
  if (!mesh.vertex_colors.empty()) {
    const double w0 = 1.0 - hit.u - hit.v, w1 = hit.u, w2 = hit.v;
    const Rgb8 &c0 = mesh.vertex_colors[t[0]], &c1 = mesh.vertex_colors[t[1]], &c2 = mesh.vertex_colors[t[2]];
    rgb[0] = w0 * c0.r + w1 * c1.r + w2 * c2.r;
    rgb[1] = w0 * c0.g + w1 * c1.g + w2 * c2.g;
    rgb[2] = w0 * c0.b + w1 * c1.b + w2 * c2.b;
  }
  for (int k = 0; k < 3; ++k)
    px[k] = static_cast<std::uint8_t>(std::clamp(rgb[k] * lambert, 0.0, 255.0));
}

struct TopView {
  ColorImage image;
  Vector3d centre, ex, ey, up;  // image x along ex, image y along -ey (north up)
  double scale = 1.0;           // pixels per metre
  int width = 0, height = 0;
  Eigen::Vector2d to_pixel(const Vector3d& p) const {
    const Vector3d r = p - centre;
    return {0.5 * width + scale * r.dot(ex), 0.5 * height - scale * r.dot(ey)};
  }
};

// Orthographic view from above, cut below the ceiling: rays start at the cut height.
TopView render_top_view(const TriangleMesh& mesh, const Raycaster& rc, const Vector3d& up,
                        int width, int height) {
  TopView v;
  v.up = up.normalized();
  v.ex = (std::abs(v.up.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY());
  v.ex = (v.ex - v.ex.dot(v.up) * v.up).normalized();
  v.ey = v.up.cross(v.ex);
  Vector3d lo = Vector3d::Constant(1e30), hi = Vector3d::Constant(-1e30);
  double hmin = 1e30, hmax = -1e30;
  for (const auto& p : mesh.vertices) {
    const Vector3d q = p.cast<double>();
    const Vector3d l(q.dot(v.ex), q.dot(v.ey), 0);
    lo = lo.cwiseMin(l);
    hi = hi.cwiseMax(l);
    hmin = std::min(hmin, q.dot(v.up));
    hmax = std::max(hmax, q.dot(v.up));
  }
  const double sx = hi.x() - lo.x(), sy = hi.y() - lo.y();
  v.scale = 0.92 * std::min(width / std::max(sx, 1e-3), height / std::max(sy, 1e-3));
  v.width = width;
  v.height = height;
  // Cut 15 % of the height below the top (the ceiling of a room).
  const double cut = hmax - 0.15 * (hmax - hmin);
  v.centre = 0.5 * (lo.x() + hi.x()) * v.ex + 0.5 * (lo.y() + hi.y()) * v.ey + cut * v.up;
  v.image = ColorImage(width, height, 255);
  const Vector3d dir = -v.up;
  tbb::parallel_for(0, height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      const Vector3d o = v.centre + ((x + 0.5 - 0.5 * width) / v.scale) * v.ex -
                         ((y + 0.5 - 0.5 * height) / v.scale) * v.ey;
      const RayHit h = rc.intersect(o.cast<float>(), dir.cast<float>());
      if (h.hit()) shade(mesh, h, dir, &v.image.at(x, y, 0));
    }
  });
  return v;
}

// The opening of a plan drawn over the top view: an SVG of its size with the rendered top view
// (`image_uri`, encoded once per report) faded to `opacity` under what is drawn on it.
std::string plan_svg_begin(const std::string& id, const TopView& top, const std::string& image_uri,
                           double opacity) {
  return fmt::format(
      "<svg id=\"{3}\" xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" "
      "viewBox=\"0 0 {0} {1}\"><image width=\"{0}\" height=\"{1}\" href=\"{2}\" "
      "opacity=\"{4}\"/>",
      top.width, top.height, image_uri, id, opacity);
}

// What every plan drawn over the top view carries: a scale bar (a round length near a quarter
// of the width) and the case's axes, +y up the page as north on a map. The case frame is
// levelled (z up), so the drawing is a true plan.
std::string map_furniture_svg(const TopView& top) {
  const double target = 0.25 * top.width / top.scale;
  double length = 0.1;
  for (const double nice : {0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 2.5, 5.0, 10.0, 20.0})
    if (nice <= target) length = nice;
  const double px = length * top.scale;
  const double x0 = 12, y0 = top.height - 14.0;
  std::string svg = fmt::format(
      "<g class=\"scale-bar\"><rect x=\"{0:.1f}\" y=\"{1:.1f}\" width=\"{2:.1f}\" height=\"6\" "
      "fill=\"#fff\" stroke=\"#000\"/><rect x=\"{0:.1f}\" y=\"{1:.1f}\" width=\"{3:.1f}\" "
      "height=\"6\" fill=\"#000\"/><text x=\"{0:.1f}\" y=\"{4:.1f}\" font-size=\"10\">0</text>"
      "<text x=\"{5:.1f}\" y=\"{4:.1f}\" font-size=\"10\" text-anchor=\"end\">{6} m</text></g>",
      x0, y0, px, 0.5 * px, y0 - 3, x0 + px, length);
  const double ax = top.width - 30.0, ay = top.height - 16.0;
  svg += fmt::format(
      "<g class=\"axes\" font-size=\"10\"><line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" "
      "y2=\"{2:.1f}\" stroke=\"#000\" stroke-width=\"1.5\"/><path d=\"M{0:.1f},{3:.1f} l-4,8 h8 z\"/>"
      "<text x=\"{0:.1f}\" y=\"{4:.1f}\" text-anchor=\"middle\">N (+y)</text>"
      "<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{5:.1f}\" y2=\"{1:.1f}\" stroke=\"#000\"/>"
      "<text x=\"{6:.1f}\" y=\"{7:.1f}\">x</text></g>",
      ax, ay, ay - 34, ay - 38, ay - 40, ax + 18, ax + 20, ay + 4);
  return svg;
}

// The floor the scan observed, over the top view (coverage/floor_coverage.json): hidden cells
// amber, unseen red, the tripod's centre and its unseen disc outlined.
std::string coverage_section(const fs::path& root, const TopView& top, const std::string& top_uri) {
  std::string h = "<h2 id=\"coverage\">Coverage: the floor the scan observed</h2>\n";
  const json c = read_json_or_null(root / "coverage" / "floor_coverage.json");
  if (c.is_null()) {
    h += "<p class=\"note\">Not computed: the case has no horizontal floor plane to judge "
         "(not levelled, or no floor in view).</p>\n";
    return h;
  }
  std::string svg = plan_svg_begin("coverage-plot", top, top_uri, 0.6);
  const double cell = c.value("cell_m", 0.05), z = c.value("floor_z_m", 0.0);
  const double ox = c["origin"][0].get<double>(), oy = c["origin"][1].get<double>();
  const auto& rows = c["rows"];
  std::string unseen, hidden;
  for (std::size_t y = 0; y < rows.size(); ++y) {
    const std::string row = rows[y].get<std::string>();
    for (std::size_t x = 0; x < row.size();) {  // runs of one kind, one rectangle each
      const char kind = row[x];
      std::size_t end = x;
      while (end < row.size() && row[end] == kind) ++end;
      if (kind == 'u' || kind == 'h') {
        const auto a = top.to_pixel({ox + cell * x, oy + cell * (y + 1), z});
        const auto b = top.to_pixel({ox + cell * end, oy + cell * y, z});
        // Rectangles of one kind are one path, a little over a cell each way: a path's own
        // overlaps are painted once, so neither seams nor darker overlaps show.
        (kind == 'u' ? unseen : hidden) +=
            fmt::format("M{:.1f},{:.1f}h{:.1f}v{:.1f}h{:.1f}z", a.x() - 0.3, a.y() - 0.3,
                        b.x() - a.x() + 0.6, b.y() - a.y() + 0.6, -(b.x() - a.x() + 0.6));
      }
      x = end;
    }
  }
  svg += fmt::format("<path d=\"{}\" fill=\"#d62728\" fill-opacity=\"0.55\"/><path d=\"{}\" "
                     "fill=\"#ff9f1c\" fill-opacity=\"0.55\"/>",
                     unseen, hidden);
  if (c.contains("tripod")) {
    const json& t = c["tripod"];
    const auto p = top.to_pixel({t["centre"][0].get<double>(), t["centre"][1].get<double>(), z});
    svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" fill=\"none\" "
                       "stroke=\"#000\" stroke-dasharray=\"4 3\"/><circle cx=\"{:.1f}\" "
                       "cy=\"{:.1f}\" r=\"3\" fill=\"#000\"/>",
                       p.x(), p.y(), t.value("unseen_radius_m", 0.0) * top.scale, p.x(), p.y());
  }
  svg += map_furniture_svg(top) + "</svg>";
  const json& area = c["area_m2"];
  h += "<figure>" + svg +
       fmt::format("<figcaption>Floor at z = {:.3f} m in {:.0f} mm cells, from {} views: red unseen "
                   "(in no view's field and range), amber hidden under or behind objects, the "
                   "rest seen; black: the tripod's centre and its unseen disc</figcaption>",
                   z, 1000 * cell, c.value("views_used", 0)) +
       "</figure>\n";
  h += fmt::format("<table id=\"coverage-table\"><tr><th>floor seen</th><td class=n>{:.2f} m&sup2; "
                   "({:.0f} %)</td></tr><tr><th>hidden</th><td class=n>{:.2f} m&sup2;</td></tr>"
                   "<tr><th>unseen</th><td class=n>{:.2f} m&sup2;</td></tr></table>\n",
                   area.value("seen", 0.0), 100.0 * c.value("seen_share", 0.0),
                   area.value("hidden", 0.0), area.value("unseen", 0.0));
  h += "<ul id=\"coverage-advice\">";
  for (const json& line : c["advice"]) h += "<li>" + esc(line.get<std::string>()) + "</li>";
  h += "</ul>\n";
  return h;
}

// One dimension line of the plan: the ends' snapped points (a measurement JSON's "a"/"b").
struct PlanDimension {
  std::string name, value;
  Vector3d a, b;
};

std::optional<PlanDimension> plan_dimension(const json& m, const std::string& name,
                                            const std::string& value) {
  if (!m.contains("a") || !m.contains("b") || !m["a"].contains("snapped") ||
      !m["b"].contains("snapped"))
    return std::nullopt;
  return PlanDimension{name, value, json_vec3(m["a"]["snapped"], "report: " + name),
                       json_vec3(m["b"]["snapped"], "report: " + name)};
}

// The measurements drawn on the plan: Table I's measured rows and the other point-to-point
// measurements (not withdrawn), each a numbered dimension line with ticks at its ends; a
// measurement that is nearly vertical (under 8 px long on the plan) is listed, not drawn.
std::string floor_plan_section(const fs::path& root, const TopView& top, const std::string& top_uri) {
  std::vector<PlanDimension> dims;
  if (const json t = read_json_or_null(root / "measurements" / "table.json"); !t.is_null())
    for (const json& r : t["rows"]) {
      if (r.contains("not_measured") || !r.value("ends_snapped", true)) continue;
      if (auto d = plan_dimension(r["measurement"], r.value("name", ""),
                                  fmt::format("{:.1f} cm", 100.0 * r.value("model_m", 0.0))))
        dims.push_back(*d);
    }
  for (const CaseMeasurement& m : read_case_measurements(root / kCaseMeasurementsJson)) {
    if (m.revisions.withdrawn() || m.kind != MeasurementKind::PointToPoint) continue;
    const bool snapped = m.a->fixed_by_model() && m.b->fixed_by_model();
    dims.push_back({m.name,
                    fmt::format("{:.1f} cm{}", 100.0 * m.value,
                                snapped ? "" : " (an end not snapped: as picked)"),
                    m.a->snapped, m.b->snapped});
  }
  std::string h = "<h2 id=\"floor-plan\">Dimensioned floor plan</h2>\n";
  if (dims.empty()) {
    h += "<p class=\"note\">No measurements to draw yet (<code>locard measure</code>).</p>\n";
    return h;
  }
  std::string svg = plan_svg_begin("floor-plan-plot", top, top_uri, 0.45);
  std::string legend = "<table id=\"floor-plan-legend\"><tr><th>#</th><th>measurement</th>"
                       "<th>model</th><th>on the plan</th></tr>";
  for (std::size_t k = 0; k < dims.size(); ++k) {
    const auto p = top.to_pixel(dims[k].a), q = top.to_pixel(dims[k].b);
    const Eigen::Vector2d d = q - p;
    const bool drawn = d.norm() >= 8.0;
    if (drawn) {
      const Eigen::Vector2d n = Eigen::Vector2d(-d.y(), d.x()).normalized() * 5.0;
      const Eigen::Vector2d mid = 0.5 * (p + q);
      svg += fmt::format(
          "<g class=\"dimension\" stroke=\"#0b3d91\" stroke-width=\"1.4\"><line x1=\"{:.1f}\" "
          "y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\"/><line x1=\"{:.1f}\" y1=\"{:.1f}\" "
          "x2=\"{:.1f}\" y2=\"{:.1f}\"/><line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" "
          "y2=\"{:.1f}\"/></g><circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"7\" fill=\"#fff\" "
          "stroke=\"#0b3d91\"/><text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"9\" "
          "text-anchor=\"middle\" fill=\"#0b3d91\">{}</text>",
          p.x(), p.y(), q.x(), q.y(), p.x() - n.x(), p.y() - n.y(), p.x() + n.x(), p.y() + n.y(),
          q.x() - n.x(), q.y() - n.y(), q.x() + n.x(), q.y() + n.y(), mid.x(), mid.y(), mid.x(),
          mid.y() + 3, k + 1);
    }
    legend += fmt::format("<tr><td class=n>{}</td><td>{}</td><td class=n>{}</td><td>{}</td></tr>",
                          k + 1, esc(dims[k].name), dims[k].value,
                          drawn ? "drawn" : "nearly vertical: not drawn");
  }
  svg += map_furniture_svg(top) + "</svg>";
  h += "<figure>" + svg +
       "<figcaption>Orthographic plan (the case frame from above, z up): each measurement's "
       "snapped ends joined by a numbered dimension line; lengths are the 3D distances in the "
       "legend, not their projections</figcaption></figure>\n" + legend + "</table>\n";
  return h;
}

std::string svg_text(const std::string& svg) {
  const auto p = svg.find("<svg");
  return p == std::string::npos ? svg : svg.substr(p);
}

}  // namespace

ColorImage render_mesh_view(const TriangleMesh& mesh, const Raycaster& rc, const Vector3d& eye,
                            const Vector3d& target, const Vector3d& up, double fov_deg, int width,
                            int height) {
  const Vector3d fwd = (target - eye).normalized();
  const Vector3d right = fwd.cross(up).normalized();
  const Vector3d down = fwd.cross(right);
  const double f = 0.5 * height / std::tan(0.5 * fov_deg * M_PI / 180.0);
  ColorImage img(width, height, 255);
  tbb::parallel_for(0, height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      const Vector3d dir = fwd + ((x + 0.5 - 0.5 * width) / f) * right + ((y + 0.5 - 0.5 * height) / f) * down;
      const RayHit h = rc.intersect(eye.cast<float>(), dir.cast<float>());
      if (h.hit()) shade(mesh, h, dir, &img.at(x, y, 0));
    }
  });
  return img;
}

std::vector<std::uint8_t> encode_png(const ColorImage& image) {
  static std::atomic<int> counter{0};
  const fs::path tmp = fs::temp_directory_path() /
                       fmt::format("locard-png-{}-{}.png", ::getpid(), counter++);
  write_png(tmp, image);
  std::ifstream in(tmp, std::ios::binary);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  fs::remove(tmp);
  return bytes;
}

std::string png_data_uri(const ColorImage& image) {
  return "data:image/png;base64," + base64(encode_png(image));
}

fs::path find_chromium() {
  if (const char* env = std::getenv("LOCARD_CHROMIUM"); env && *env)
    return fs::exists(env) ? fs::path(env) : fs::path();
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    if (const char* path = std::getenv("PATH")) {
      std::stringstream ss(path);
      std::string dir;
      while (std::getline(ss, dir, ':'))
        if (!dir.empty() && fs::exists(fs::path(dir) / name)) return fs::path(dir) / name;
    }
    if (fs::exists(fs::path("/usr/bin") / name)) return fs::path("/usr/bin") / name;
  }
  return {};
}

namespace {

// What every section of the report reads: the case's records, loaded once.
struct ReportInputs {
  fs::path root;
  json case_json;
  Trajectory trajectory;
  MarkerSet markers;                         // evidence/markers.json (empty: none)
  std::vector<TrajectoryAnalysis> analyses;  // trajectories/analyses.json (empty: none)
  CaseMetadata metadata;
};

Vector3d report_up(const ReportInputs& r) {
  // Up: the case frame's z where one was chosen (`locard level` on picked floor points, or
  // `marker frame` on a room corner); else +z in a levelled case (reconstruct levels from the
  // data's gravity or the floor); otherwise the mean of the cameras' -y axes (the sensor is held
  // roughly level).
  Vector3d up = Vector3d::Zero();
  const std::string frame_text = r.case_json.value("world_frame", "");
  const Vector3d frame_z = r.markers.frame.axes.col(2);
  const bool levelled = r.case_json.contains("level")
                            ? r.case_json["level"].value("levelled", false)
                            // cases written before the typed field: their world_frame sentence
                            : frame_text.find("levelled") != std::string::npos ||
                                  frame_text.find("level as given") != std::string::npos;
  if ((frame_z - Vector3d::UnitZ()).norm() > 1e-9) {  // a frame was chosen that turns z
    up = frame_z.normalized();
  } else if (levelled) {
    up = Vector3d::UnitZ();
  } else {
    for (const StampedPose& p : r.trajectory) up += p.T_world_camera.linear() * Vector3d(0, -1, 0);
    up = up.norm() > 1e-6 ? up.normalized() : Vector3d::UnitZ();
  }
  return up;
}

std::string report_opening(const ReportInputs& r, const ReportOptions& o) {
  std::string h;
  const json& case_json = r.case_json;
  const CaseMetadata& metadata = r.metadata;
  const fs::path& root = r.root;
  const std::string title = !metadata.number.empty()
                                ? "Case " + metadata.number
                                : (o.title.empty() ? case_json.value("title", "Locard case") : o.title);
  h += "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n";
  h += "<title>" + esc(title) + "</title>\n<style>\n"
       "body{font-family:DejaVu Sans,Arial,sans-serif;margin:24px;color:#222;max-width:1100px}"
       "h1{font-size:22px}h2{font-size:17px;border-bottom:1px solid #999;margin-top:28px}"
       "table{border-collapse:collapse;font-size:12px;margin:6px 0}"
       "td,th{border:1px solid #bbb;padding:2px 6px;text-align:left;vertical-align:top}"
       "th{background:#eee}td.n{text-align:right;font-variant-numeric:tabular-nums}"
       ".ok{color:#060}.bad{color:#a00;font-weight:bold}tr.withdrawn td{color:#888}"
       "tr.withdrawn td:not(:last-child){text-decoration:line-through}.hash{font-family:monospace;font-size:10px}"
       ".views img{width:48%;margin:0.5%;border:1px solid #ccc}figure{margin:8px 0}"
       "figcaption{font-size:12px;color:#555}.note{font-size:12px;color:#555}"
       ".illustrative{border:2px solid #c60;padding:4px 8px;color:#c60;font-weight:bold}"
       ".hashes{columns:2;font-family:monospace;font-size:8px;line-height:1.25}"
       "@page{size:" + std::string(to_string(o.paper)) + ";margin:14mm}"
       "@media print{h2{page-break-after:avoid}table{page-break-inside:auto}}\n</style></head><body>\n";
  h += "<h1>" + esc(title) + "</h1>\n";
  h += fmt::format("<p class=\"note\">Case folder <code>{}</code>, created {} by Locard {}. World "
                   "frame: {}. Lengths in metres unless stated; uncertainties are expanded "
                   "(k = 2, about 95 %).</p>\n",
                   esc(fs::absolute(root).string()), esc(case_json.value("created", "")),
                   esc(case_json["software"].value("version", "")),
                   esc(case_json.value("world_frame", "")));
  // The case as a court exhibit names it
  {
    const auto field = [](const std::string& v) {
      return v.empty() ? std::string("<span class=note>not set (<code>locard case set</code>)</span>") : esc(v);
    };
    h += fmt::format("<table id=\"case-metadata\"><tr><th>case number</th><td>{}</td></tr><tr><th>"
                     "investigator</th><td>{}</td></tr><tr><th>location</th><td>{}</td></tr><tr>"
                     "<th>date of examination</th><td>{}</td></tr></table>\n",
                     field(metadata.number), field(metadata.investigator),
                     field(metadata.location), field(metadata.date));
  }
  return h;
}

std::string summary_section(const ReportInputs& r) {
  std::string h;
  const json& case_json = r.case_json;
  const fs::path& root = r.root;
  // Summary
  h += "<h2 id=\"summary\">Summary</h2>\n<table>";
  const json& in = case_json["inputs"];
  h += fmt::format("<tr><th>input</th><td>{} ({}, {} frames, {} files hashed)</td></tr>",
                   esc(in.value("root", "")), esc(in.value("format", "")),
                   in.value("frames", 0), in.contains("files") ? in["files"].size() : 0);
  if (case_json.contains("alignment")) {
    const json& a = case_json["alignment"];
    h += fmt::format("<tr><th>alignment</th><td>{} of {} views registered, {} piece(s), {} loop "
                     "closure(s)</td></tr>",
                     a.value("registered", 0), a.value("frames", 0), a.value("pieces", 0),
                     a.value("loop_closures", 0));
  }
  if (const json mj = read_json_or_null(root / "mesh" / "mesh.json"); !mj.is_null())
    h += fmt::format("<tr><th>model</th><td>{} mesh, voxel {} mm: {} vertices, {} triangles; "
                     "registered cloud {} points</td></tr>",
                     mj.value("method", "tsdf") == "poisson" ? "Poisson" : "TSDF",
                     mm(mj.value("voxel_size", 0.0), 1), mj.value("vertices", 0),
                     mj.value("triangles", 0), mj.value("cloud_points", 0));
  h += "</table>\n";
  return h;
}

std::string views_section(const TriangleMesh& mesh, const Raycaster& rc, const Vector3d& up,
                          const std::string& top_uri, const Trajectory& trajectory,
                          const ReportOptions& o) {
  std::string h = "<h2 id=\"views\">Rendered views of the model</h2>\n<div class=\"views\">";
  h += "<figure><img alt=\"top view\" src=\"" + top_uri +
       "\"><figcaption>Top view (orthographic, cut below the ceiling)</figcaption></figure>";
  if (!trajectory.empty()) {
    Vector3d centre = Vector3d::Zero();
    for (const StampedPose& p : trajectory) centre += p.T_world_camera.translation();
    centre /= static_cast<double>(trajectory.size());
    for (int k = 0; k < 3; ++k) {
      const StampedPose& p = trajectory[trajectory.size() * static_cast<std::size_t>(k) / 3];
      const Vector3d fwd = p.T_world_camera.linear() * Vector3d::UnitZ();
      const Vector3d eye = centre - 0.8 * (fwd - fwd.dot(up) * up).normalized() + 0.3 * up;
      const ColorImage img = render_mesh_view(mesh, rc, eye, eye + fwd, up, 75.0, o.render_width,
                                              o.render_height);
      h += "<figure><img alt=\"view " + std::to_string(k + 1) + "\" src=\"" + png_data_uri(img) +
           "\"><figcaption>From the scanner position, looking as view " +
           std::to_string(p.frame_index) + " did</figcaption></figure>";
    }
  }
  h += "</div>\n";
  return h;
}

std::string stage_errors_section(const ReportInputs& r) {
  std::string h;
  const json& case_json = r.case_json;
  const fs::path& root = r.root;
  // Stage-error plot (the paper's Fig. 4)
  h += "<h2 id=\"stage-errors\">Alignment error per stage (Fig. 4)</h2>\n";
  if (fs::exists(root / "alignment" / "stage_report.svg"))
    h += "<figure id=\"stage-plot\">" + svg_text(read_text(root / "alignment" / "stage_report.svg")) +
         "<figcaption>Cumulative error of each view at its initial pose (feature alignment by "
         "SVD, or the tripod guess), after ICP and after loop closure</figcaption></figure>\n";
  if (case_json.contains("alignment") && case_json["alignment"].contains("stage_errors")) {
    h += "<table><tr><th>stage</th><th>views</th><th>mean error (mm)</th><th>max (mm)</th><th>ATE "
         "RMSE (mm)</th></tr>";
    for (const json& s : case_json["alignment"]["stage_errors"])
      h += fmt::format("<tr><td>{}</td><td class=n>{}</td><td class=n>{}</td><td class=n>{}</td>"
                       "<td class=n>{}</td></tr>",
                       esc(s.value("stage", "")), s.value("views", 0),
                       mm(s.value("mean_translation_m", 0.0), 2), mm(s.value("max_translation_m", 0.0), 2),
                       s["ate_rmse_m"].is_number() ? mm(s["ate_rmse_m"].get<double>(), 2) : "n/a");
    h += "</table>\n";
  }

  return h;
}

std::string trajectory_plot_section(const ReportInputs& r, const TopView& top,
                                    const std::string& top_uri) {
  std::string h;
  const Trajectory& trajectory = r.trajectory;
  // Trajectory top view: camera path, markers and bullet lines over the top view.
  h += "<h2 id=\"trajectory\">Camera trajectory, evidence and bullet lines (top view)</h2>\n";
  std::string svg = plan_svg_begin("trajectory-plot", top, top_uri, 0.55);
  std::string path;
  for (const StampedPose& p : trajectory) {
    const auto px = top.to_pixel(p.T_world_camera.translation());
    path += fmt::format("{}{:.1f},{:.1f} ", path.empty() ? "M" : "L", px.x(), px.y());
  }
  svg += "<path d=\"" + path + "\" fill=\"none\" stroke=\"#1f5fbf\" stroke-width=\"2\"/>";
  for (const StampedPose& p : trajectory) {
    const auto px = top.to_pixel(p.T_world_camera.translation());
    const Vector3d f = p.T_world_camera.linear() * Vector3d::UnitZ();
    const auto tip = top.to_pixel(p.T_world_camera.translation() + 0.25 * f);
    svg += fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" "
                       "stroke=\"#1f5fbf\" stroke-width=\"0.8\"/>",
                       px.x(), px.y(), tip.x(), tip.y());
  }
  for (const TrajectoryAnalysis& a : r.analyses) {
    if (a.revisions.withdrawn() || a.points.empty()) continue;  // withdrawn: listed below
    const Vector3d p0 = a.backward.hit ? a.backward.point : a.points.front();
    const Vector3d p1 = a.forward.hit ? a.forward.point : a.points.back();
    const auto q0 = top.to_pixel(p0), q1 = top.to_pixel(p1);
    svg += fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" "
                       "stroke=\"#c00\" stroke-width=\"2\" stroke-dasharray=\"6 3\"/>",
                       q0.x(), q0.y(), q1.x(), q1.y());
  }
  for (const EvidenceMarker& m : r.markers.markers) {
    if (m.revisions.withdrawn()) continue;
    const auto px = top.to_pixel(m.world);
    svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"7\" fill=\"#ffd400\" "
                       "stroke=\"#000\"/><text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"9\" "
                       "text-anchor=\"middle\">{}</text>",
                       px.x(), px.y(), px.x(), px.y() + 3, m.number);
  }
  svg += map_furniture_svg(top) + "</svg>";
  h += "<figure>" + svg +
       "<figcaption>Blue: camera positions and viewing directions; yellow: evidence markers; "
       "red dashed: bullet trajectories to the surfaces they meet</figcaption></figure>\n";
  return h;
}

std::string table_one_section(const fs::path& root) {
  std::string h;
  // Table I
  h += "<h2 id=\"measurements\">Measurements against reference (Table I)</h2>\n";
  const json table = read_json_or_null(root / "measurements" / "table.json");
  if (table.is_null()) {
    h += "<p class=\"note\">No reference measurements were given.</p>\n";
  } else {
    h += "<table id=\"measurement-table\"><tr><th>object</th><th>real (cm)</th><th>3D model "
         "(cm)</th><th>error (mm)</th><th>uncertainty U (mm, k=2)</th><th>|error| &le; U</th>"
         "<th>end points (snapped)</th></tr>";
    for (const json& r : table["rows"]) {
      if (r.contains("not_measured")) {
        h += fmt::format("<tr><td>{}</td><td class=n>{}</td><td colspan=5 class=bad>not measured: "
                         "{}</td></tr>",
                         esc(r.value("name", "")), cm(r.value("real_m", 0.0), 2),
                         esc(r.value("not_measured", "")));
        continue;
      }
      const bool ok = r.value("within_uncertainty", false);
      const bool snapped = r.value("ends_snapped", true);  // tables before this field: as they said
      const json& m = r["measurement"];
      h += fmt::format("<tr><td>{}</td><td class=n>{}</td><td class=n>{}</td><td class=n>{}</td>"
                       "<td class=n>{}</td><td class=\"{}\">{}</td><td>{} {} &rarr; {} {}</td></tr>",
                       esc(r.value("name", "")), cm(r.value("real_m", 0.0), 2),
                       cm(r.value("model_m", 0.0), 2), mm(r.value("error_m", 0.0), 1),
                       mm(r.value("expanded_uncertainty_m", 0.0), 1), ok ? "ok" : "bad",
                       !snapped ? "not measured: an end is not snapped" : ok ? "yes" : "NO",
                       esc(m["a"].value("feature", "")), v3(m["a"]["snapped"]),
                       esc(m["b"].value("feature", "")), v3(m["b"]["snapped"]));
    }
    h += "</table>\n";
  }
  if (const fs::path adhoc = root / kCaseMeasurementsJson; fs::exists(adhoc)) {
    h += "<h3>Other measurements</h3><table id=\"other-measurements\"><tr><th>name</th>"
         "<th>kind</th><th>value</th><th>U (k=2)</th><th>status</th></tr>";
    for (const CaseMeasurement& m : read_case_measurements(adhoc)) {
      const bool angle = m.is_angle();
      h += fmt::format("<tr{}><td>{}</td><td>{}</td><td class=n>{}</td><td class=n>{}</td><td>{}</td></tr>",
                       revision_class(m.revisions), revised_name(m.name, m.revisions),
                       esc(std::string(to_string(m.kind))),
                       angle ? fmt::format("{:.2f}&deg;", m.value)
                             : fmt::format("{:.4f} m", m.value),
                       angle ? fmt::format("{:.2f}&deg;", m.expanded_uncertainty)
                             : fmt::format("{} mm", mm(m.expanded_uncertainty)),
                       revision_status(m.revisions));
    }
    h += "</table>\n";
  }

  return h;
}

std::string evidence_section(const MarkerSet& set) {
  std::string h = "<h2 id=\"evidence\">Evidence markers</h2>\n";
  if (set.markers.empty())
    return h + "<p class=\"note\">No evidence markers yet (<code>locard marker add</code>).</p>\n";
  h += "<p class=\"note\">Frame: " + esc(set.frame.description) + ", origin " +
       v3(set.frame.origin) + "</p>";
  h += "<table id=\"evidence-table\"><tr><th>#</th><th>label</th><th>x</th><th>y</th><th>z</th>"
       "<th>U (mm)</th><th>note</th><th>status</th></tr>";
  for (const EvidenceMarker& m : set.markers) {
    const Vector3d l = set.frame.to_local(m.world);
    h += fmt::format("<tr{}><td>{}</td><td>{}</td><td class=n>{:.3f}</td><td class=n>{:.3f}</td>"
                     "<td class=n>{:.3f}</td><td class=n>{}</td><td>{}</td><td>{}</td></tr>",
                     revision_class(m.revisions), m.number, revised_name(m.label, m.revisions),
                     l.x(), l.y(), l.z(), mm(m.expanded_uncertainty_m), esc(m.note),
                     revision_status(m.revisions));
  }
  return h + "</table>\n";
}

std::string trajectories_section(const std::vector<TrajectoryAnalysis>& analyses) {
  std::string h = "<h2 id=\"trajectories\">Bullet trajectory analyses</h2>\n";
  if (analyses.empty())
    return h + "<p class=\"note\">No trajectory analyses yet (<code>locard trajectory</code>).</p>\n";
  h += "<table id=\"trajectory-table\"><tr><th>name</th><th>points</th><th>horizontal "
       "angle</th><th>vertical angle</th><th>cone half-angle (k=2)</th><th>forward hit</th>"
       "<th>backward hit</th><th>status</th></tr>";
  const auto hit = [](const SurfaceHit& j) {
    if (!j.hit) return std::string("none");
    return fmt::format("{} at {:.3f} m, cone radius {} mm", v3(j.point), j.distance_m,
                       mm(j.cone_radius_m));
  };
  for (const TrajectoryAnalysis& a : analyses)
    h += fmt::format("<tr{}><td>{}</td><td class=n>{}</td><td class=n>{:.2f}&deg;</td><td "
                     "class=n>{:.2f}&deg;</td><td class=n>{:.2f}&deg;</td><td>{}</td><td>{}</td>"
                     "<td>{}</td></tr>",
                     revision_class(a.revisions), revised_name(a.name, a.revisions),
                     a.points.size(), a.horizontal_angle_deg, a.vertical_angle_deg,
                     a.cone_half_angle_deg, hit(a.forward), hit(a.backward),
                     revision_status(a.revisions));
  return h + "</table>\n";
}

std::string simulations_section(const fs::path& root) {
  std::string h;
  // Simulations: never measured data, said on every row.
  h += "<h2 id=\"simulations\">Simulations (illustrative)</h2>\n";
  std::vector<fs::path> sims;
  std::error_code ec;
  if (fs::is_directory(root / "simulations", ec))
    for (const auto& e : fs::directory_iterator(root / "simulations", ec))
      if (e.is_directory() && fs::is_regular_file(e.path() / "events.json")) sims.push_back(e.path());
  std::sort(sims.begin(), sims.end());
  if (sims.empty()) {
    h += "<p class=\"note\">No simulations (<code>locard simulate</code>).</p>\n";
  } else {
    h += "<p class=\"illustrative\">ILLUSTRATIVE: physics scenarios played against the model "
         "show what could have happened under the scenario's assumptions. They are not "
         "measured data.</p>\n<table id=\"simulation-table\"><tr><th>scenario</th><th>"
         "description</th><th>events</th><th>support and warnings</th></tr>";
    for (const fs::path& dir : sims) {
      const json ev = read_json_or_null(dir / "events.json");
      if (ev.is_null()) continue;
      std::map<std::string, int> counts;
      if (ev.contains("events") && ev["events"].is_array())
        for (const json& e : ev["events"]) ++counts[e.value("type", "?")];
      std::string events;
      for (const auto& [type, n] : counts) events += fmt::format("{}{} {}", events.empty() ? "" : ", ", n, type);
      std::string support;
      if (ev.contains("inferred_support") && ev["inferred_support"].is_object())
        support = fmt::format("floor inferred at {:.3f} m where the scan has holes",
                              ev["inferred_support"].value("height_m", 0.0));
      if (ev.contains("warnings") && ev["warnings"].is_array())
        for (const json& w : ev["warnings"])
          if (w.is_string()) support += (support.empty() ? "" : "; ") + std::string("warning: ") + w.get<std::string>();
      h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                       esc(ev.value("scenario", dir.filename().string())),
                       esc(ev.value("description", "")), esc(events.empty() ? "none" : events),
                       esc(support.empty() ? "-" : support));
    }
    h += "</table>\n";
  }
  return h;
}

std::string parameters_section(const json& case_json) {
  std::string h;
  // Parameters
  h += "<h2 id=\"parameters\">Parameters</h2>\n<table>";
  for (const auto& [k, v] : case_json["parameters"].items())
    h += "<tr><th>" + esc(k) + "</th><td>" + esc(v.dump()) + "</td></tr>";
  h += "<tr><th>seeds</th><td>" + esc(case_json.value("seeds", json::object()).dump()) + "</td></tr>";
  h += "<tr><th>sensor</th><td>" + esc(case_json.value("sensor", json::object()).dump()) + "</td></tr>";
  h += "</table>\n";

  return h;
}

std::string log_section(const fs::path& root) {
  std::string h;
  // Processing log
  h += "<h2 id=\"log\">Processing log</h2>\n<table><tr><th>#</th><th>time (UTC)</th><th>step</th>"
       "<th>duration (s)</th><th>parameters</th><th>line sha256</th></tr>";
  {
    std::ifstream log(root / "log.jsonl");
    std::string line;
    while (std::getline(log, line)) {
      if (line.empty()) continue;
      json j;
      try {
        j = json::parse(line);
      } catch (const json::exception&) {
        continue;
      }
      h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td class=n>{:.2f}</td><td "
                       "class=hash>{}</td><td class=hash>{}</td></tr>",
                       j.value("seq", 0), esc(j.value("time", "")), esc(j.value("step", "")),
                       j.value("duration_s", 0.0), esc(j["parameters"].dump()),
                       sha256_hex(line).substr(0, 16));
    }
  }
  h += "</table>\n";

  return h;
}

std::string hashes_section(const ReportInputs& r) {
  std::string h;
  const fs::path& root = r.root;
  const json& in = r.case_json["inputs"];
  // Hashes: an appendix headed by the two hashes that cover everything (the manifest lists
  // every output's hash, the log head anchors the history); the inputs, often thousands of
  // frames, in compact columns (their full hashes are in case.json, itself in the manifest).
  h += "<h2 id=\"hashes\">Appendix: integrity (SHA-256)</h2>\n";
  {
    const std::string head = log_head_sha256(root);
    const fs::path manifest_path = root / "manifest.json";
    const std::string manifest_hash = fs::is_regular_file(manifest_path) ? sha256_file(manifest_path) : "";
    h += fmt::format("<table id=\"anchor-hashes\"><tr><th>manifest.json when this report was "
                     "written</th><td class=hash>sha256 {}</td></tr><tr><th>log head</th><td "
                     "class=hash id=\"log-head\">sha256 {}</td></tr></table>\n",
                     manifest_hash.empty() ? "(none)" : manifest_hash,
                     head.empty() ? "(empty log)" : head);
    h += fmt::format("<p class=\"note\">Check the case with <code>locard verify CASE_DIR</code>, "
                     "and that it still holds every step up to this report with <code>locard "
                     "verify CASE_DIR --expect-head {}</code>. The report and the final manifest "
                     "are hashed in log.jsonl and manifest.json.</p>",
                     head);
  }
  h += "<table id=\"output-hashes\"><tr><th>case file</th><th>bytes</th><th>sha256</th></tr>";
  if (const json manifest = read_json_or_null(root / "manifest.json"); !manifest.is_null())
    for (const auto& [k, v] : manifest["files"].items())
      if (k.rfind("report/", 0) != 0)
        h += fmt::format("<tr><td>{}</td><td class=n>{}</td><td class=hash>{}</td></tr>", esc(k),
                         v.value("bytes", 0), esc(v.value("sha256", "")));
  h += "</table>\n";
  if (in.contains("files") && in["files"].is_array()) {
    h += fmt::format("<p class=\"note\">{} input files under <code>{}</code>: path and the first "
                     "16 hex digits of each SHA-256 (case.json holds them in full).</p><div "
                     "class=\"hashes\" id=\"input-hashes\">",
                     in["files"].size(), esc(in.value("root", "")));
    for (const json& f : in["files"])
      h += fmt::format("{} {}<br>", esc(f.value("sha256", "").substr(0, 16)), esc(f.value("path", "")));
    h += "</div>\n";
  }
  return h;
}

// report.pdf from report.html through headless Chromium, when one is installed; a missing or
// failing Chromium leaves a note, never a half-written PDF.
void print_pdf(const fs::path& root, ReportResult& result) {
  const fs::path chromium = find_chromium();
  if (chromium.empty()) {
    result.pdf_note = "warning: no Chromium found (chromium, chromium-browser, google-chrome or "
                      "$LOCARD_CHROMIUM); report.pdf was not written - print report.html instead";
    return;
  }
  const fs::path pdf = root / "report" / "report.pdf";
  const fs::path tmp_pdf = root / "report" / ".report.pdf.tmp";
  const fs::path profile = fs::temp_directory_path() / fmt::format("locard-chromium-{}", ::getpid());
  const fs::path log = fs::temp_directory_path() / fmt::format("locard-chromium-{}.log", ::getpid());
  const std::string cmd = fmt::format(
      "timeout 120 '{}' --headless --no-sandbox --disable-gpu --no-first-run "
      "--user-data-dir='{}' --no-pdf-header-footer --print-to-pdf='{}' 'file://{}' >'{}' 2>&1",
      chromium.string(), profile.string(), tmp_pdf.string(), fs::absolute(result.html).string(),
      log.string());
  const int status = std::system(cmd.c_str());
  std::error_code ec;
  fs::remove_all(profile, ec);
  if (status == 0 && fs::exists(tmp_pdf) && fs::file_size(tmp_pdf) > 0) {
    fs::rename(tmp_pdf, pdf);
    result.pdf = pdf;
    fs::remove(log, ec);
  } else {
    fs::remove(tmp_pdf, ec);
    result.pdf_note = fmt::format("warning: Chromium ({}) could not print the PDF (exit {}; see "
                                  "{}); report.html is complete",
                                  chromium.string(), status, log.string());
  }
}

}  // namespace

std::string_view to_string(PaperSize paper) { return paper == PaperSize::Letter ? "letter" : "A4"; }

std::optional<PaperSize> parse_paper_size(std::string_view name) {
  if (name == "A4") return PaperSize::A4;
  if (name == "letter") return PaperSize::Letter;
  return std::nullopt;
}

ReportResult write_case_report(const CaseFolder& folder, const ReportOptions& o) {
  ReportInputs r;
  r.root = folder.root();
  const fs::path& root = r.root;
  r.case_json = read_json_or_null(root / "case.json");
  if (r.case_json.is_null()) throw_input_error(root / "case.json", "missing or not JSON");
  const TriangleMesh mesh = folder.load_mesh();
  const Raycaster rc(mesh);
  r.trajectory = read_tum_trajectory(root / "alignment" / "trajectory.txt");
  r.markers = read_markers(root / "evidence" / "markers.json");
  r.metadata = read_case_metadata(folder);
  r.analyses = read_trajectory_analyses(root / "trajectories" / "analyses.json");
  const Vector3d up = report_up(r);

  std::string h = report_opening(r, o);
  h += summary_section(r);
  const TopView top = render_top_view(mesh, rc, up, o.render_width, o.render_width * 3 / 4);
  const std::string top_uri = png_data_uri(top.image);  // drawn on by every plan below
  h += views_section(mesh, rc, up, top_uri, r.trajectory, o);
  h += stage_errors_section(r);
  h += trajectory_plot_section(r, top, top_uri);
  h += coverage_section(root, top, top_uri);
  h += table_one_section(root);
  h += floor_plan_section(root, top, top_uri);
  h += evidence_section(r.markers);
  h += trajectories_section(r.analyses);
  h += simulations_section(root);
  h += parameters_section(r.case_json);
  h += log_section(root);
  h += hashes_section(r);
  h += "</body></html>\n";

  ReportResult result;
  result.html = folder.path("report/report.html");
  {
    AtomicFile f(result.html, false);
    f.stream() << h;
    f.commit();
  }
  if (!o.pdf) {
    result.pdf_note = "PDF not requested";
    fs::remove(root / "report" / "report.pdf");
    return result;
  }
  print_pdf(root, result);
  return result;
}

}  // namespace locard::forensics

namespace locard::forensics {

ReportResult refresh_case_report(CaseFolder& folder) {
  const auto t0 = std::chrono::steady_clock::now();
  const json case_json = read_json_or_null(folder.root() / "case.json");
  ReportOptions o;
  if (!case_json.is_null()) {
    o.title = case_json.value("title", "");
    const json p = case_json.value("parameters", json::object());
    o.render_width = p.value("render_width", o.render_width);
    o.render_height = p.value("render_height", o.render_height);
    o.pdf = p.value("pdf", o.pdf);
    o.paper = parse_paper_size(p.value("paper", std::string(to_string(o.paper)))).value_or(o.paper);
  }
  CaseChange change(folder, {"report/report.html", "report/report.pdf"});
  const bool had_pdf = fs::exists(folder.root() / "report" / "report.pdf");
  const ReportResult r = write_case_report(folder, o);
  LogStep s;
  s.step = "report";
  s.parameters_json = json{{"pdf", o.pdf}, {"pdf_note", r.pdf_note}}.dump();
  s.duration_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s.outputs = {"report/report.html"};
  if (r.pdf) s.outputs.push_back("report/report.pdf");
  if (had_pdf && !fs::exists(folder.root() / "report" / "report.pdf"))
    s.removed.push_back("report/report.pdf");  // pdf no longer requested
  change.commit(s);
  return r;
}

}  // namespace locard::forensics
