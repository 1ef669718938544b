#pragma once
// A case folder (docs/case-format.md): the one place everything about a reconstruction lives.
// This is the library code every command that adds to a case goes through (reconstruct,
// measure, marker, trajectory, the viewer's saves): write your files, then
//
//   CaseFolder c = CaseFolder::open(dir);
//   ... write c.path("evidence/markers.json") (through AtomicFile) ...
//   LogStep s; s.step = "marker add"; s.parameters_json = R"({"label":"A"})";
//   s.outputs = {"evidence/markers.json", "evidence/markers.csv"};
//   c.append_log_step(s);   // hashes the outputs, appends to log.jsonl, rewrites manifest.json
//
// Integrity (verify_case): every file in manifest.json is re-hashed; files on disk that the
// manifest does not list are reported as added; the log's hash chain (each line's prev_sha256
// is the SHA-256 of the line before it, "" for the first) and the manifest's log_head_sha256
// must hold; each input recorded in case.json is re-hashed at its original path.

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

// One processing step as it goes into log.jsonl.
struct LogStep {
  std::string step;                   // "reconstruct/align", "measure", "marker add", ...
  std::string parameters_json = "{}";  // a JSON object (text) with every parameter used
  double duration_s = 0.0;
  // Inputs: case-relative paths, or absolute paths outside the case (original data).
  std::vector<std::filesystem::path> inputs;
  // Outputs: case-relative paths of files this step wrote (hashed when the step is appended).
  std::vector<std::filesystem::path> outputs;
};

class CaseFolder {
 public:
  // A new case: creates `root`. Throws InputError when `root` is a file, or a folder that is
  // not empty and `force` is false (a case is never written over without --force). With
  // force, the previous contents are removed first (only once all inputs were checked by the
  // caller: call this after validating, before writing).
  static CaseFolder create(const std::filesystem::path& root, bool force);
  // An existing case: throws InputError unless `root` holds case.json and manifest.json.
  // Both hold the case exclusively (case_lock.hpp) for as long as the CaseFolder, or a copy
  // of it, lives: one writer at a time, across processes and threads.
  static CaseFolder open(const std::filesystem::path& root);

  const std::filesystem::path& root() const { return root_; }
  // root / relative, with the parent folders created.
  std::filesystem::path path(const std::filesystem::path& relative) const;

  // Appends one line to log.jsonl ({"seq","time","step","parameters","duration_s","inputs",
  // "outputs","prev_sha256"}), with the SHA-256 of every input and output computed now, then
  // rewrites manifest.json. Throws InputError when an output does not exist or
  // parameters_json is not a JSON object. Returns the line's sequence number.
  std::size_t append_log_step(const LogStep& step);
  // Re-hashes every file in the case (except manifest.json) into manifest.json (atomic).
  void update_manifest();

  // The model as the case holds it: mesh/mesh.ply (z-up metres) and cloud/registered.ply.
  TriangleMesh load_mesh() const;
  PointCloud load_cloud() const;
  // case.json as text (JSON object).
  std::string case_json_text() const;

 private:
  CaseFolder(std::filesystem::path root, std::shared_ptr<CaseLock> lock)
      : root_(std::move(root)), lock_(std::move(lock)) {}
  std::filesystem::path root_;
  std::shared_ptr<CaseLock> lock_;
};

struct VerifyProblem {
  enum class Kind { Changed, Missing, Added, LogChain, InputChanged, InputMissing, Manifest };
  Kind kind;
  std::string path;    // case-relative, or the input's original path
  std::string detail;  // expected vs found
};
std::string_view to_string(VerifyProblem::Kind kind);

struct VerifyReport {
  std::size_t files_checked = 0;
  std::size_t inputs_checked = 0;
  std::size_t log_lines = 0;
  std::string log_head_sha256;  // of the log's last line; empty for an empty log
  std::vector<VerifyProblem> problems;
  bool ok() const { return problems.empty(); }
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
