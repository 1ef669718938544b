#pragma once
// Minimal reader for binary_little_endian PLY vertex data (what locard::write_ply writes:
// float x y z, optional float nx ny nz, optional uchar red green blue), so that the PCL peers
// need no pcl_io (and hence no VTK). Other layouts are rejected. Reading is preparation: the
// peers call it outside the clock.

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace locard_pcl {

struct Property {
  std::string name;
  int size = 0;
  bool is_float = false;
};

inline int type_size(const std::string& type) {
  if (type == "float" || type == "float32" || type == "int" || type == "uint" || type == "int32" ||
      type == "uint32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  if (type == "uchar" || type == "char" || type == "uint8" || type == "int8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  throw std::runtime_error("unsupported PLY property type " + type);
}

// The vertex block of a PLY file and where each wanted property lies in a vertex record
// (-1: absent).
struct PlyVertices {
  std::size_t count = 0;
  int stride = 0;
  int x = -1, y = -1, z = -1, nx = -1, ny = -1, nz = -1, red = -1, green = -1, blue = -1;
  std::vector<char> data;

  const char* vertex(std::size_t i) const {
    return data.data() + i * static_cast<std::size_t>(stride);
  }
  static float get_float(const char* v, int offset) {
    float f;
    std::memcpy(&f, v + offset, 4);
    return f;
  }
};

inline PlyVertices read_ply_vertices(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::string line;
  PlyVertices out;
  std::vector<Property> properties;
  bool in_vertex = false, binary_le = false;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "format") {
      std::string format;
      words >> format;
      binary_le = format == "binary_little_endian";
    } else if (word == "element") {
      std::string name;
      words >> name;
      in_vertex = name == "vertex";
      if (in_vertex) words >> out.count;
    } else if (word == "property" && in_vertex) {
      std::string type, name;
      words >> type >> name;
      properties.push_back({name, type_size(type), type == "float" || type == "float32"});
    } else if (word == "end_header") {
      break;
    }
  }
  if (!binary_le) throw std::runtime_error(path + ": only binary_little_endian PLY is supported");
  for (const Property& p : properties) {
    const auto at = [&](const char* name, int& offset, bool is_float, int size) {
      if (p.name == name && p.is_float == is_float && p.size == size) offset = out.stride;
    };
    at("x", out.x, true, 4);
    at("y", out.y, true, 4);
    at("z", out.z, true, 4);
    at("nx", out.nx, true, 4);
    at("ny", out.ny, true, 4);
    at("nz", out.nz, true, 4);
    at("red", out.red, false, 1);
    at("green", out.green, false, 1);
    at("blue", out.blue, false, 1);
    out.stride += p.size;
  }
  if (out.x < 0 || out.y < 0 || out.z < 0) throw std::runtime_error(path + ": no float x y z");
  out.data.resize(out.count * static_cast<std::size_t>(out.stride));
  in.read(out.data.data(), static_cast<std::streamsize>(out.data.size()));
  if (!in) throw std::runtime_error(path + ": truncated");
  return out;
}

template <typename Point>
void set_dense(pcl::PointCloud<Point>& cloud) {
  cloud.width = static_cast<std::uint32_t>(cloud.size());
  cloud.height = 1;
  cloud.is_dense = true;
}

// Reads positions (and colours when present) into XYZRGB points.
inline void read_ply(const std::string& path, pcl::PointCloud<pcl::PointXYZRGB>& cloud) {
  const PlyVertices ply = read_ply_vertices(path);
  const bool colour = ply.red >= 0 && ply.green >= 0 && ply.blue >= 0;
  cloud.resize(ply.count);
  for (std::size_t i = 0; i < ply.count; ++i) {
    const char* v = ply.vertex(i);
    pcl::PointXYZRGB& p = cloud[i];
    p.x = PlyVertices::get_float(v, ply.x);
    p.y = PlyVertices::get_float(v, ply.y);
    p.z = PlyVertices::get_float(v, ply.z);
    if (colour) {
      p.r = static_cast<std::uint8_t>(v[ply.red]);
      p.g = static_cast<std::uint8_t>(v[ply.green]);
      p.b = static_cast<std::uint8_t>(v[ply.blue]);
    }
  }
  set_dense(cloud);
}

inline void read_ply(const std::string& path, pcl::PointCloud<pcl::PointXYZ>& cloud) {
  const PlyVertices ply = read_ply_vertices(path);
  cloud.resize(ply.count);
  for (std::size_t i = 0; i < ply.count; ++i) {
    const char* v = ply.vertex(i);
    cloud[i] = pcl::PointXYZ(PlyVertices::get_float(v, ply.x), PlyVertices::get_float(v, ply.y),
                             PlyVertices::get_float(v, ply.z));
  }
  set_dense(cloud);
}

// Positions and normals; the file must have float nx ny nz.
inline void read_ply(const std::string& path, pcl::PointCloud<pcl::PointNormal>& cloud) {
  const PlyVertices ply = read_ply_vertices(path);
  if (ply.nx < 0 || ply.ny < 0 || ply.nz < 0)
    throw std::runtime_error(path + ": no float nx ny nz");
  cloud.resize(ply.count);
  for (std::size_t i = 0; i < ply.count; ++i) {
    const char* v = ply.vertex(i);
    pcl::PointNormal& p = cloud[i];
    p.x = PlyVertices::get_float(v, ply.x);
    p.y = PlyVertices::get_float(v, ply.y);
    p.z = PlyVertices::get_float(v, ply.z);
    p.normal_x = PlyVertices::get_float(v, ply.nx);
    p.normal_y = PlyVertices::get_float(v, ply.ny);
    p.normal_z = PlyVertices::get_float(v, ply.nz);
  }
  set_dense(cloud);
}

}  // namespace locard_pcl
