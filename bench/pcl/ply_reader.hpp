#pragma once
// Minimal reader for binary_little_endian PLY vertex data (what locard::write_ply writes:
// float x y z, optional float nx ny nz, optional uchar red green blue), so that the PCL peer
// needs no pcl_io (and hence no VTK). Other layouts are rejected.

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

// Reads positions (and colours when present) into XYZRGB points.
inline void read_ply(const std::string& path, pcl::PointCloud<pcl::PointXYZRGB>& cloud) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::size_t count = 0;
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
      if (in_vertex) words >> count;
    } else if (word == "property" && in_vertex) {
      std::string type, name;
      words >> type >> name;
      properties.push_back({name, type_size(type), type == "float" || type == "float32"});
    } else if (word == "end_header") {
      break;
    }
  }
  if (!binary_le) throw std::runtime_error(path + ": only binary_little_endian PLY is supported");
  int stride = 0, ox = -1, oy = -1, oz = -1, orr = -1, og = -1, ob = -1;
  for (const Property& p : properties) {
    if (p.name == "x" && p.is_float) ox = stride;
    if (p.name == "y" && p.is_float) oy = stride;
    if (p.name == "z" && p.is_float) oz = stride;
    if (p.name == "red" && p.size == 1) orr = stride;
    if (p.name == "green" && p.size == 1) og = stride;
    if (p.name == "blue" && p.size == 1) ob = stride;
    stride += p.size;
  }
  if (ox < 0 || oy < 0 || oz < 0) throw std::runtime_error(path + ": no float x y z");
  std::vector<char> data(count * static_cast<std::size_t>(stride));
  in.read(data.data(), static_cast<std::streamsize>(data.size()));
  if (!in) throw std::runtime_error(path + ": truncated");
  cloud.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    const char* v = data.data() + i * stride;
    pcl::PointXYZRGB& p = cloud[i];
    std::memcpy(&p.x, v + ox, 4);
    std::memcpy(&p.y, v + oy, 4);
    std::memcpy(&p.z, v + oz, 4);
    if (orr >= 0 && og >= 0 && ob >= 0) {
      p.r = static_cast<std::uint8_t>(v[orr]);
      p.g = static_cast<std::uint8_t>(v[og]);
      p.b = static_cast<std::uint8_t>(v[ob]);
    }
  }
  cloud.width = static_cast<std::uint32_t>(count);
  cloud.height = 1;
  cloud.is_dense = true;
}

inline void read_ply(const std::string& path, pcl::PointCloud<pcl::PointXYZ>& cloud) {
  pcl::PointCloud<pcl::PointXYZRGB> coloured;
  read_ply(path, coloured);
  pcl::copyPointCloud(coloured, cloud);
}

}  // namespace locard_pcl
