#include <locard/forensics/revisions.hpp>

#include "forensics/revisions_json.hpp"

#include <locard/core/error.hpp>

#include <fmt/format.h>

namespace locard::forensics {

std::string Revisions::status() const {
  if (!withdrawn()) return "current";
  return fmt::format("withdrawn {}: {}", withdrawn_at, withdrawn_reason);
}

std::string Revisions::previous_names_text() const {
  std::string out;
  for (const std::string& name : previous_names) out += (out.empty() ? "" : "; ") + name;
  return out;
}

void put_revisions(nlohmann::json& object, const Revisions& r) {
  if (!r.previous_names.empty()) object["previous_names"] = r.previous_names;
  if (r.withdrawn())
    object["withdrawn"] = {{"reason", r.withdrawn_reason}, {"at", r.withdrawn_at}};
}

Revisions get_revisions(const nlohmann::json& object, const std::string& where) {
  Revisions r;
  if (const auto it = object.find("previous_names"); it != object.end()) {
    if (!it->is_array()) throw InputError(where + ": 'previous_names' is not a list");
    for (const auto& name : *it) {
      if (!name.is_string()) throw InputError(where + ": 'previous_names' holds a non-string");
      r.previous_names.push_back(name.get<std::string>());
    }
  }
  if (const auto it = object.find("withdrawn"); it != object.end()) {
    const auto reason = it->is_object() ? it->find("reason") : it->end();
    const auto at = it->is_object() ? it->find("at") : it->end();
    if (!it->is_object() || reason == it->end() || at == it->end() || !reason->is_string() ||
        !at->is_string() || at->get<std::string>().empty())
      throw InputError(where + ": 'withdrawn' needs a text 'reason' and 'at'");
    r.withdrawn_reason = reason->get<std::string>();
    r.withdrawn_at = at->get<std::string>();
  }
  return r;
}

}  // namespace locard::forensics
