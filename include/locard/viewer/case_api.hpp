#pragma once
// The viewer's JSON API over one case folder, apart from HTTP so it can be tested directly.
// Coordinates in every request and answer are in the case's world frame (z up, metres; see
// docs/case-format.md), not the y-up frame of the glTF files the browser draws; markers also
// carry "local", their case-frame coordinates, and GET /api/markers the frame itself, so the
// viewer shows what `marker list` and the report print.
//
//   GET  /api/case        case.json plus what the viewer can show: mesh, cloud, inferred
//                         triangles, segments, simulations, counts
//   GET  /api/points      the registered cloud, decimated to at most ?max= points (default
//                         1,000,000), as one binary buffer (see points() below)
//   POST /api/measure     {"a": [x,y,z], "b": [x,y,z], "name"?, "save"?} -> points snapped to
//                         the surface, distance and its uncertainty (the forensics library's
//                         measurement); saved to measurements/measurements.json through the
//                         integrity log unless "save": false
//   GET  /api/markers     the case's evidence markers and case frame (withdrawn ones too,
//                         with "withdrawn": {"reason", "at"}; "previous_names" when renamed)
//   POST /api/markers     {"position": [x,y,z], "label": "...", "note": "..."} -> the marker,
//                         numbered and saved through the case's integrity log
//   POST /api/trajectory  {"a": [x,y,z], "b": [x,y,z]} -> line, angles, surface hits of its
//                         extension, error cone; saved through the integrity log
//   GET  /api/measurements  the saved measurements (CLI and viewer), with their revisions
//   GET  /api/trajectories  the saved trajectory analyses, with their revisions
//   POST /api/evidence/rename    {"kind": "marker"|"measurement"|"trajectory", "which": "...",
//                                "name": "..."} -> renamed as a logged step (case_edits.hpp)
//   POST /api/evidence/withdraw  {"kind", "which", "reason"} -> withdrawn as a logged step
// Bad requests (malformed JSON, a missing or non-finite coordinate) get 400 with
// {"error": "..."}; a case without what a request needs gets 404.

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace locard::viewer {

struct ApiResponse {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
};

class CaseApi {
 public:
  // Throws InputError when `case_dir` is not a folder.
  explicit CaseApi(std::filesystem::path case_dir);
  ~CaseApi();
  CaseApi(const CaseApi&) = delete;
  CaseApi& operator=(const CaseApi&) = delete;

  const std::filesystem::path& case_dir() const;

  // The file a request path names below the case folder, or nullopt when the path is empty,
  // absolute, has a ".." or "." component, a backslash or NUL, or resolves (through symbolic
  // links) outside the case folder, or is not a regular file.
  std::optional<std::filesystem::path> resolve_case_file(std::string_view relative) const;

  // Dispatches one API call: method "GET" or "POST", path "/api/...", query parameter `max`
  // (for /api/points; 0 = default), request body. Unknown routes give 404.
  ApiResponse handle(std::string_view method, std::string_view path, std::string_view body,
                     std::size_t max_points = 0);

  ApiResponse case_summary();
  // Binary, little-endian: "LCPT" magic, uint32 count n, uint32 flags (bit 0: segment labels
  // present), uint32 total points in the file; float32 xyz * n; uint8 rgb * n, zero-padded to
  // a multiple of 4 bytes; int32 segment label * n when flagged (-1: none). Points are taken
  // at a fixed stride, so the same file always gives the same subset.
  ApiResponse points(std::size_t max_points);
  ApiResponse measure(std::string_view body);
  ApiResponse markers();
  ApiResponse add_marker(std::string_view body);
  ApiResponse trajectory(std::string_view body);
  ApiResponse measurements();
  ApiResponse trajectories();
  ApiResponse edit(std::string_view body, bool withdraw);

  // Rewrites report/report.html (and the PDF) with the options recorded in case.json and logs a
  // "report" step: what the CLI does last after adding to a case. Throws like
  // forensics::refresh_case_report.
  void refresh_report();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locard::viewer
