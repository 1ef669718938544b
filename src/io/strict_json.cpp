// Strict reading of a JSON object (see strict_json.hpp).
#include <locard/io/strict_json.hpp>

#include <locard/core/error.hpp>

#include <cmath>
#include <cstdint>
#include <sstream>

namespace locard {

StrictObject::StrictObject(const json& j, std::string where, const std::filesystem::path& file)
    : j_(j), where_(std::move(where)), file_(file) {
  if (!j_.is_object()) fail(where_ + ": expected an object, found " + type_phrase(j_));
}

void StrictObject::fail(const std::string& what) const { throw_input_error(file_, what); }

const StrictObject::json& StrictObject::required(const std::string& key) {
  known_.insert(key);
  if (!j_.contains(key)) fail(where_ + ": missing required key '" + key + "'");
  return j_.at(key);
}

const StrictObject::json* StrictObject::optional(const std::string& key) {
  known_.insert(key);
  return j_.contains(key) ? &j_.at(key) : nullptr;
}

double StrictObject::number_value(const json& value, const std::string& key) const {
  if (!value.is_number()) fail(place(key) + ": expected a number, found " + type_phrase(value));
  const double x = value.get<double>();
  if (!std::isfinite(x)) fail(place(key) + ": expected a finite number, found " + value.dump());
  return x;
}

double StrictObject::number_or(const std::string& key, double fallback) {
  const json* v = optional(key);
  return v ? number_value(*v, key) : fallback;
}

double StrictObject::check_positive(const std::string& key, double x) const {
  if (!(x > 0.0)) fail(place(key) + ": expected a positive number, found " + number_text(x));
  return x;
}

double StrictObject::non_negative_or(const std::string& key, double fallback) {
  const double x = number_or(key, fallback);
  if (x < 0.0) fail(place(key) + ": expected a number >= 0, found " + number_text(x));
  return x;
}

double StrictObject::in_range_or(const std::string& key, double fallback, double lo, double hi) {
  const double x = number_or(key, fallback);
  if (x < lo || x > hi)
    fail(place(key) + ": expected a number from " + number_text(lo) + " to " + number_text(hi) +
         ", found " + number_text(x));
  return x;
}

std::string StrictObject::string_value(const json& value, const std::string& key) const {
  if (!value.is_string()) fail(place(key) + ": expected a string, found " + type_phrase(value));
  return value.get<std::string>();
}

std::string StrictObject::string_or(const std::string& key, const std::string& fallback) {
  const json* v = optional(key);
  return v ? string_value(*v, key) : fallback;
}

bool StrictObject::boolean_or(const std::string& key, bool fallback) {
  const json* v = optional(key);
  if (!v) return fallback;
  if (!v->is_boolean()) fail(place(key) + ": expected true or false, found " + type_phrase(*v));
  return v->get<bool>();
}

Eigen::Vector3d StrictObject::vec3_value(const json& value, const std::string& key) const {
  if (!value.is_array() || value.size() != 3)
    fail(place(key) + ": expected an array of 3 numbers, found " + describe(value));
  Eigen::Vector3d out;
  for (int i = 0; i < 3; ++i) out[i] = number_value(value[i], key + "[" + std::to_string(i) + "]");
  return out;
}

Eigen::Vector3d StrictObject::vec3_or(const std::string& key, const Eigen::Vector3d& fallback) {
  const json* v = optional(key);
  return v ? vec3_value(*v, key) : fallback;
}

Eigen::Vector3d StrictObject::positive_vec3(const std::string& key) {
  const Eigen::Vector3d v = vec3(key);
  if ((v.array() <= 0.0).any())
    fail(place(key) + ": expected three positive sizes, found [" + number_text(v.x()) + ", " +
         number_text(v.y()) + ", " + number_text(v.z()) + "]");
  return v;
}

Rgb8 StrictObject::color_or(const std::string& key, Rgb8 fallback, bool* given) {
  const json* v = optional(key);
  if (given) *given = v != nullptr;
  if (!v) return fallback;
  if (!v->is_array() || v->size() != 3)
    fail(place(key) + ": expected an RGB array of 3 integers 0..255, found " + describe(*v));
  std::uint8_t c[3];
  for (int i = 0; i < 3; ++i) {
    const json& x = (*v)[i];
    if (!x.is_number_integer() || x.get<std::int64_t>() < 0 || x.get<std::int64_t>() > 255)
      fail(place(key) + ": expected an RGB array of 3 integers 0..255, found " + v->dump());
    c[i] = static_cast<std::uint8_t>(x.get<std::int64_t>());
  }
  return {c[0], c[1], c[2]};
}

const StrictObject::json& StrictObject::array(const std::string& key, bool is_required) {
  static const json kEmpty = json::array();
  const json* v = is_required ? &required(key) : optional(key);
  if (!v) return kEmpty;
  if (!v->is_array()) fail(place(key) + ": expected an array, found " + type_phrase(*v));
  return *v;
}

void StrictObject::finish() const {
  for (const auto& item : j_.items()) {
    if (known_.count(item.key())) continue;
    std::string expected;
    for (const auto& k : known_) expected += (expected.empty() ? "" : ", ") + k;
    fail(where_ + ": unknown key '" + item.key() + "' (expected one of: " + expected + ")");
  }
}

std::string StrictObject::type_phrase(const json& j) {
  switch (j.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::string: return "a string";
    case json::value_t::array: return "an array";
    case json::value_t::object: return "an object";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "a number";
    default: return "a value of another type";
  }
}

std::string StrictObject::describe(const json& v) {
  return v.is_array() ? "an array of " + std::to_string(v.size()) : type_phrase(v);
}

std::string StrictObject::number_text(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

}  // namespace locard
