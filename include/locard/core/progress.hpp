#pragma once
// Progress for long work. Library functions take an optional ProgressCallback; the CLI turns
// it into a bar on a terminal. A bar is drawn only on a TTY and never under --quiet, so CI
// logs stay clean.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <mutex>
#include <string>

namespace locard {

// Called with (done, total); may be called from worker threads.
using ProgressCallback = std::function<void(std::size_t done, std::size_t total)>;

class ProgressBar {
 public:
  // enabled=false makes every call a no-op.
  ProgressBar(std::string label, std::size_t total, bool enabled);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void advance(std::size_t n = 1);  // thread-safe
  void finish();
  ProgressCallback callback();       // forwards (done, total) to this bar

  // True when stderr is a terminal and `quiet` is false.
  static bool should_show(bool quiet);

 private:
  void draw(std::size_t done, bool final);

  std::string label_;
  std::atomic<std::size_t> total_;
  bool enabled_;
  std::atomic<std::size_t> done_{0};
  std::mutex mutex_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  bool finished_ = false;
};

}  // namespace locard
