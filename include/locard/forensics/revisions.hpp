#pragma once
// What happened to a recorded object (an evidence marker, a measurement, a trajectory analysis)
// after it was made. Nothing recorded is ever erased: a rename keeps the earlier names, a
// withdrawal keeps the object with its reason and time, and each is a logged step of its own
// (see case_edits.hpp). Reports and tables show withdrawn objects as withdrawn; commands refuse
// to use them as points.
#include <string>
#include <vector>

namespace locard::forensics {

struct Revisions {
  std::vector<std::string> previous_names;  // oldest first
  std::string withdrawn_reason;
  std::string withdrawn_at;  // ISO 8601 UTC; empty while the object stands

  bool withdrawn() const { return !withdrawn_at.empty(); }
  // "current", or "withdrawn <time>: <reason>" (what the CSV status column holds).
  std::string status() const;
  // The earlier names joined with "; " (the CSV column), empty when never renamed.
  std::string previous_names_text() const;
};

}  // namespace locard::forensics
