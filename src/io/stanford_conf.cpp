// Stanford range-scan .conf files. Each line is `camera` or `bmesh`/`mesh` followed by a
// translation and a quaternion (x, y, z, w). The quaternion's rotation is applied transposed
// (measured on the bunny scans, see the header), so T_world_scan = [R(q)^T | t].

#include <locard/core/error.hpp>
#include <locard/io/stanford_conf.hpp>

#include "io/text_lines.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <span>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (i < line.size()) {
    while (i < line.size() && space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !space(line[i])) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

// Parses the 7 numbers tx ty tz qx qy qz qw that end a line.
Isometry3d parse_pose(const fs::path& path, long line_no, std::span<const std::string_view> words) {
  if (words.size() != 7)
    throw_input_error(path, "expected 7 numbers (tx ty tz qx qy qz qw), found " +
                                std::to_string(words.size()), line_no);
  std::array<double, 7> v{};
  for (std::size_t i = 0; i < 7; ++i) {
    std::string_view w = words[i];
    if (!w.empty() && w.front() == '+') w.remove_prefix(1);
    const auto r = std::from_chars(w.data(), w.data() + w.size(), v[i]);
    if (r.ec != std::errc{} || r.ptr != w.data() + w.size() || !std::isfinite(v[i]))
      throw_input_error(path, "'" + std::string(words[i]) + "' is not a number", line_no);
  }
  const double norm = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
  if (norm < 1e-6) throw_input_error(path, "quaternion has zero length", line_no);
  Isometry3d T = isometry_from_translation_quaternion({v[0], v[1], v[2]}, v[3], v[4], v[5], v[6]);
  T.linear() = T.linear().transpose().eval();
  return T;
}

}  // namespace

StanfordConf read_stanford_conf(const fs::path& path) {
  io_detail::require_regular_file(path);
  std::ifstream in(path);  // read-only
  if (!in) throw_input_error(path, fs::exists(path) ? "cannot open for reading" : "no such file");
  StanfordConf conf;
  std::string line;
  long line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto words = split_words(line);
    if (words.empty() || words[0].starts_with('#')) continue;
    const std::string_view key = words[0];
    if (key == "camera") {
      if (conf.camera) throw_input_error(path, "second 'camera' line", line_no);
      conf.camera = parse_pose(path, line_no, std::span(words).subspan(1));
    } else if (key == "bmesh" || key == "mesh") {
      if (words.size() < 2) throw_input_error(path, "'" + std::string(key) + "' needs a file name", line_no);
      RangeScan scan;
      scan.name = std::string(words[1]);
      scan.file = path.parent_path() / scan.name;
      scan.T_world_scan = parse_pose(path, line_no, std::span(words).subspan(2));
      conf.scans.push_back(std::move(scan));
    } else {
      throw_input_error(path, "unknown keyword '" + std::string(key) +
                                  "' (expected camera, bmesh or mesh)", line_no);
    }
  }
  if (in.bad()) throw_input_error(path, "read failed");
  return conf;
}

}  // namespace locard
