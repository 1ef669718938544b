#pragma once
// Writes an output file so that it either appears complete or not at all: data goes to a
// temporary file in the same folder, which is renamed over the target only on commit().
// If the writer throws before commit(), the destructor removes the temporary file.

#include <filesystem>
#include <fstream>

namespace locard {

class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path target, bool binary = true);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ofstream& stream() { return stream_; }
  const std::filesystem::path& temp_path() const { return temp_; }
  // Flushes, checks and closes the temporary file without renaming it: a writer of several
  // files finishes them all (where a full disk shows) before any replaces its target.
  // Throws locard::Error on failure.
  void finish();
  // finish() if not done, then renames over the target. Throws locard::Error on failure.
  void commit();

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  std::ofstream stream_;
  bool finished_ = false;
  bool committed_ = false;
};

}  // namespace locard
