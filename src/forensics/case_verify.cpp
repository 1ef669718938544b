// verify_case (case_folder.hpp): the log is the record of a case. Each check below is one
// question a court expert would ask of it, in the order the report lists the answers.
#include <locard/forensics/case_folder.hpp>

#include "forensics/case_log.hpp"

#include <locard/core/error.hpp>
#include <locard/forensics/integrity.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <map>
#include <set>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace detail;
using Kind = VerifyProblem::Kind;

// The last record of one output: its hash and the step that wrote it.
struct Recorded {
  std::string sha256;
  std::uintmax_t bytes = 0;
  std::size_t line = 0;  // 1-based
  std::string step;
};

// A command whose "begin" line has no "complete" after it.
struct OpenCommand {
  std::string step;
  std::size_t begin_line = 0;  // 1-based
  std::string begin_time;
  std::string failure;  // the error of a "failed" line, if one was logged
};

struct LogRecord {
  std::vector<std::string> lines;
  std::map<std::string, Recorded> outputs;
  std::map<std::string, OpenCommand> open;  // by step name
};

// Fields of a record that may have been edited by hand. A field is read only when it has the
// type the writer gives it; a wrong type reads as absent and is itself a finding (of `kind`, on
// `file`), so verify reports what it cannot read instead of throwing out of the check (the
// case fuzzer's first find: a log output with "bytes": "x" ended verify with a raw type_error).
class Fields {
 public:
  Fields(VerifyReport* report, Kind kind, std::string file, std::string where)
      : report_(report), kind_(kind), file_(std::move(file)), where_(std::move(where)) {}

  std::string text(const json& record, const char* key, std::string absent = "") const {
    const json* f = typed(record, key, &json::is_string, "a string");
    return f ? f->get<std::string>() : absent;
  }
  std::uintmax_t count(const json& record, const char* key) const {
    const json* f = typed(record, key, &json::is_number_unsigned, "a whole number");
    return f ? f->get<std::uintmax_t>() : 0;
  }
  json list(const json& record, const char* key) const {
    const json* f = typed(record, key, &json::is_array, "a list");
    return f ? *f : json::array();
  }
  json object(const json& record, const char* key) const {
    const json* f = typed(record, key, &json::is_object, "an object");
    return f ? *f : json::object();
  }

 private:
  const json* typed(const json& record, const char* key, bool (json::*is)() const noexcept,
                    const char* expected) const {
    if (!record.is_object()) return nullptr;
    const auto it = record.find(key);
    if (it == record.end()) return nullptr;
    if (((*it).*is)()) return &*it;
    if (report_)
      report_->problems.push_back({kind_, file_, fmt::format("{}: \"{}\" is {}, not {}", where_, key,
                                                             it->type_name(), expected)});
    return nullptr;
  }
  VerifyReport* report_;  // null: wrong types read as absent, unreported (already reported)
  Kind kind_;
  std::string file_, where_;
};

std::string line_name(const json& line, std::size_t number) {
  const Fields quiet(nullptr, Kind::LogChain, kLog, "");
  return fmt::format("line {} '{}' ({})", number, quiet.text(line, "step", "?"), quiet.text(line, "time", "?"));
}

// Tracks begin / complete / failed lines of multi-step commands.
void note_phase(const json& line, std::size_t number, LogRecord& log, VerifyReport& report) {
  const std::optional<StepPhase> phase = parse_phase(line);
  const Fields quiet(nullptr, Kind::LogChain, kLog, "");  // scan_log reported wrong types
  const std::string step = quiet.text(line, "step");
  if (!phase) {
    report.problems.push_back({Kind::LogChain, kLog,
                               fmt::format("line {}: unknown phase {}", number,
                                           line["phase"].dump())});
    return;
  }
  if (*phase == StepPhase::Begin) log.open[step] = {step, number, quiet.text(line, "time"), ""};
  if (*phase == StepPhase::Complete) log.open.erase(step);
  if (*phase == StepPhase::Failed && log.open.count(step))
    log.open[step].failure = quiet.text(quiet.object(line, "parameters"), "error");
}

// The hash chain, the order, the recorded outputs and the open commands.
LogRecord scan_log(const fs::path& root, VerifyReport& report) {
  LogRecord log;
  log.lines = log_lines(root);
  report.log_lines = log.lines.size();
  for (std::size_t i = 0; i < log.lines.size(); ++i) {
    json line;
    try {
      line = json::parse(log.lines[i]);
    } catch (const json::exception&) {
      report.problems.push_back({Kind::LogChain, kLog, fmt::format("line {} is not JSON", i + 1)});
      continue;
    }
    if (!line.is_object()) {
      report.problems.push_back({Kind::LogChain, kLog, fmt::format("line {} is not an object", i + 1)});
      continue;
    }
    const Fields fields(&report, Kind::LogChain, kLog, fmt::format("line {}", i + 1));
    const std::string prev = fields.text(line, "prev_sha256");
    (void)fields.text(line, "step");
    (void)fields.text(line, "time");
    const std::string expected = i == 0 ? std::string() : sha256_hex(log.lines[i - 1]);
    if (prev != expected)
      report.problems.push_back(
          {Kind::LogChain, kLog,
           fmt::format("line {}: prev_sha256 {} but the previous line hashes to {}", i + 1,
                       prev.empty() ? "(none)" : prev, expected.empty() ? "(none)" : expected)});
    if (!line.contains("seq") || !line["seq"].is_number_unsigned() || line["seq"].get<std::size_t>() != i)
      report.problems.push_back(
          {Kind::LogChain, kLog, fmt::format("line {}: seq {} out of order", i + 1,
                                             line.value("seq", json()).dump())});
    for (const json& o : fields.list(line, "outputs")) {
      const std::string path = fields.text(o, "path");
      if (!o.is_object() || path.empty()) {
        report.problems.push_back({Kind::LogChain, kLog, fmt::format("line {}: an output without a path: {}", i + 1, o.dump())});
        continue;
      }
      log.outputs[path] = {fields.text(o, "sha256"), fields.count(o, "bytes"), i + 1, fields.text(line, "step")};
    }
    for (const json& r : fields.list(line, "removed"))
      if (r.is_string()) log.outputs.erase(r.get<std::string>());
    note_phase(line, i + 1, log, report);
  }
  report.log_head_sha256 = log.lines.empty() ? std::string() : sha256_hex(log.lines.back());
  return log;
}

// Every output a step recorded is on disk with the hash it logged.
void check_outputs(const fs::path& root, const LogRecord& log, VerifyReport& report) {
  for (const auto& [rel, rec] : log.outputs) {
    ++report.files_checked;
    const fs::path full = root / rel;
    const std::string by = fmt::format("recorded by log line {} '{}'", rec.line, rec.step);
    if (!fs::is_regular_file(full)) {
      report.problems.push_back({Kind::Missing, rel, by + ", not on disk"});
      continue;
    }
    const std::string found = sha256_file(full);
    if (found != rec.sha256)
      report.problems.push_back(
          {Kind::Changed, rel,
           fmt::format("sha256 {} {}, {} found ({} bytes recorded, {} found)", rec.sha256, by,
                       found, rec.bytes, fs::file_size(full))});
  }
}

// manifest.json says what the log says: the same files at the same hashes, the log's head.
void check_manifest(const fs::path& root, const LogRecord& log, VerifyReport& report) {
  const json manifest = parse_json_file(root / kManifest);
  if (!manifest.is_object() || !manifest.contains("files") || !manifest["files"].is_object())
    throw_input_error(root / kManifest, "no \"files\" object");
  const json& files = manifest["files"];
  const Fields fields(&report, Kind::Manifest, kManifest, "manifest.json");
  for (const auto& [rel, entry] : files.items()) {
    const std::string listed = fields.text(entry, "sha256");
    if (rel == kLog) continue;
    const auto it = log.outputs.find(rel);
    if (it == log.outputs.end())
      report.problems.push_back({Kind::Manifest, rel, "listed in manifest.json, recorded by no step of the log"});
    else if (it->second.sha256 != listed)
      report.problems.push_back(
          {Kind::Manifest, rel,
           fmt::format("the log's last step recorded sha256 {}, manifest.json {}", it->second.sha256, listed)});
  }
  for (const auto& [rel, rec] : log.outputs)
    if (!files.contains(rel))
      report.problems.push_back({Kind::Manifest, rel,
                                 fmt::format("recorded by log line {}, not listed in manifest.json", rec.line)});
  ++report.files_checked;  // the log itself
  if (!files.contains(kLog) || !files[kLog].is_object()) {
    report.problems.push_back({Kind::Manifest, kLog, "not listed in manifest.json"});
  } else if (fs::is_regular_file(root / kLog)) {
    const std::string listed = fields.text(files[kLog], "sha256");
    const std::string found = sha256_file(root / kLog);
    if (found != listed)
      report.problems.push_back({Kind::Changed, kLog,
                                 fmt::format("sha256 {} in manifest.json, {} found", listed, found)});
  }
  const std::string head = report.log_head_sha256;
  const std::string recorded_head = fields.text(manifest, "log_head_sha256");
  if (recorded_head != head)
    report.problems.push_back(
        {Kind::LogChain, kLog,
         fmt::format("the log's last line hashes to {}, manifest.json records {} (lines "
                     "removed or added after the manifest)",
                     head, recorded_head)});
}

bool is_hex(std::string_view s, std::size_t n) {
  return s.size() == n && s.find_first_not_of("0123456789abcdef") == std::string_view::npos;
}

// anchors/ is outside the log (a signature cannot be in the log it signs), so what may be there
// is checked by name: `locard sign`'s signature-HEAD16-KEY8.json and `timestamp store`'s
// timestamp-HEAD16.tsr, HEAD16 the start of the hash of one of this log's lines. Whether an
// anchor holds takes the trusted key or TSA certificate (verify --public-key / --tsa-cert).
bool is_anchor_of_this_log(const std::string& name, const std::set<std::string>& line_prefixes) {
  std::string head;
  if (name.rfind("signature-", 0) == 0 && name.size() == 10 + 16 + 1 + 8 + 5 &&
      name.compare(name.size() - 5, 5, ".json") == 0 && name[26] == '-' &&
      is_hex(std::string_view(name).substr(27, 8), 8))
    head = name.substr(10, 16);
  else if (name.rfind("timestamp-", 0) == 0 && name.size() == 10 + 16 + 4 &&
           name.compare(name.size() - 4, 4, ".tsr") == 0)
    head = name.substr(10, 16);
  return is_hex(head, 16) && line_prefixes.count(head);
}

// Files on disk that no step recorded (planted, or left by a command that was interrupted).
void check_unrecorded(const fs::path& root, const LogRecord& log, VerifyReport& report) {
  const std::string anchors = std::string(kAnchors) + "/";
  std::set<std::string> line_prefixes;
  for (const std::string& line : log.lines) line_prefixes.insert(sha256_hex(line).substr(0, 16));
  for (const std::string& rel : list_files_recursive(root)) {
    if (rel == kManifest || rel == kLog) continue;
    if (rel.rfind(anchors, 0) == 0) {
      if (!is_anchor_of_this_log(rel.substr(anchors.size()), line_prefixes))
        report.problems.push_back({Kind::Added, rel, "in anchors/, not a signature or time stamp of "
                                                     "a line of this case's log"});
      continue;
    }
    if (rel.rfind(std::string(kUndo) + "/", 0) == 0) {
      report.problems.push_back({Kind::Incomplete, rel, "kept by a command that was interrupted while "
                                 "changing the case; the next command that changes it puts its "
                                 "files back (and logs that it did)"});
      continue;
    }
    if (!log.outputs.count(rel))
      report.problems.push_back({Kind::Added, rel, "on disk, recorded by no step of the log"});
  }
}

void check_complete(const LogRecord& log, VerifyReport& report) {
  if (log.open.empty() || log.lines.empty()) return;
  const json last = json::parse(log.lines.back(), nullptr, false);
  for (const auto& [step, c] : log.open) {
    std::string detail = fmt::format("INCOMPLETE: '{}' began at log line {} ({}) and did not complete; "
                                     "its last step is {}",
                                     step, c.begin_line, c.begin_time,
                                     last.is_object() ? line_name(last, log.lines.size()) : "unreadable");
    if (!c.failure.empty()) detail += fmt::format("; it failed: {}", c.failure);
    report.problems.push_back({Kind::Incomplete, kLog, detail});
  }
}

// Each recorded input at its recorded path (relative to the input root, or absolute for a
// frame a list named outside it), and files that appeared in the input folder since.
void check_inputs(const fs::path& root, VerifyReport& report) {
  const json case_json = parse_json_file(root / kCase);
  if (!case_json.is_object() || !case_json.contains("inputs") || !case_json["inputs"].is_object())
    return;
  const json& in = case_json["inputs"];
  const Fields fields(&report, Kind::InputChanged, kCase, "case.json inputs");
  const fs::path input_root = fields.text(in, "root");
  std::set<std::string> recorded;
  for (const json& f : fields.list(in, "files")) {
    ++report.inputs_checked;
    const std::string path = fields.text(f, "path");
    const fs::path p = input_root / path;  // an absolute path stays itself
    recorded.insert(fs::path(path).generic_string());
    if (path.empty() || !fs::is_regular_file(p)) {
      report.problems.push_back({Kind::InputMissing, p.string(), "recorded input not found"});
      continue;
    }
    const std::string found = sha256_file(p);
    const std::string logged = fields.text(f, "sha256");
    if (found != logged)
      report.problems.push_back({Kind::InputChanged, p.string(),
                                 fmt::format("sha256 {} at ingestion, {} now", logged, found)});
  }
  if (!fs::is_directory(input_root)) return;
  for (const std::string& rel : list_files_recursive(input_root))
    if (!recorded.count(rel))
      report.problems.push_back({Kind::InputAdded, (input_root / rel).string(),
                                 "in the input folder, not there when the case was made"});
}

}  // namespace

std::string_view to_string(VerifyProblem::Kind kind) {
  switch (kind) {
    case Kind::Changed: return "changed";
    case Kind::Missing: return "missing";
    case Kind::Added: return "added";
    case Kind::LogChain: return "log chain broken";
    case Kind::InputChanged: return "input changed";
    case Kind::InputMissing: return "input missing";
    case Kind::InputAdded: return "input added";
    case Kind::Manifest: return "manifest disagrees with log";
    case Kind::Incomplete: return "incomplete";
    case Kind::Anchor: return "anchor";
  }
  return "?";
}

bool VerifyReport::only_incomplete() const {
  if (problems.empty()) return false;
  for (const VerifyProblem& p : problems)
    if (p.kind != Kind::Incomplete) return false;
  return true;
}

std::string log_head_sha256(const fs::path& root) {
  const std::vector<std::string> lines = log_lines(root);
  return lines.empty() ? std::string() : sha256_hex(lines.back());
}

std::optional<std::size_t> find_log_line(const fs::path& root, const std::string& hex) {
  const std::vector<std::string> lines = log_lines(root);
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (sha256_hex(lines[i]) == hex) return i;
  return std::nullopt;
}

VerifyReport verify_case(const fs::path& root, bool check_inputs_too) {
  const CaseFolder folder = CaseFolder::open(root, CaseAccess::Read);
  VerifyReport report;
  const LogRecord log = scan_log(root, report);
  check_outputs(root, log, report);
  check_manifest(root, log, report);
  check_unrecorded(root, log, report);
  check_complete(log, report);
  if (check_inputs_too && fs::is_regular_file(root / kCase)) check_inputs(root, report);
  return report;
}

}  // namespace locard::forensics
