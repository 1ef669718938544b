#include <locard/core/progress.hpp>

#include <cstdio>
#include <unistd.h>

namespace locard {

ProgressBar::ProgressBar(std::string label, std::size_t total, bool enabled)
    : label_(std::move(label)), total_(total), enabled_(enabled),
      start_(std::chrono::steady_clock::now()), last_draw_() {}

ProgressBar::~ProgressBar() { finish(); }

bool ProgressBar::should_show(bool quiet) { return !quiet && ::isatty(STDERR_FILENO) == 1; }

void ProgressBar::advance(std::size_t n) {
  const std::size_t done = done_.fetch_add(n) + n;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  std::unique_lock lock(mutex_, std::try_to_lock);
  // Redraw at most ~10 times a second; a busy worker never waits for the terminal.
  if (!lock.owns_lock() || finished_ || now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  draw(done, false);
}

void ProgressBar::finish() {
  if (!enabled_) return;
  std::lock_guard lock(mutex_);
  if (finished_) return;
  finished_ = true;
  draw(done_.load(), true);
}

ProgressCallback ProgressBar::callback() {
  return [this](std::size_t done, std::size_t total) {
    total_.store(total);
    const std::size_t before = done_.load();
    if (done > before) advance(done - before);
  };
}

void ProgressBar::draw(std::size_t done, bool final) {
  constexpr int kWidth = 30;
  const std::size_t total = total_.load();
  const double fraction = total ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
  const int filled = static_cast<int>(fraction * kWidth);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(kWidth, '.');
  std::fprintf(stderr, "\r%-18s [%s] %zu/%zu %5.1fs%s", label_.c_str(), bar.c_str(), done, total,
               seconds, final ? "\n" : "");
  std::fflush(stderr);
}

}  // namespace locard
