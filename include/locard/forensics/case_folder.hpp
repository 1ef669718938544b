#pragma once
// A case folder (docs/case-format.md): the one place everything about a reconstruction lives.
// This is the library code every command that changes a case goes through (reconstruct,
// measure, marker, trajectory, simulate, the viewer's saves). A change is a transaction:
//
//   CaseFolder c = CaseFolder::open(dir, CaseAccess::Change);  // lock, then verify: refuses
//                                                              // a case that does not verify
//   LogStep s; s.step = "marker add"; s.parameters_json = R"({"label":"A"})";
//   s.outputs = {"evidence/markers.json", "evidence/markers.csv"};
//   CaseChange change(c, s.outputs);       // the current versions are kept aside
//   ... write c.path("evidence/markers.json") (through AtomicFile) ...
//   change.commit(s);  // hashes the outputs, appends to log.jsonl, writes manifest.json
//                      // (from the log); anything thrown before puts every file back
//
// Integrity (verify_case): the log is the record. Each line's prev_sha256 is the SHA-256 of
// the line before it ("" for the first); every output a step recorded must exist with the
// hash its last step logged; files no step recorded are reported as added; manifest.json is
// written from the log (never from the disk) and must agree with it and with the log head;
// a command that began (phase "begin") and did not complete leaves the case incomplete; each
// input recorded in case.json is re-hashed at its recorded path, and files that appeared in
// the input folder since ingestion are reported.

#include <locard/core/error.hpp>
#include <locard/core/point_cloud.hpp>
#include <locard/core/triangle_mesh.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace locard::forensics {

class CaseLock;

struct FileRecord {
  std::string path;  // relative to the case root (outputs) or as given (inputs)
  std::uintmax_t bytes = 0;
  std::string sha256;
};

// Where a step stands in a command of several steps (reconstruct): "begin" is logged before
// anything else, "complete" after the last step, "failed" (with the error) when it stopped.
// verify_case reports a case whose last "begin" has no "complete" after it as incomplete.
enum class StepPhase { Single, Begin, Complete, Failed };
std::string_view to_string(StepPhase phase);

// One processing step as it goes into log.jsonl.
struct LogStep {
  std::string step;                   // "reconstruct/align", "measure", "marker add", ...
  StepPhase phase = StepPhase::Single;  // written as "phase" unless Single
  std::string parameters_json = "{}";  // a JSON object (text) with every parameter used
  double duration_s = 0.0;
  // Inputs: case-relative paths, or absolute paths outside the case (original data).
  std::vector<std::filesystem::path> inputs;
  // Outputs: case-relative paths of files this step wrote (hashed when the step is appended).
  std::vector<std::filesystem::path> outputs;
  // Recorded outputs of earlier steps that this step deleted (written as "removed"): the
  // record of the case no longer holds them.
  std::vector<std::filesystem::path> removed;
};

// What a command means to do with a case it opens.
enum class CaseAccess {
  Read,    // look only: append_log_step is refused
  Change,  // add steps: the case folder must verify first (CaseNotIntact otherwise)
};

struct VerifyProblem {
  enum class Kind {
    Changed,       // a recorded file's bytes differ from its logged hash
    Missing,       // a recorded file is gone
    Added,         // a file on disk that no step recorded
    LogChain,      // the log's chain, order or head
    InputChanged,
    InputMissing,
    InputAdded,    // a file in the input folder that was not there at ingestion
    Manifest,      // manifest.json disagrees with the log
    Incomplete,    // a command began and did not complete (killed, or failed)
    Anchor,        // a signature or time stamp that does not hold
  };
  Kind kind;
  std::string path;    // case-relative, or the input's original path
  std::string detail;  // expected vs found
};
std::string_view to_string(VerifyProblem::Kind kind);

// A command that changes a case refused to, because the case does not verify: writing on
// would bury the finding under a fresh, consistent manifest. The CLI exits with
// kExitCaseNotIntact; the viewer answers 409.
class CaseNotIntact : public Error {
 public:
  CaseNotIntact(const std::filesystem::path& root, std::vector<VerifyProblem> problems);
  const std::vector<VerifyProblem>& problems() const { return problems_; }

 private:
  std::vector<VerifyProblem> problems_;
};

// Exit codes of the case commands (besides 0, 1 a mismatch or an internal error, 2 bad input,
// 4 kExitTooFewVerified): `verify` exits 3 when the only finding is an incomplete case; a
// command that changes a case exits 5 when it refused a case that does not verify.
inline constexpr int kExitCaseIncomplete = 3;
inline constexpr int kExitCaseNotIntact = 5;

class CaseFolder {
 public:
  // A new case: creates `root`. Throws InputError when `root` is a file, or a folder that is
  // not empty and `force` is false (a case is never written over without --force). With
  // force, the previous contents are removed first (only once all inputs were checked by the
  // caller: call this after validating, before writing) - and only when the old case verifies
  // (or is merely incomplete): a tampered case is evidence, CaseNotIntact otherwise.
  static CaseFolder create(const std::filesystem::path& root, bool force);
  // An existing case: throws InputError unless `root` holds manifest.json. With
  // CaseAccess::Change the case folder is verified (its original inputs are not re-hashed:
  // no command changes them) and CaseNotIntact thrown when it does not verify.
  // Both hold the case exclusively (case_lock.hpp) for as long as the CaseFolder, or a copy
  // of it, lives: one writer at a time, across processes and threads.
  static CaseFolder open(const std::filesystem::path& root, CaseAccess access);

  const std::filesystem::path& root() const { return root_; }
  // root / relative, with the parent folders created.
  std::filesystem::path path(const std::filesystem::path& relative) const;

  // Appends one line to log.jsonl ({"seq","time","step","phase","parameters","duration_s",
  // "inputs","outputs","prev_sha256"}), with the SHA-256 of every input and output computed
  // now, and writes manifest.json from the log's recorded outputs. Both new files are written
  // in full before either replaces the old one, and the old log is put back if the manifest
  // cannot be: a full disk leaves the case as it was. Throws InputError when an output does
  // not exist or parameters_json is not a JSON object, Error when the folder was opened for
  // reading. Returns the line's sequence number.
  std::size_t append_log_step(const LogStep& step);

  // The model as the case holds it: mesh/mesh.ply (z-up metres) and cloud/registered.ply.
  TriangleMesh load_mesh() const;
  PointCloud load_cloud() const;
  // case.json as text (JSON object).
  std::string case_json_text() const;

 private:
  CaseFolder(std::filesystem::path root, std::shared_ptr<CaseLock> lock, CaseAccess access)
      : root_(std::move(root)), lock_(std::move(lock)), access_(access) {}
  std::filesystem::path root_;
  std::shared_ptr<CaseLock> lock_;
  CaseAccess access_;
};

// One step's change to a case, all or nothing. The constructor keeps the current version of
// each file the step may write (a hard link in .locard-undo/, so no space is needed); commit()
// appends the step (append_log_step) and drops them. If the step throws before its commit
// finished - a full disk, a bad point, anything - the destructor puts every kept file back and
// removes the ones the step created, so no output is left that the log does not record.
class CaseChange {
 public:
  CaseChange(CaseFolder& folder, std::vector<std::filesystem::path> may_write);
  ~CaseChange();
  CaseChange(const CaseChange&) = delete;
  CaseChange& operator=(const CaseChange&) = delete;
  std::size_t commit(const LogStep& step);

 private:
  void roll_back() noexcept;
  void write_undo_journal();
  CaseFolder& folder_;
  std::vector<std::filesystem::path> paths_;  // case-relative
  std::vector<bool> existed_;
  std::filesystem::path undo_;
  bool committed_ = false;
};


// Undoes what a command killed in the middle of a CaseChange (kill -9, power loss) had begun to
// write, from the journal it left in .locard-undo/: its files go back to their logged versions
// (or the step's log line is already there, and only the kept copies go). Call under the case's
// lock; CaseFolder::open(Change) does, before it verifies. Returns the case-relative paths put back.
std::vector<std::string> recover_interrupted_changes(const std::filesystem::path& root);

struct VerifyReport {
  std::size_t files_checked = 0;
  std::size_t inputs_checked = 0;
  std::size_t log_lines = 0;
  std::string log_head_sha256;  // of the log's last line; empty for an empty log
  std::vector<VerifyProblem> problems;
  bool ok() const { return problems.empty(); }
  // Nothing but an incomplete command was found (verify exits kExitCaseIncomplete).
  bool only_incomplete() const;
};

// Re-hashes the case (see the header comment). check_inputs=false skips the original inputs
// (e.g. on a machine that only received the case folder). Throws InputError when the folder
// is not a case or manifest.json / case.json / log.jsonl cannot be parsed at all.
VerifyReport verify_case(const std::filesystem::path& root, bool check_inputs = true);

// The SHA-256 of the last line of the case's log.jsonl (empty when it has none): the anchor
// every command that changes a case prints, and `verify --expect-head` checks (a head
// written down earlier pins every step up to it, as each line hashes the one before).
std::string log_head_sha256(const std::filesystem::path& root);
// The 0-based number of the log line whose SHA-256 is `sha256_hex`; none when no line is.
// A head printed earlier is found unless the steps up to it were rewritten or removed.
std::optional<std::size_t> find_log_line(const std::filesystem::path& root,
                                         const std::string& sha256_hex);

// Every regular file under `folder`, relative, sorted, '/'-separated.
std::vector<std::string> list_files_recursive(const std::filesystem::path& folder);

}  // namespace locard::forensics
