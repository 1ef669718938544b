#pragma once
// Renaming and withdrawing what a case records - evidence markers, ad-hoc measurements, bullet
// trajectory analyses - as logged steps. Nothing is erased: a rename keeps the earlier names
// in the object, a withdrawal keeps the object with its reason and time (revisions.hpp), and
// the log holds every edit with who made it (CLI or viewer). The CLI (`locard evidence`) and
// the viewer (POST /api/evidence/rename|withdraw) both call apply_case_edit, so they see and
// change the same objects.
#include <locard/forensics/case_folder.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace locard::forensics {

enum class CaseObjectKind { Marker, Measurement, Trajectory };
enum class CaseEditKind { Rename, Withdraw };

std::string_view to_string(CaseObjectKind kind);  // "marker", "measurement", "trajectory"
std::optional<CaseObjectKind> parse_case_object_kind(std::string_view text);

struct CaseEdit {
  CaseObjectKind object = CaseObjectKind::Marker;
  // Which one: a marker by number or label; a measurement or trajectory by name, or by its
  // position in the list as "#N" (1-based) where names repeat.
  std::string which;
  CaseEditKind edit = CaseEditKind::Rename;
  std::string new_name;  // Rename: the new label (marker) or name
  std::string reason;    // Withdraw: why (required)
  std::string source = "cli";  // logged: "cli" or "viewer"
};

struct CaseEditResult {
  std::string summary;     // e.g. "marker 3 relabelled 'knife' (was 'blade')"
  std::size_t log_seq = 0;
};

// Applies one edit as one logged step ("marker rename", "measurement withdraw", ...) under
// the case's lock: `folder` must be opened with CaseAccess::Change. Throws InputError (nothing
// written) for an unknown object, an ambiguous name, an empty new name or reason, a name in
// use, or an object already withdrawn.
CaseEditResult apply_case_edit(CaseFolder& folder, const CaseEdit& edit);

// The table of one kind as the case's CSV holds it (markers.csv, measurements.csv,
// analyses.csv: header, one row per object, withdrawn ones with their status), computed from
// the JSON so a case written before the CSV existed lists the same. Header only when empty.
std::string case_objects_csv(const CaseFolder& folder, CaseObjectKind kind);

}  // namespace locard::forensics
