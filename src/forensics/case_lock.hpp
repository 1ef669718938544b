#pragma once
// The exclusive lock a CaseFolder holds on its case for as long as it lives (case_folder.hpp).
//
// Every command that changes a case reads it, writes files and appends a log step; two at
// once (the viewer's POST /api/markers and a CLI `marker add`) read the same markers.json and
// the later write drops the earlier marker - 24 of 37 markers were kept in a test. So a case
// is held by one writer at a time:
//   - across processes, flock(LOCK_EX) on the case directory itself (no lock file: a file in
//     the case would be one more thing for the manifest and `verify` to explain);
//   - across threads of one process (the viewer answers requests on a pool), a mutex per case;
//   - re-entrant within a thread: a command holding the case may open it again (a report
//     refresh, a verify before writing) without deadlocking against itself.
// A lock not obtained within `wait` (another command holds the case) is an InputError naming
// the case.
#include <chrono>
#include <filesystem>
#include <memory>

namespace locard::forensics {

class CaseLock {
 public:
  static std::shared_ptr<CaseLock> acquire(const std::filesystem::path& root,
                                           std::chrono::milliseconds wait = std::chrono::minutes(2));
  ~CaseLock();
  CaseLock(const CaseLock&) = delete;
  CaseLock& operator=(const CaseLock&) = delete;

 private:
  explicit CaseLock(std::filesystem::path key) : key_(std::move(key)) {}
  std::filesystem::path key_;
};

}  // namespace locard::forensics
