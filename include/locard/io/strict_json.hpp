#pragma once
// Strict reading of a JSON object from a file a person wrote (scene files, physics scenarios):
// every key known, every required key present, every value of the right type and range;
// otherwise an InputError names the file, the place ("objects[2] \"bed\"") and the key, because
// a typo must not silently become a default in something a court may be shown.
//
//   StrictObject r(j, "room", file);
//   room.size = r.positive_vec3("size");
//   room.wall_color = r.color_or("wall_color", room.wall_color);
//   r.finish();  // any key not asked for is an error listing the known ones

#include <locard/core/point_cloud.hpp>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <set>
#include <string>

namespace locard {

class StrictObject {
 public:
  using json = nlohmann::json;

  // `where` names the object in messages ("room", "objects[2] \"bed\""). InputError when `j`
  // is not an object.
  StrictObject(const json& j, std::string where, const std::filesystem::path& file);

  [[noreturn]] void fail(const std::string& what) const;
  std::string place(const std::string& key) const { return where_ + "." + key; }
  const std::string& where() const { return where_; }
  bool has(const std::string& key) const { return j_.contains(key); }

  const json& required(const std::string& key);
  const json* optional(const std::string& key);

  double number_value(const json& value, const std::string& key) const;  // finite
  double number(const std::string& key) { return number_value(required(key), key); }
  double number_or(const std::string& key, double fallback);
  double positive(const std::string& key) { return check_positive(key, number(key)); }
  double positive_or(const std::string& key, double fallback) {
    return check_positive(key, number_or(key, fallback));
  }
  double check_positive(const std::string& key, double x) const;
  double non_negative_or(const std::string& key, double fallback);
  double in_range_or(const std::string& key, double fallback, double lo, double hi);

  std::string string_value(const json& value, const std::string& key) const;
  std::string string(const std::string& key) { return string_value(required(key), key); }
  std::string string_or(const std::string& key, const std::string& fallback);
  bool boolean_or(const std::string& key, bool fallback);

  Eigen::Vector3d vec3_value(const json& value, const std::string& key) const;
  Eigen::Vector3d vec3(const std::string& key) { return vec3_value(required(key), key); }
  Eigen::Vector3d vec3_or(const std::string& key, const Eigen::Vector3d& fallback);
  Eigen::Vector3d positive_vec3(const std::string& key);  // three sizes > 0

  // An RGB array of three integers 0..255; `given` (when not null) says whether it was there.
  Rgb8 color_or(const std::string& key, Rgb8 fallback, bool* given = nullptr);
  // An array (empty when optional and absent).
  const json& array(const std::string& key, bool is_required);

  // Every key present must have been asked for.
  void finish() const;

  static std::string type_phrase(const json& value);  // "a string", "an array", ...
  static std::string describe(const json& value);     // "an array of 2", or the type
  static std::string number_text(double x);           // as a person would write it

 private:
  const json& j_;
  std::string where_;
  std::filesystem::path file_;
  std::set<std::string> known_;
};

}  // namespace locard
