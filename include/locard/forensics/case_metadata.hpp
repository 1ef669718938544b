#pragma once
// What a court exhibit names a case by: its number, the investigator, the scene's location
// and the date of the scene examination. Kept in case.json under "metadata" (absent until
// set), set by `locard case set` as a logged step; the report's title and first table show it.
#include <locard/forensics/case_folder.hpp>

#include <optional>
#include <string>

namespace locard::forensics {

struct CaseMetadata {
  std::string number;        // e.g. "2026-0412"
  std::string investigator;  // name, or name and role
  std::string location;      // address or description of the scene
  std::string date;          // of the examination, YYYY-MM-DD
};

// Fields to change; nullopt leaves a field as it is, "" clears it.
struct CaseMetadataUpdate {
  std::optional<std::string> number, investigator, location, date;
};

// The case's metadata (empty fields when never set). InputError naming case.json for fields
// of the wrong type.
CaseMetadata read_case_metadata(const CaseFolder& folder);

// Applies `update` to case.json as one logged step ("case set"): folder opened with
// CaseAccess::Change. InputError (nothing written) for a date that is not a real YYYY-MM-DD,
// a field over 500 characters or with control characters, or an update that changes nothing.
// Returns the log line's sequence number.
std::size_t set_case_metadata(CaseFolder& folder, const CaseMetadataUpdate& update,
                              const std::string& source = "cli");

}  // namespace locard::forensics
