#pragma once
// The ad-hoc measurements of a case (not public API): measurements/measurements.json
// ({"measurements": [{"name", "kind", ..., "created", revisions}]}) and measurements.csv beside
// it, one row each (spreadsheet-safe), always written together.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace locard::forensics {

inline const std::filesystem::path kMeasurementsJson = "measurements/measurements.json";
inline const std::filesystem::path kMeasurementsCsv = "measurements/measurements.csv";

// {"measurements": []} when the file does not exist; InputError naming it when malformed.
nlohmann::json read_measurements_file(const std::filesystem::path& json_path);
std::string measurements_csv(const nlohmann::json& all);
// Writes the JSON and the CSV beside it (atomic each).
void write_measurements_files(const std::filesystem::path& json_path, const nlohmann::json& all);

}  // namespace locard::forensics
