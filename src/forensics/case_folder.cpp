#include <locard/forensics/case_folder.hpp>

#include "forensics/case_lock.hpp"
#include "forensics/json_util.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/forensics/integrity.hpp>
#include <locard/io/ply.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kManifest = "manifest.json";
constexpr const char* kLog = "log.jsonl";
constexpr const char* kCase = "case.json";

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw_input_error(path, "cannot be read");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Lines of log.jsonl without their '\n' (an empty file has none).
std::vector<std::string> log_lines(const fs::path& path) {
  std::vector<std::string> lines;
  if (!fs::exists(path)) return lines;
  std::ifstream in(path, std::ios::binary);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) lines.push_back(line);
  return lines;
}

FileRecord record(const fs::path& root, const fs::path& p) {
  const fs::path full = p.is_absolute() ? p : root / p;
  if (!fs::is_regular_file(full)) throw_input_error(full, "no such file to hash");
  FileRecord r;
  r.path = p.is_absolute() ? p.string() : p.generic_string();
  r.bytes = fs::file_size(full);
  r.sha256 = sha256_file(full);
  return r;
}

json record_json(const FileRecord& r) {
  return {{"path", r.path}, {"bytes", r.bytes}, {"sha256", r.sha256}};
}

json parse_json_file(const fs::path& path) {
  const std::string text = read_text(path);
  try {
    return json::parse(text);
  } catch (const json::exception& e) {  // syntax, and numbers out of range (1e400)
    throw_input_error(path, fmt::format("not valid JSON: {}", e.what()));
  }
}

}  // namespace

std::string utc_now_iso8601() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::vector<std::string> list_files_recursive(const fs::path& folder) {
  std::vector<std::string> out;
  if (!fs::is_directory(folder)) return out;
  for (const auto& entry : fs::recursive_directory_iterator(folder))
    if (entry.is_regular_file() || entry.is_symlink())
      out.push_back(fs::relative(entry.path(), folder).generic_string());
  std::sort(out.begin(), out.end());
  return out;
}

CaseFolder CaseFolder::create(const fs::path& root, bool force) {
  if (fs::exists(root) && !fs::is_directory(root))
    throw_input_error(root, "the case folder is a file; choose another path");
  if (fs::is_directory(root) && !fs::is_empty(root)) {
    if (!force)
      throw_input_error(root, "case folder is not empty; pass --force to replace it (a case is "
                              "never written over otherwise)");
    if (!fs::exists(root / kCase))
      throw_input_error(root, "folder is not empty and holds no case.json: it is not a Locard "
                              "case, so it is not replaced even with --force");
    // Held before anything is removed: a command still working on the old case finishes first.
    std::shared_ptr<CaseLock> lock = CaseLock::acquire(root);
    for (const auto& entry : fs::directory_iterator(root)) fs::remove_all(entry.path());
    return CaseFolder(root, std::move(lock));
  }
  fs::create_directories(root);
  return CaseFolder(root, CaseLock::acquire(root));
}

CaseFolder CaseFolder::open(const fs::path& root) {
  if (!fs::is_directory(root)) throw_input_error(root, "no such case folder");
  for (const char* name : {kCase, kManifest})
    if (!fs::is_regular_file(root / name))
      throw_input_error(root, fmt::format("not a Locard case folder: {} is missing", name));
  return CaseFolder(root, CaseLock::acquire(root));
}

fs::path CaseFolder::path(const fs::path& relative) const {
  const fs::path full = root_ / relative;
  fs::create_directories(full.parent_path());
  return full;
}

std::size_t CaseFolder::append_log_step(const LogStep& step) {
  json parameters;
  try {
    parameters = json::parse(step.parameters_json.empty() ? "{}" : step.parameters_json);
  } catch (const json::exception& e) {  // syntax, and numbers out of range (1e400)
    throw InputError(fmt::format("log step '{}': parameters are not valid JSON: {}", step.step,
                                 e.what()));
  }
  if (!parameters.is_object())
    throw InputError(fmt::format("log step '{}': parameters must be a JSON object", step.step));
  const fs::path log_path = root_ / kLog;
  const std::vector<std::string> lines = log_lines(log_path);
  json inputs = json::array(), outputs = json::array();
  for (const fs::path& p : step.inputs) inputs.push_back(record_json(record(root_, p)));
  for (const fs::path& p : step.outputs) {
    if (p.is_absolute()) throw InputError("log step outputs must be relative to the case folder");
    outputs.push_back(record_json(record(root_, p)));
  }
  const std::size_t seq = lines.size();
  json line = {{"seq", seq},
               {"time", utc_now_iso8601()},
               {"step", step.step},
               {"parameters", parameters},
               {"duration_s", step.duration_s},
               {"inputs", inputs},
               {"outputs", outputs},
               {"prev_sha256", lines.empty() ? std::string() : sha256_hex(lines.back())}};
  {
    std::ofstream out(log_path, std::ios::binary | std::ios::app);
    out << line.dump() << '\n';
    out.flush();
    if (!out) throw Error(fmt::format("{}: could not append to the log", log_path.string()));
  }
  update_manifest();
  return seq;
}

void CaseFolder::update_manifest() {
  json files = json::object();
  for (const std::string& rel : list_files_recursive(root_)) {
    if (rel == kManifest || rel.find(".tmp") != std::string::npos) continue;
    const FileRecord r = record(root_, rel);
    files[rel] = {{"bytes", r.bytes}, {"sha256", r.sha256}};
  }
  const std::vector<std::string> lines = log_lines(root_ / kLog);
  json manifest = {{"format", "locard-case-manifest/1"},
                   {"files", files},
                   {"log_lines", lines.size()},
                   {"log_head_sha256", lines.empty() ? std::string() : sha256_hex(lines.back())}};
  AtomicFile file(root_ / kManifest, false);
  file.stream() << manifest.dump(1) << '\n';
  file.commit();
}

TriangleMesh CaseFolder::load_mesh() const { return read_ply_mesh(root_ / "mesh" / "mesh.ply"); }
PointCloud CaseFolder::load_cloud() const { return read_ply(root_ / "cloud" / "registered.ply"); }
std::string CaseFolder::case_json_text() const { return read_text(root_ / kCase); }

std::string_view to_string(VerifyProblem::Kind kind) {
  switch (kind) {
    case VerifyProblem::Kind::Changed: return "changed";
    case VerifyProblem::Kind::Missing: return "missing";
    case VerifyProblem::Kind::Added: return "added";
    case VerifyProblem::Kind::LogChain: return "log chain broken";
    case VerifyProblem::Kind::InputChanged: return "input changed";
    case VerifyProblem::Kind::InputMissing: return "input missing";
    case VerifyProblem::Kind::Manifest: return "manifest disagrees with log";
  }
  return "?";
}

std::string log_head_sha256(const fs::path& root) {
  const std::vector<std::string> lines = log_lines(root / kLog);
  return lines.empty() ? std::string() : sha256_hex(lines.back());
}

std::optional<std::size_t> find_log_line(const fs::path& root, const std::string& hex) {
  const std::vector<std::string> lines = log_lines(root / kLog);
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (sha256_hex(lines[i]) == hex) return i;
  return std::nullopt;
}

VerifyReport verify_case(const fs::path& root, bool check_inputs) {
  const CaseFolder folder = CaseFolder::open(root);
  VerifyReport report;
  using Kind = VerifyProblem::Kind;
  const json manifest = parse_json_file(root / kManifest);
  if (!manifest.contains("files") || !manifest["files"].is_object())
    throw_input_error(root / kManifest, "no \"files\" object");
  std::map<std::string, std::string> manifest_hash;
  for (const auto& [rel, entry] : manifest["files"].items()) {
    ++report.files_checked;
    const std::string expected = entry.value("sha256", "");
    manifest_hash[rel] = expected;
    const fs::path full = root / rel;
    if (!fs::is_regular_file(full)) {
      report.problems.push_back({Kind::Missing, rel, "listed in manifest.json, not on disk"});
      continue;
    }
    const std::string found = sha256_file(full);
    if (found != expected)
      report.problems.push_back(
          {Kind::Changed, rel,
           fmt::format("sha256 {} recorded, {} found ({} bytes recorded, {} found)", expected,
                       found, entry.value("bytes", std::uintmax_t{0}), fs::file_size(full))});
  }
  for (const std::string& rel : list_files_recursive(root))
    if (rel != kManifest && !manifest_hash.count(rel))
      report.problems.push_back({Kind::Added, rel, "on disk, not in manifest.json"});

  // The log's hash chain, and the last logged hash of each output against the manifest.
  const std::vector<std::string> lines = log_lines(root / kLog);
  report.log_lines = lines.size();
  std::map<std::string, std::string> last_logged;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    json line;
    try {
      line = json::parse(lines[i]);
    } catch (const json::exception&) {
      report.problems.push_back({Kind::LogChain, kLog, fmt::format("line {} is not JSON", i + 1)});
      continue;
    }
    const std::string prev = line.value("prev_sha256", "");
    const std::string expected = i == 0 ? std::string() : sha256_hex(lines[i - 1]);
    if (prev != expected)
      report.problems.push_back(
          {Kind::LogChain, kLog,
           fmt::format("line {}: prev_sha256 {} but the previous line hashes to {}", i + 1,
                       prev.empty() ? "(none)" : prev, expected.empty() ? "(none)" : expected)});
    if (line.value("seq", std::size_t{0}) != i)
      report.problems.push_back(
          {Kind::LogChain, kLog, fmt::format("line {}: seq {} out of order", i + 1,
                                             line.value("seq", std::size_t{0}))});
    if (line.contains("outputs"))
      for (const json& o : line["outputs"]) last_logged[o.value("path", "")] = o.value("sha256", "");
  }
  const std::string head = lines.empty() ? std::string() : sha256_hex(lines.back());
  report.log_head_sha256 = head;
  if (manifest.value("log_head_sha256", "") != head)
    report.problems.push_back(
        {Kind::LogChain, kLog,
         fmt::format("the log's last line hashes to {}, manifest.json records {} (lines "
                     "removed or added after the manifest)",
                     head, manifest.value("log_head_sha256", ""))});
  for (const auto& [rel, logged] : last_logged) {
    const auto it = manifest_hash.find(rel);
    if (it != manifest_hash.end() && it->second != logged)
      report.problems.push_back(
          {Kind::Manifest, rel,
           fmt::format("the log's last step recorded sha256 {}, manifest.json {}", logged,
                       it->second)});
  }

  if (check_inputs) {
    const json case_json = parse_json_file(root / kCase);
    if (case_json.contains("inputs") && case_json["inputs"].contains("files")) {
      const fs::path input_root = case_json["inputs"].value("root", "");
      for (const json& f : case_json["inputs"]["files"]) {
        ++report.inputs_checked;
        const fs::path p = input_root / f.value("path", "");
        if (!fs::is_regular_file(p)) {
          report.problems.push_back({Kind::InputMissing, p.string(), "recorded input not found"});
          continue;
        }
        const std::string found = sha256_file(p);
        if (found != f.value("sha256", ""))
          report.problems.push_back({Kind::InputChanged, p.string(),
                                     fmt::format("sha256 {} at ingestion, {} now",
                                                 f.value("sha256", ""), found)});
      }
    }
  }
  return report;
}

}  // namespace locard::forensics
