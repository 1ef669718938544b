#pragma once
// Revisions as the case files store them (not public API): {"previous_names": [...],
// "withdrawn": {"reason", "at"}} inside the object, both absent for an untouched one, so files
// written before revisions existed read unchanged.
#include <locard/forensics/revisions.hpp>

#include <nlohmann/json.hpp>

#include <string>

namespace locard::forensics {

// Adds the revision fields to `object` (nothing for an untouched object).
void put_revisions(nlohmann::json& object, const Revisions& revisions);
// Reads them back; InputError naming `where` for fields of the wrong type.
Revisions get_revisions(const nlohmann::json& object, const std::string& where);

}  // namespace locard::forensics
