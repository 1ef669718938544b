#pragma once
// Line-oriented text parsing shared by the trajectory, intrinsics and sequence readers.
// Internal to the library (not installed).

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard::io_detail {

// Whitespace-separated tokens (spaces, tabs, line breaks).
std::vector<std::string_view> split_tokens(std::string_view line);
// The whole token as a number; nullopt for anything else (including trailing characters).
std::optional<double> parse_number(std::string_view token);
std::optional<std::int64_t> parse_integer(std::string_view token);

// Every reader opens its files through these. Only a regular file (after links) is opened: a
// FIFO or a device named in a list would block the reader or feed it without end, a folder
// would fail later with a stranger message. InputError naming the path otherwise.
void require_regular_file(const std::filesystem::path& path);
// The one file reader: the whole file, bytes as they are, into a contiguous container of
// one-byte elements (std::string for text; byte vectors, any allocator, for binary formats);
// InputError naming the file when it cannot be read.
std::size_t readable_file_size(const std::filesystem::path& path);  // checks it is regular
void read_exact(const std::filesystem::path& path, char* data, std::size_t size);
template <typename Bytes>
Bytes read_file_into(const std::filesystem::path& path) {
  static_assert(sizeof(typename Bytes::value_type) == 1);
  Bytes data;
  data.resize(readable_file_size(path));
  read_exact(path, reinterpret_cast<char*>(data.data()), data.size());
  return data;
}
inline std::string read_whole_file(const std::filesystem::path& path) {
  return read_file_into<std::string>(path);
}
inline std::string read_text_file(const std::filesystem::path& path) { return read_whole_file(path); }

// Walks the data lines of a text table. Blank lines and '#' comments are skipped anywhere;
// before the first data line, a line whose first token is not a number is a header and is
// skipped too (the TUM lists in circulation lost the '#' of their column-name line). After
// that, every line is data and the caller reports what does not parse. With
// `numeric_data` false (lists of file names), only blanks and comments are skipped.
class DataLines {
 public:
  explicit DataLines(const std::filesystem::path& path, bool numeric_data = true);
  // Next data line's tokens; false at the end of the file.
  bool next(std::vector<std::string_view>& tokens);
  long line_number() const { return line_number_; }
  const std::filesystem::path& path() const { return path_; }
  [[noreturn]] void fail(const std::string& what) const;

 private:
  std::filesystem::path path_;
  std::string text_;
  std::size_t pos_ = 0;
  long line_number_ = 0;
  bool in_header_;
};

// Requires strictly increasing timestamps: association and evaluation assume time order.
class TimeOrderCheck {
 public:
  void check(const DataLines& lines, double timestamp);

 private:
  std::optional<double> previous_;
  long previous_line_ = 0;
};

// Index of the entry of the ascending `times` nearest to `t`, when within `tolerance`.
std::optional<std::size_t> nearest_within(const std::vector<double>& times, double t,
                                          double tolerance);

// Lower-cased extension including the dot (".png"), for case-insensitive matching.
std::string lower_extension(const std::filesystem::path& path);

}  // namespace locard::io_detail
