// CaseLock (case_lock.hpp): a recursive mutex per case for the threads of this process, and
// one flock on the case directory while any thread of this process holds the case.
#include "forensics/case_lock.hpp"

#include <locard/core/error.hpp>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <map>
#include <mutex>
#include <thread>

namespace locard::forensics {
namespace {

struct Held {
  std::recursive_timed_mutex threads;
  int fd = -1;          // the directory, flocked while depth > 0
  std::size_t depth = 0;  // acquisitions not yet released, all threads (only the owner's)
};

std::mutex registry_mutex;
std::map<std::filesystem::path, Held>& registry() {
  static std::map<std::filesystem::path, Held> held;  // never shrinks: a few cases a run
  return held;
}

std::filesystem::path key_of(const std::filesystem::path& root) {
  std::error_code ec;
  const std::filesystem::path canonical = std::filesystem::canonical(root, ec);
  return ec ? root.lexically_normal() : canonical;
}

}  // namespace

std::shared_ptr<CaseLock> CaseLock::acquire(const std::filesystem::path& root,
                                            std::chrono::milliseconds wait) {
  const std::filesystem::path key = key_of(root);
  Held* held = nullptr;
  {
    const std::lock_guard<std::mutex> guard(registry_mutex);
    held = &registry()[key];  // std::map: the address stays valid
  }
  const auto deadline = std::chrono::steady_clock::now() + wait;
  if (!held->threads.try_lock_until(deadline))
    throw_input_error(root, "the case is held by another command of this process; try again");
  if (held->depth++ == 0) {
    held->fd = ::open(key.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    bool locked = held->fd >= 0 && ::flock(held->fd, LOCK_EX | LOCK_NB) == 0;
    while (held->fd >= 0 && !locked && errno == EWOULDBLOCK &&
           std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      locked = ::flock(held->fd, LOCK_EX | LOCK_NB) == 0;
    }
    if (!locked) {
      const std::string why = held->fd < 0 ? std::strerror(errno)
                                           : "another command (a CLI run or the viewer) holds it";
      if (held->fd >= 0) ::close(held->fd);
      held->fd = -1;
      held->depth = 0;
      held->threads.unlock();
      throw_input_error(root, "cannot lock the case: " + why);
    }
  }
  return std::shared_ptr<CaseLock>(new CaseLock(key));
}

CaseLock::~CaseLock() {
  Held* held = nullptr;
  {
    const std::lock_guard<std::mutex> guard(registry_mutex);
    held = &registry()[key_];
  }
  if (--held->depth == 0) {
    ::flock(held->fd, LOCK_UN);
    ::close(held->fd);
    held->fd = -1;
  }
  held->threads.unlock();
}

}  // namespace locard::forensics
