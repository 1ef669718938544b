#pragma once
// Case measurements as JSON values (not public API; the format is in case_measurements.hpp).
#include <locard/forensics/case_measurements.hpp>

#include <nlohmann/json.hpp>

#include <vector>

namespace locard::forensics {

// What was measured and its value: "kind", the ends or planes, the value and uncertainties
// (without name, created and revisions; Table I's rows carry this too).
nlohmann::json measurement_content_json(const CaseMeasurement& measurement);
// {"measurements": [...]} exactly as measurements.json holds it.
nlohmann::json case_measurements_to_json(const std::vector<CaseMeasurement>& measurements);

}  // namespace locard::forensics
