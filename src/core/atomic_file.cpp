#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>

#include <atomic>
#include <system_error>
#include <unistd.h>

namespace locard {
namespace {
std::atomic<unsigned> g_counter{0};
}

AtomicFile::AtomicFile(std::filesystem::path target, bool binary) : target_(std::move(target)) {
  // Same folder as the target so the final rename never crosses file systems.
  temp_ = target_;
  temp_ += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(g_counter++);
  const auto parent = target_.parent_path();
  if (!parent.empty() && !std::filesystem::is_directory(parent))
    throw_input_error(target_, "output folder '" + parent.string() + "' does not exist");
  stream_.open(temp_, binary ? std::ios::binary | std::ios::out | std::ios::trunc
                             : std::ios::out | std::ios::trunc);
  if (!stream_) throw_input_error(target_, "cannot create file for writing");
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    stream_.close();
    std::error_code ec;
    std::filesystem::remove(temp_, ec);
  }
}

void AtomicFile::finish() {
  if (finished_) return;
  stream_.flush();
  if (!stream_) throw Error(target_.string() + ": write failed (disk full?)");
  stream_.close();
  if (!stream_) throw Error(target_.string() + ": write failed on close (disk full?)");
  finished_ = true;
}

void AtomicFile::commit() {
  finish();
  std::error_code ec;
  std::filesystem::rename(temp_, target_, ec);
  if (ec) throw Error(target_.string() + ": cannot move finished file into place: " + ec.message());
  committed_ = true;
}

}  // namespace locard
