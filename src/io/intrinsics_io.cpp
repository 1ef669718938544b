#include <locard/io/rgbd_sequence.hpp>

#include "io/text_lines.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>

#include <nlohmann/json.hpp>

#include <cmath>

namespace locard {
namespace {

using nlohmann::json;

double number_field(const std::filesystem::path& path, const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number())
    throw_input_error(path, std::string("missing or non-numeric \"") + key + "\"");
  return it->get<double>();
}

int size_field(const std::filesystem::path& path, const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number_integer() || it->get<long long>() <= 0 ||
      it->get<long long>() > 1 << 16)
    throw_input_error(path, std::string("\"") + key + "\" must be a positive integer");
  return it->get<int>();
}

// Open3D PinholeCameraIntrinsic: the 3x3 K stored column-major.
CameraIntrinsics from_open3d(const std::filesystem::path& path, const json& j) {
  const json& m = j["intrinsic_matrix"];
  if (!m.is_array() || m.size() != 9)
    throw_input_error(path, "\"intrinsic_matrix\" must hold 9 numbers");
  double k[9];
  for (std::size_t i = 0; i < 9; ++i) {
    if (!m[i].is_number()) throw_input_error(path, "\"intrinsic_matrix\" must hold 9 numbers");
    k[i] = m[i].get<double>();
  }
  // Column-major: [fx 0 0 | s fy 0 | cx cy 1]. A row-major file has cx, cy at 2 and 5.
  if (k[2] != 0.0 || k[5] != 0.0)
    throw_input_error(path,
                      "\"intrinsic_matrix\" looks row-major (non-zero entries 2 and 5); "
                      "Open3D stores K column-major: [fx,0,0, 0,fy,0, cx,cy,1]");
  if (k[1] != 0.0 || k[3] != 0.0 || k[8] != 1.0)
    throw_input_error(path, "\"intrinsic_matrix\" is not a pinhole K without skew");
  CameraIntrinsics out;
  out.width = size_field(path, j, "width");
  out.height = size_field(path, j, "height");
  out.fx = k[0];
  out.fy = k[4];
  out.cx = k[6];
  out.cy = k[7];
  return out;
}

CameraIntrinsics from_locard(const std::filesystem::path& path, const json& j) {
  CameraIntrinsics out;
  out.width = size_field(path, j, "width");
  out.height = size_field(path, j, "height");
  out.fx = number_field(path, j, "fx");
  out.fy = number_field(path, j, "fy");
  out.cx = number_field(path, j, "cx");
  out.cy = number_field(path, j, "cy");
  if (const auto it = j.find("distortion"); it != j.end()) {
    if (!it->is_array() || it->size() != out.distortion.size())
      throw_input_error(path, "\"distortion\" must hold 5 numbers (k1 k2 p1 p2 k3)");
    for (std::size_t i = 0; i < out.distortion.size(); ++i) {
      if (!(*it)[i].is_number()) throw_input_error(path, "\"distortion\" must hold 5 numbers");
      out.distortion[i] = (*it)[i].get<double>();
    }
  }
  if (const auto it = j.find("name"); it != j.end() && it->is_string())
    out.name = it->get<std::string>();
  return out;
}

}  // namespace

IntrinsicsFile read_intrinsics_json_with_scale(const std::filesystem::path& path) {
  const std::string text = io_detail::read_text_file(path);
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw_input_error(path, std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object()) throw_input_error(path, "expected a JSON object with camera intrinsics");
  IntrinsicsFile out;
  if (j.contains("intrinsic_matrix")) {
    out.intrinsics = from_open3d(path, j);
  } else if (j.contains("fx")) {
    out.intrinsics = from_locard(path, j);
    if (j.contains("depth_scale")) {
      out.depth_scale = number_field(path, j, "depth_scale");
      if (!(*out.depth_scale > 0.0)) throw_input_error(path, "\"depth_scale\" must be positive");
    }
  } else {
    throw_input_error(path,
                      "no camera intrinsics: expected \"intrinsic_matrix\" (Open3D) or "
                      "\"fx\", \"fy\", \"cx\", \"cy\" (Locard)");
  }
  if (!(out.intrinsics.fx > 0.0 && out.intrinsics.fy > 0.0))
    throw_input_error(path, "focal lengths must be positive");
  if (out.intrinsics.name.empty()) out.intrinsics.name = path.filename().string();
  return out;
}

CameraIntrinsics read_intrinsics_json(const std::filesystem::path& path) {
  return read_intrinsics_json_with_scale(path).intrinsics;
}

void write_intrinsics_json(const std::filesystem::path& path, const CameraIntrinsics& intrinsics,
                           double depth_scale) {
  nlohmann::ordered_json j;
  j["width"] = intrinsics.width;
  j["height"] = intrinsics.height;
  j["fx"] = intrinsics.fx;
  j["fy"] = intrinsics.fy;
  j["cx"] = intrinsics.cx;
  j["cy"] = intrinsics.cy;
  j["depth_scale"] = depth_scale;
  if (!intrinsics.name.empty()) j["name"] = intrinsics.name;
  if (intrinsics.distortion != std::array<double, 5>{}) j["distortion"] = intrinsics.distortion;
  AtomicFile file(path, false);
  file.stream() << j.dump(2) << '\n';
  file.commit();
}

CameraIntrinsics read_intrinsics_matrix_txt(const std::filesystem::path& path, int width,
                                            int height) {
  const std::string text = io_detail::read_text_file(path);
  const auto tokens = io_detail::split_tokens(text);
  double k[9];
  std::size_t count = 0;
  for (const auto token : tokens) {
    const auto value = io_detail::parse_number(token);
    if (!value || count == 9) {
      throw_input_error(path, "expected exactly 9 numbers (a 3x3 K matrix, row-major)");
    }
    k[count++] = *value;
  }
  if (count != 9) throw_input_error(path, "expected exactly 9 numbers (a 3x3 K matrix, row-major)");
  if (k[1] != 0.0 || k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0)
    throw_input_error(path, "not a pinhole K matrix [fx 0 cx; 0 fy cy; 0 0 1]");
  if (!(k[0] > 0.0 && k[4] > 0.0)) throw_input_error(path, "focal lengths must be positive");
  if (width <= 0 || height <= 0) throw_input_error(path, "image size unknown for this K matrix");
  CameraIntrinsics out;
  out.width = width;
  out.height = height;
  out.fx = k[0];
  out.fy = k[4];
  out.cx = k[2];
  out.cy = k[5];
  out.name = path.filename().string();
  return out;
}

}  // namespace locard
