#include "io/text_lines.hpp"

#include <locard/core/error.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>

namespace locard::io_detail {
namespace {

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

std::string format_time(double t) {
  std::ostringstream out;
  out.precision(17);
  out << t;
  return out.str();
}

}  // namespace

std::vector<std::string_view> split_tokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

std::optional<double> parse_number(std::string_view token) {
  // from_chars rejects a leading '+', which some writers emit.
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size() || !std::isfinite(value))
    return std::nullopt;
  return value;
}

std::optional<std::int64_t> parse_integer(std::string_view token) {
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

void require_regular_file(const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || status.type() == fs::file_type::not_found) throw_input_error(path, "no such file");
  if (status.type() == fs::file_type::directory)
    throw_input_error(path, "is a folder, not a file");
  if (status.type() != fs::file_type::regular)
    throw_input_error(path, "is not a regular file (a pipe, socket or device): refused, as "
                            "reading it could block or never end");
}

std::size_t readable_file_size(const std::filesystem::path& path) {
  require_regular_file(path);
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw_input_error(path, "cannot read file size: " + ec.message());
  return static_cast<std::size_t>(size);
}

void read_exact(const std::filesystem::path& path, char* data, std::size_t size) {
  std::ifstream in(path, std::ios::binary);  // read-only
  if (!in) throw_input_error(path, "cannot open for reading");
  in.read(data, static_cast<std::streamsize>(size));
  if (static_cast<std::size_t>(in.gcount()) != size) throw_input_error(path, "read failed");
}

DataLines::DataLines(const std::filesystem::path& path, bool numeric_data)
    : path_(path), text_(read_text_file(path)), in_header_(numeric_data) {}

bool DataLines::next(std::vector<std::string_view>& tokens) {
  while (pos_ < text_.size()) {
    std::size_t end = text_.find('\n', pos_);
    if (end == std::string::npos) end = text_.size();
    const std::string_view line(text_.data() + pos_, end - pos_);
    pos_ = end + 1;
    ++line_number_;
    tokens = split_tokens(line);
    if (tokens.empty() || tokens.front().front() == '#') continue;
    if (in_header_ && !parse_number(tokens.front())) continue;
    in_header_ = false;
    return true;
  }
  return false;
}

void DataLines::fail(const std::string& what) const {
  throw_input_error(path_, what, line_number_);
}

void TimeOrderCheck::check(const DataLines& lines, double timestamp) {
  if (previous_ && !(timestamp > *previous_))
    lines.fail("timestamp " + format_time(timestamp) + " is not after " + format_time(*previous_) +
               " on line " + std::to_string(previous_line_) +
               "; timestamps must increase line by line");
  previous_ = timestamp;
  previous_line_ = lines.line_number();
}

std::optional<std::size_t> nearest_within(const std::vector<double>& times, double t,
                                          double tolerance) {
  if (times.empty()) return std::nullopt;
  const auto it = std::lower_bound(times.begin(), times.end(), t);
  std::size_t best = static_cast<std::size_t>(it - times.begin());
  if (best == times.size() || (best > 0 && t - times[best - 1] <= times[best] - t)) --best;
  if (std::abs(times[best] - t) > tolerance) return std::nullopt;
  return best;
}

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace locard::io_detail
