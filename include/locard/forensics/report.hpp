#pragma once
// The case report: one self-contained HTML page (every image inline: PNG as data: URIs, plots
// as inline SVG; no script, no network) and its PDF (headless Chromium --print-to-pdf).
// Sections: summary, rendered views of the model, the stage-error plot (paper Fig. 4), the
// trajectory top view, the Table-I measurement table with uncertainties, evidence markers,
// bullet-trajectory analyses, every parameter, every input and output hash, the log.

#include <locard/core/image.hpp>
#include <locard/core/triangle_mesh.hpp>

#include <Eigen/Core>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard {
class Raycaster;
}

namespace locard::forensics {

// The PDF's page (CSS @page size): "A4" (the default) or "letter".
enum class PaperSize { A4, Letter };
std::string_view to_string(PaperSize paper);
std::optional<PaperSize> parse_paper_size(std::string_view name);

class CaseFolder;

// Ray-cast view of a coloured mesh (Embree), headlight Lambert shading times vertex colour,
// white background. `eye` looks at `target`, `up` the world up, vertical field of view fov_deg.
ColorImage render_mesh_view(const TriangleMesh& mesh, const Raycaster& raycaster,
                            const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                            const Eigen::Vector3d& up, double fov_deg, int width, int height);
// PNG bytes (libpng) and a data: URI of them.
std::vector<std::uint8_t> encode_png(const ColorImage& image);
std::string png_data_uri(const ColorImage& image);

struct ReportOptions {
  std::string title;
  int render_width = 640;
  int render_height = 400;
  bool pdf = true;
  PaperSize paper = PaperSize::A4;  // CSS @page size
};

struct ReportResult {
  std::filesystem::path html;
  std::optional<std::filesystem::path> pdf;
  std::string pdf_note;  // why there is no PDF (no Chromium, Chromium failed)
};

// Reads everything from the case folder and writes report/report.html (and report.pdf).
// Does not log: the caller appends the step.
ReportResult write_case_report(const CaseFolder& folder, const ReportOptions& options);
// write_case_report with the options recorded in case.json, then a "report" step in the log
// (and the manifest rewritten). What commands that add to a case call last.
ReportResult refresh_case_report(CaseFolder& folder);

// The Chromium binary to use: $LOCARD_CHROMIUM, else chromium / chromium-browser /
// google-chrome on PATH or in /usr/bin; empty when there is none.
std::filesystem::path find_chromium();

}  // namespace locard::forensics
