#pragma once
// What case_folder.cpp (writing) and case_verify.cpp (checking) share about a case's files:
// their names and how log.jsonl is read. Not public API.

#include <locard/forensics/case_folder.hpp>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard::forensics::detail {

inline constexpr const char* kManifest = "manifest.json";
inline constexpr const char* kLog = "log.jsonl";
inline constexpr const char* kCase = "case.json";
// Signatures and time stamps over the log head (anchors.hpp): they cover the manifest and the
// log, so they cannot be listed in them; verify checks them on their own.
inline constexpr const char* kAnchors = "anchors";
// Earlier cases that `reconstruct --force` replaced while they held evidence (markers,
// measurements, trajectories, simulations): each whole, under archive/replaced-<head16>/.
inline constexpr const char* kArchive = "archive";
// Where CaseChange keeps the previous versions of the files a step writes, until it commits.
inline constexpr const char* kUndo = ".locard-undo";

// The whole file; InputError naming it when it cannot be read.
std::string read_text(const std::filesystem::path& path);
// Lines of a log's text without their '\n' (empty lines skipped).
std::vector<std::string> split_log_lines(std::string_view text);
// The lines of root/log.jsonl (none when it does not exist).
std::vector<std::string> log_lines(const std::filesystem::path& root);
// The file parsed; InputError naming it when it is not JSON (numbers out of range included).
nlohmann::json parse_json_file(const std::filesystem::path& path);
// A log line's "phase" (absent: Single); nullopt for a value no version of Locard writes.
std::optional<StepPhase> parse_phase(const nlohmann::json& line);

}  // namespace locard::forensics::detail
