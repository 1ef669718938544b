#include <locard/forensics/case_folder.hpp>

#include "forensics/case_lock.hpp"
#include "forensics/case_log.hpp"
#include "forensics/json_util.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/forensics/integrity.hpp>
#include <locard/io/ply.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <sstream>

namespace locard::forensics {

namespace detail {

namespace fs = std::filesystem;

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw_input_error(path, "cannot be read");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::string> split_log_lines(std::string_view text) {
  std::vector<std::string> lines;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    if (end > pos) lines.emplace_back(text.substr(pos, end - pos));
    pos = end + 1;
  }
  return lines;
}

std::vector<std::string> log_lines(const fs::path& root) {
  if (!fs::exists(root / kLog)) return {};
  return split_log_lines(read_text(root / kLog));
}

nlohmann::json parse_json_file(const fs::path& path) {
  const std::string text = read_text(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // syntax, and numbers out of range (1e400)
    throw_input_error(path, fmt::format("not valid JSON: {}", e.what()));
  }
}

std::optional<StepPhase> parse_phase(const nlohmann::json& line) {
  const auto it = line.find("phase");
  if (it == line.end()) return StepPhase::Single;
  if (!it->is_string()) return std::nullopt;
  for (StepPhase p : {StepPhase::Begin, StepPhase::Complete, StepPhase::Failed})
    if (it->get<std::string>() == to_string(p)) return p;
  return std::nullopt;
}

}  // namespace detail

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace detail;

std::atomic<unsigned> g_undo_counter{0};

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

json parse_parameters(const LogStep& step) {
  json parameters;
  try {
    parameters = json::parse(step.parameters_json.empty() ? "{}" : step.parameters_json);
  } catch (const json::exception& e) {  // syntax, and numbers out of range (1e400)
    throw InputError(fmt::format("log step '{}': parameters are not valid JSON: {}", step.step,
                                 e.what()));
  }
  if (!parameters.is_object())
    throw InputError(fmt::format("log step '{}': parameters must be a JSON object", step.step));
  return parameters;
}

// The manifest as the log records the case: each output at the hash its last step logged,
// and the log itself. Nothing is read from the disk, so a file deleted or planted since
// cannot be laundered into it by the next step.
json manifest_from_log(const fs::path& root, const std::string& log_text) {
  const std::vector<std::string> lines = split_log_lines(log_text);
  json files = json::object();
  for (std::size_t i = 0; i < lines.size(); ++i) {
    json line;
    try {
      line = json::parse(lines[i]);
    } catch (const json::exception&) {
      throw_input_error(root / kLog, fmt::format("line {} is not JSON: the case's record is "
                                                 "damaged; nothing was written",
                                                 i + 1));
    }
    try {  // verify, run before every change, reports wrong types; this only refuses them
      for (const json& o : line.value("outputs", json::array()))
        files[o.at("path").get<std::string>()] = {{"bytes", o.at("bytes").get<std::uintmax_t>()},
                                                  {"sha256", o.at("sha256").get<std::string>()}};
      for (const json& r : line.value("removed", json::array()))
        if (r.is_string()) files.erase(r.get<std::string>());
    } catch (const json::exception& e) {
      throw_input_error(root / kLog, fmt::format("line {}: an output record is malformed ({}): "
                                                 "the case's record is damaged; nothing was written",
                                                 i + 1, e.what()));
    }
  }
  files[kLog] = {{"bytes", log_text.size()}, {"sha256", sha256_hex(log_text)}};
  return {{"format", "locard-case-manifest/2"},
          {"source", "log"},
          {"files", files},
          {"log_lines", lines.size()},
          {"log_head_sha256", lines.empty() ? std::string() : sha256_hex(lines.back())}};
}

// Both files are written in full (where a full disk shows) before either replaces the old one;
// if the manifest's rename fails after the log's, the old log is put back.
void write_log_and_manifest(const fs::path& root, const std::string& log_text) {
  const std::string manifest = manifest_from_log(root, log_text).dump(1) + '\n';
  AtomicFile log_file(root / kLog, true);
  log_file.stream() << log_text;
  log_file.finish();
  AtomicFile manifest_file(root / kManifest, false);
  manifest_file.stream() << manifest;
  manifest_file.finish();
  const fs::path log_path = root / kLog;
  const fs::path kept = root / fmt::format("{}.old-{}", kLog, ::getpid());
  std::error_code ec;
  const bool had_log = fs::exists(log_path);
  if (had_log) fs::create_hard_link(log_path, kept);
  log_file.commit();
  try {
    manifest_file.commit();
  } catch (...) {
    if (had_log) fs::rename(kept, log_path, ec);
    else fs::remove(log_path, ec);
    throw;
  }
  if (had_log) fs::remove(kept, ec);
}

std::string describe(const std::vector<VerifyProblem>& problems) {
  std::string out;
  const std::size_t shown = std::min<std::size_t>(problems.size(), 5);
  for (std::size_t i = 0; i < shown; ++i)
    out += fmt::format("\n  {}: {} - {}", to_string(problems[i].kind), problems[i].path,
                       problems[i].detail);
  if (problems.size() > shown) out += fmt::format("\n  ... and {} more", problems.size() - shown);
  return out;
}

}  // namespace

std::string_view to_string(StepPhase phase) {
  switch (phase) {
    case StepPhase::Single: return "single";
    case StepPhase::Begin: return "begin";
    case StepPhase::Complete: return "complete";
    case StepPhase::Failed: return "failed";
  }
  return "?";
}

CaseNotIntact::CaseNotIntact(const fs::path& root, std::vector<VerifyProblem> problems)
    : Error(fmt::format("{}: the case does not verify, so it was not changed ({} finding(s); "
                        "`locard verify` reports them all):{}",
                        root.string(), problems.size(), describe(problems))),
      problems_(std::move(problems)) {}

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

namespace {

// A change another process began and never finished (its journal is still there, and we hold
// the case's lock, so that process is gone). If the log's head is still the one the journal
// recorded, its step was never logged: every file it may have written goes back to the kept
// version, or is removed if it did not exist. Otherwise the step was logged and only the kept
// copies are left to drop. Returns the paths put back.
std::vector<std::string> undo_one_interrupted(const fs::path& root, const fs::path& journal_file) {
  const fs::path kept = journal_file.parent_path() / journal_file.stem();
  std::vector<std::string> restored;
  json journal;
  try {
    journal = parse_json_file(journal_file);
  } catch (const InputError&) {
    journal = json();  // written atomically: unreadable only if edited by hand
  }
  const auto text = [&journal](const char* key) {
    const auto it = journal.is_object() ? journal.find(key) : journal.end();
    return it != journal.end() && it->is_string() ? it->get<std::string>() : std::string();
  };
  const auto paths = journal.is_object() ? journal.find("paths") : journal.end();
  if (paths == journal.end() || !paths->is_array())
    throw_input_error(journal_file, "an interrupted change left a journal that cannot be read: "
                                    "the case cannot be restored automatically");
  if (text("log_head_sha256") == log_head_sha256(root)) {
    for (const json& entry : *paths) {
      const auto path = entry.is_object() ? entry.find("path") : entry.end();
      const auto existed = entry.is_object() ? entry.find("existed") : entry.end();
      if (path == entry.end() || !path->is_string() || existed == entry.end() || !existed->is_boolean())
        throw_input_error(journal_file, "an interrupted change left a malformed journal entry: " + entry.dump());
      const fs::path rel = path->get<std::string>();
      if (rel.is_absolute() || rel.lexically_normal().string().rfind("..", 0) == 0)
        throw_input_error(journal_file, "an interrupted change's journal names a path outside the case: " + rel.string());
      std::error_code ec;
      if (existed->get<bool>())
        fs::rename(kept / rel, root / rel, ec);
      else
        fs::remove(root / rel, ec);
      if (ec) throw_input_error(root / rel, "cannot restore it after an interrupted change: " + ec.message());
      restored.push_back(rel.generic_string());
    }
  } else {
    // Logged: killed after the log's rename, perhaps before the manifest's. The manifest is
    // the log's summary, so it is written again from the log (the same bytes if it was).
    write_log_and_manifest(root, read_text(root / kLog));
  }
  std::error_code ec;
  fs::remove_all(kept, ec);
  fs::remove(journal_file, ec);
  return restored;
}

}  // namespace

std::vector<std::string> recover_interrupted_changes(const fs::path& root) {
  std::vector<std::string> restored;
  const fs::path undo = root / kUndo;
  if (!fs::is_directory(undo)) return restored;
  const std::string own = std::to_string(::getpid()) + "-";
  std::vector<fs::path> journals, orphans;
  for (const auto& entry : fs::directory_iterator(undo)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(own, 0) == 0) continue;  // a change of this process, still under way
    if (entry.path().extension() == ".json") journals.push_back(entry.path());
    else if (!fs::exists(entry.path().string() + ".json")) orphans.push_back(entry.path());
  }
  for (const fs::path& j : journals)
    for (std::string& r : undo_one_interrupted(root, j)) restored.push_back(std::move(r));
  // Kept copies without a journal: killed before its journal was written, so before the step
  // wrote anything - there is nothing to undo.
  std::error_code ec;
  for (const fs::path& o : orphans) fs::remove_all(o, ec);
  fs::remove(undo, ec);  // only when empty
  return restored;
}

namespace {

constexpr const char* kEvidenceFolders[] = {"evidence", "measurements/measurements.json",
                                            "trajectories", "simulations"};

bool holds_evidence(const fs::path& root) {
  for (const char* rel : kEvidenceFolders)
    if (fs::is_regular_file(root / rel) || !list_files_recursive(root / rel).empty()) return true;
  return false;
}

// Moves every file of the case but earlier archives into archive/replaced-<head16>/.
void archive_whole_case(const fs::path& root, const std::string& head) {
  const fs::path into = root / kArchive / ("replaced-" + (head.empty() ? std::string("empty") : head.substr(0, 16)));
  if (fs::exists(into)) throw_input_error(into, "already exists: this case was archived before");
  fs::create_directories(into);
  for (const auto& entry : fs::directory_iterator(root)) {
    const std::string name = entry.path().filename().string();
    if (name != kArchive && name != kUndo) fs::rename(entry.path(), into / name);
  }
}

// The new case's first step records the archive (its files are outputs, so verify holds them
// to their hashes) and carries the earlier markers over: they are positions the investigator
// chose on the scene, which a new model of the same scan still shows. Measurements,
// trajectories and simulations were computed on the old model: they stay in the archive.
void log_archive(CaseFolder& folder, const std::string& replaced_head) {
  LogStep step;
  step.step = "archive replaced case";
  std::size_t markers = 0;
  if (!replaced_head.empty()) {
    const fs::path from = fs::path(kArchive) / ("replaced-" + replaced_head.substr(0, 16)) / "evidence";
    for (const char* name : {"markers.json", "markers.csv"})
      if (fs::is_regular_file(folder.root() / from / name)) {
        fs::create_directories(folder.root() / "evidence");
        fs::copy_file(folder.root() / from / name, folder.root() / "evidence" / name);
        step.outputs.push_back(fs::path("evidence") / name);
        markers += std::string_view(name) == "markers.json";
      }
  }
  for (const std::string& rel : list_files_recursive(folder.root() / kArchive))
    step.outputs.push_back(fs::path(kArchive) / rel);
  step.parameters_json = json{{"replaced_log_head_sha256", replaced_head},
                              {"archive", replaced_head.empty() ? "" : std::string(kArchive) + "/replaced-" + replaced_head.substr(0, 16)},
                              {"markers_carried_over", markers > 0}}
                             .dump();
  folder.append_log_step(step);
}

}  // namespace

CaseFolder CaseFolder::create(const fs::path& root, bool force) {
  if (fs::exists(root) && !fs::is_directory(root))
    throw_input_error(root, "the case folder is a file; choose another path");
  if (fs::is_directory(root) && !fs::is_empty(root)) {
    if (!force)
      throw_input_error(root, "case folder is not empty; pass --force to replace it (a case is "
                              "never written over otherwise)");
    if (!fs::exists(root / kManifest))
      throw_input_error(root, "folder is not empty and holds no manifest.json: it is not a "
                              "Locard case, so it is not replaced even with --force");
    // Held before anything is removed: a command still working on the old case finishes first.
    std::shared_ptr<CaseLock> lock = CaseLock::acquire(root);
    // A case that does not verify is evidence of what happened to it: --force does not
    // destroy it (remove it by hand, deliberately). An incomplete one is replaced: re-running
    // the reconstruct that did not finish is how it is completed.
    VerifyReport old;
    try {
      old = verify_case(root, false);
    } catch (const InputError& e) {
      throw InputError(fmt::format("--force replaces only a case that verifies: {}", e.what()));
    }
    if (!old.ok() && !old.only_incomplete()) throw CaseNotIntact(root, std::move(old.problems));
    // What an investigator added (markers, measurements, trajectories, simulations) cannot be
    // made again from the inputs: a case holding any is archived whole, not deleted.
    const bool archived = holds_evidence(root);
    if (archived) archive_whole_case(root, old.log_head_sha256);
    for (const auto& entry : fs::directory_iterator(root))
      if (entry.path().filename() != kArchive) fs::remove_all(entry.path());
    CaseFolder folder(root, std::move(lock), CaseAccess::Change);
    if (fs::is_directory(root / kArchive)) log_archive(folder, archived ? old.log_head_sha256 : "");
    return folder;
  }
  fs::create_directories(root);
  return CaseFolder(root, CaseLock::acquire(root), CaseAccess::Change);
}

CaseFolder CaseFolder::open(const fs::path& root, CaseAccess access) {
  if (!fs::is_directory(root)) throw_input_error(root, "no such case folder");
  if (!fs::is_regular_file(root / kManifest))
    throw_input_error(root, "not a Locard case folder: manifest.json is missing");
  CaseFolder folder(root, CaseLock::acquire(root), access);
  if (access == CaseAccess::Change) {
    const std::vector<std::string> restored = recover_interrupted_changes(root);
    // Verified under the lock, before anything is written: a step appended to a case that
    // does not verify would bury the finding under a new, consistent manifest.
    VerifyReport report = verify_case(root, false);
    if (!report.ok()) throw CaseNotIntact(root, std::move(report.problems));
    if (!restored.empty()) {  // on the record: a command was interrupted, and what was undone
      LogStep step;
      step.step = "recover interrupted change";
      step.parameters_json = json{{"restored", restored}}.dump();
      folder.append_log_step(step);
    }
  }
  return folder;
}

fs::path CaseFolder::path(const fs::path& relative) const {
  const fs::path full = root_ / relative;
  fs::create_directories(full.parent_path());
  return full;
}

std::size_t CaseFolder::append_log_step(const LogStep& step) {
  if (access_ != CaseAccess::Change)
    throw Error(fmt::format("{}: the case was opened for reading; log step '{}' refused",
                            root_.string(), step.step));
  const json parameters = parse_parameters(step);
  const fs::path log_path = root_ / kLog;
  const std::string old_log = fs::exists(log_path) ? read_text(log_path) : std::string();
  const std::vector<std::string> lines = split_log_lines(old_log);
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
  if (step.phase != StepPhase::Single) line["phase"] = std::string(to_string(step.phase));
  if (!step.removed.empty()) {
    json removed = json::array();
    for (const fs::path& p : step.removed) {
      if (fs::exists(root_ / p)) throw_input_error(root_ / p, "logged as removed, still on disk");
      removed.push_back(p.generic_string());
    }
    line["removed"] = removed;
  }
  std::string log_text = old_log;
  if (!log_text.empty() && log_text.back() != '\n') log_text += '\n';
  log_text += line.dump() + '\n';
  write_log_and_manifest(root_, log_text);
  return seq;
}

TriangleMesh CaseFolder::load_mesh() const { return read_ply_mesh(root_ / "mesh" / "mesh.ply"); }
PointCloud CaseFolder::load_cloud() const { return read_ply(root_ / "cloud" / "registered.ply"); }
std::string CaseFolder::case_json_text() const { return read_text(root_ / kCase); }

CaseChange::CaseChange(CaseFolder& folder, std::vector<fs::path> may_write)
    : folder_(folder), paths_(std::move(may_write)) {
  undo_ = folder_.root() / kUndo / fmt::format("{}-{}", ::getpid(), g_undo_counter++);
  try {
    for (const fs::path& p : paths_) {
      const fs::path full = folder_.root() / p;
      existed_.push_back(fs::is_regular_file(full));
      if (!existed_.back()) continue;
      fs::create_directories((undo_ / p).parent_path());
      // A hard link keeps the old bytes at no cost: the writers replace files by rename
      // (AtomicFile), so the link still holds the previous version afterwards.
      std::error_code ec;
      fs::create_hard_link(full, undo_ / p, ec);
      if (ec) fs::copy_file(full, undo_ / p);
    }
    write_undo_journal();
  } catch (...) {
    // Nothing was written yet: only what was kept aside goes.
    std::error_code ec;
    fs::remove(undo_.string() + ".json", ec);
    fs::remove_all(undo_, ec);
    fs::remove(folder_.root() / kUndo, ec);
    throw;
  }
}

CaseChange::~CaseChange() {
  if (!committed_) roll_back();
}

// Written before the step writes anything, so a process killed (kill -9, power loss) in the
// middle of its change leaves what the next command needs to undo it: which files the step
// may have written, which existed, and the log's head before it (see recover_interrupted).
void CaseChange::write_undo_journal() {
  json paths = json::array();
  for (std::size_t i = 0; i < paths_.size(); ++i)
    paths.push_back({{"path", paths_[i].generic_string()}, {"existed", static_cast<bool>(existed_[i])}});
  fs::create_directories(undo_.parent_path());
  AtomicFile journal(undo_.string() + ".json", false);
  journal.stream() << json{{"pid", ::getpid()}, {"log_head_sha256", log_head_sha256(folder_.root())},
                           {"paths", paths}}
                          .dump();
  journal.commit();
}

void CaseChange::roll_back() noexcept {
  std::error_code ec;
  for (std::size_t i = 0; i < paths_.size(); ++i) {
    const fs::path full = folder_.root() / paths_[i];
    if (existed_[i]) fs::rename(undo_ / paths_[i], full, ec);
    else fs::remove(full, ec);
  }
  fs::remove_all(undo_, ec);
  fs::remove(undo_.string() + ".json", ec);
  fs::remove(folder_.root() / kUndo, ec);  // only when empty
}

std::size_t CaseChange::commit(const LogStep& step) {
  const std::size_t seq = folder_.append_log_step(step);
  committed_ = true;
  std::error_code ec;
  fs::remove(undo_.string() + ".json", ec);  // first: from here on the step is logged
  fs::remove_all(undo_, ec);
  fs::remove(folder_.root() / kUndo, ec);
  return seq;
}

}  // namespace locard::forensics
