#pragma once
// Small JSON helpers shared by the forensics sources (not public API).

#include <locard/core/error.hpp>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace locard::forensics {

std::string utc_now_iso8601();

inline nlohmann::json vec_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// Three finite numbers, or InputError "<where>: <key>: expected 3 numbers".
inline Eigen::Vector3d json_vec3(const nlohmann::json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3) throw InputError(where + ": expected 3 numbers [x, y, z]");
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) {
    if (!j[static_cast<std::size_t>(i)].is_number())
      throw InputError(where + ": expected 3 numbers [x, y, z]");
    v[i] = j[static_cast<std::size_t>(i)].get<double>();
  }
  if (!v.allFinite()) throw InputError(where + ": coordinates must be finite");
  return v;
}

}  // namespace locard::forensics
