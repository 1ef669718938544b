#include "io/lzf.hpp"

#include <locard/core/error.hpp>
#include <locard/io/pcd.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <charconv>
#include <limits>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;
using test::list_folder;
using test::scratch_dir;
using test::shared_data;

fs::path o3d_data() { return shared_data() / "open3d-testdata"; }

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

template <typename T>
void put(std::string& s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  s.append(b, sizeof(T));
}

PointCloud random_cloud(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  std::uniform_int_distribution<int> byte(0, 255);
  PointCloud c;
  ScalarField curvature{"curvature", {}};
  ScalarField label{"label", {}};
  for (std::size_t i = 0; i < n; ++i) {
    c.positions.emplace_back(u(rng), u(rng) * 1e-3f, u(rng) * 1e4f);
    c.normals.push_back(Eigen::Vector3f(u(rng), u(rng), u(rng)).normalized());
    // Dark colours (red < 128) make the packed float a denormal: the hardest ascii case.
    c.colors.push_back({static_cast<std::uint8_t>(byte(rng)), static_cast<std::uint8_t>(byte(rng)),
                        static_cast<std::uint8_t>(byte(rng))});
    curvature.values.push_back(std::abs(u(rng)) * 1e-3f);
    label.values.push_back(static_cast<float>(i % 7));
  }
  c.colors[0] = {0, 0, 0};
  c.colors[1] = {255, 255, 255};
  c.scalars = {curvature, label};
  return c;
}

template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no InputError";
}

void expect_same(const PointCloud& a, const PointCloud& b) {
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.colors, b.colors);
  EXPECT_EQ(a.scalars, b.scalars);
}

TEST(Pcd, ReadsOpen3dFragment) {
  const PointCloud c = read_pcd(o3d_data() / "fragment.pcd");
  ASSERT_EQ(c.size(), 113662u);
  ASSERT_TRUE(c.has_colors());
  ASSERT_TRUE(c.has_normals());
  ASSERT_EQ(c.scalars.size(), 1u);
  EXPECT_EQ(c.scalars[0].name, "curvature");
  // Point 0 and 100, float values printed with %.9g from the file's bytes.
  EXPECT_EQ(c.positions[0], Eigen::Vector3f(1.16796875f, 1.01803279f, 0.96484375f));
  EXPECT_EQ(c.normals[0], Eigen::Vector3f(0.965461791f, -0.0861289948f, 0.245896921f));
  EXPECT_EQ(c.colors[0], (Rgb8{127, 117, 106}));
  EXPECT_EQ(c.positions[100], Eigen::Vector3f(1.63671875f, 0.837089181f, 1.14453125f));
  EXPECT_EQ(c.colors[100], (Rgb8{153, 142, 133}));
  EXPECT_EQ(c.positions.back(), Eigen::Vector3f(2.19140625f, 2.62890625f, 1.45781052f));
  EXPECT_EQ(c.colors.back(), (Rgb8{116, 110, 102}));
}

TEST(Pcd, ReadsFeatureCloudWithNormals) {
  const PointCloud c = read_pcd(o3d_data() / "Feature" / "cloud_bin_0.pcd");
  ASSERT_EQ(c.size(), 3903u);
  ASSERT_TRUE(c.has_normals());
  EXPECT_EQ(c.positions[0], Eigen::Vector3f(2.84890771f, 0.0313906074f, -1.74716592f));
  EXPECT_EQ(c.normals[0], Eigen::Vector3f(-0.8276577f, 0.33382228f, -0.451141119f));
  EXPECT_EQ(c.normals.back(), Eigen::Vector3f(0.322117209f, 0.410384268f, 0.853109837f));
  for (const auto& n : c.normals) EXPECT_NEAR(n.norm(), 1.0f, 1e-3f);
}

TEST(Pcd, RoundTripsEveryEncodingExactly) {
  const fs::path dir = scratch_dir();
  const PointCloud cloud = random_cloud(2000, 11);
  for (PcdEncoding enc : {PcdEncoding::Binary, PcdEncoding::BinaryCompressed, PcdEncoding::Ascii}) {
    SCOPED_TRACE(static_cast<int>(enc));
    write_pcd(dir / "c.pcd", cloud, enc);
    // Ascii floats are written with the shortest digits that read back bit-exact.
    expect_same(read_pcd(dir / "c.pcd"), cloud);
  }
}

TEST(Pcd, WritesPclHeaders) {
  const fs::path dir = scratch_dir();
  const PointCloud cloud = random_cloud(3, 1);
  write_pcd(dir / "b.pcd", cloud);
  const std::string b = read_bytes(dir / "b.pcd");
  EXPECT_EQ(b.substr(0, b.find("DATA")),
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
            "FIELDS x y z rgb normal_x normal_y normal_z curvature label\n"
            "SIZE 4 4 4 4 4 4 4 4 4\nTYPE F F F F F F F F F\nCOUNT 1 1 1 1 1 1 1 1 1\n"
            "WIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\n");
  EXPECT_EQ(b.size(), b.find("DATA binary\n") + 12 + 3 * 9 * 4);
  // Ascii: rgb is an unsigned integer with TYPE U, as PCL writes it.
  write_pcd(dir / "a.pcd", cloud, PcdEncoding::Ascii);
  const std::string a = read_bytes(dir / "a.pcd");
  EXPECT_NE(a.find("TYPE F F F U F F F F F\n"), std::string::npos) << a;
  EXPECT_NE(a.find(" 0 "), std::string::npos);         // black
  EXPECT_NE(a.find(" 16777215 "), std::string::npos);  // white
}

TEST(Pcd, CompressesRealData) {
  const fs::path dir = scratch_dir();
  const PointCloud fragment = read_pcd(o3d_data() / "fragment.pcd");
  write_pcd(dir / "f.pcd", fragment, PcdEncoding::BinaryCompressed);
  expect_same(read_pcd(dir / "f.pcd"), fragment);
  // The all-zero curvature column alone compresses ~88x.
  EXPECT_LT(fs::file_size(dir / "f.pcd"), fs::file_size(o3d_data() / "fragment.pcd") * 9 / 10);
}

// LZF bytes that unpack to `size` zero bytes: one literal, then back references of up to 264
// bytes, 3 bytes each (the most LZF can expand).
std::string zeros_lzf(std::size_t size) {
  std::string out("\x00\x00", 2);
  std::size_t done = 1;
  while (done < size) {
    const std::size_t n = std::min<std::size_t>(264, size - done);
    if (n == 1) {  // too short for a reference: one more literal
      out += std::string("\x00\x00", 2);
    } else if (n < 9) {
      out += static_cast<char>((n - 2) << 5);
      out += '\x00';
    } else {
      out += '\xE0';
      out += static_cast<char>(n - 9);
      out += '\x00';
    }
    done += n;
  }
  return out;
}

// Issue 14: a 1 MB binary_compressed PCD of 103 one-byte fields unpacked to 88 MB and its
// scalar fields took 352 MB more as floats. What decoding allocates is now bounded by what the
// file holds (64 MiB + 32 x the compressed bytes), checked before anything is allocated; a
// small cloud of the same kind still reads.
TEST(Pcd, CompressedBodyThatWouldExpandBeyondTheBudgetIsRefused) {
  const fs::path dir = scratch_dir();
  auto write_cloud = [&](const fs::path& path, std::size_t points) {
    std::string fields = "x y z", sizes = "1 1 1", types = "U U U", counts = "1 1 1";
    for (int f = 0; f < 100; ++f) {
      fields += " s" + std::to_string(f);
      sizes += " 1";
      types += " U";
      counts += " 1";
    }
    const std::string body = zeros_lzf(points * 103);
    std::string file = "VERSION 0.7\nFIELDS " + fields + "\nSIZE " + sizes + "\nTYPE " + types +
                       "\nCOUNT " + counts + "\nWIDTH " + std::to_string(points) +
                       "\nHEIGHT 1\nPOINTS " + std::to_string(points) +
                       "\nDATA binary_compressed\n";
    put<std::uint32_t>(file, static_cast<std::uint32_t>(body.size()));
    put<std::uint32_t>(file, static_cast<std::uint32_t>(points * 103));
    std::ofstream(path, std::ios::binary) << file << body;
  };
  write_cloud(dir / "small.pcd", 1000);
  const PointCloud small = read_pcd(dir / "small.pcd");
  EXPECT_EQ(small.size(), 1000u);
  EXPECT_EQ(small.scalars.size(), 100u);

  const std::size_t points = 850'000;  // 87.6 MB unpacked, 350 MB of floats
  write_cloud(dir / "bomb.pcd", points);
  EXPECT_LT(fs::file_size(dir / "bomb.pcd"), 1'100'000u);
  try {
    read_pcd(dir / "bomb.pcd");
    ADD_FAILURE() << "a 1 MB file decoded to a cloud of 440 MB";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bomb.pcd"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("decoding budget"), std::string::npos) << e.what();
  }
}

TEST(Pcd, LzfRoundTripsAndRejectsCorruption) {
  std::mt19937 rng(5);
  std::vector<std::vector<std::uint8_t>> inputs = {{}, {42}, std::vector<std::uint8_t>(100000, 0)};
  std::vector<std::uint8_t> noise(70000), text;
  for (auto& b : noise) b = static_cast<std::uint8_t>(rng());
  for (int i = 0; i < 5000; ++i) {
    const std::string word = "point " + std::to_string(rng() % 300) + " ";
    text.insert(text.end(), word.begin(), word.end());
  }
  inputs.push_back(noise);
  inputs.push_back(text);
  for (const auto& in : inputs) {
    const auto packed = lzf::compress(in.data(), in.size());
    EXPECT_LE(packed.size(), in.size() + in.size() / 32 + 1);
    const auto out = lzf::decompress(packed.data(), packed.size(), in.size());
    ASSERT_TRUE(out.has_value()) << in.size();
    EXPECT_EQ(*out, in);
    if (in.size() > 1) {
      EXPECT_FALSE(lzf::decompress(packed.data(), packed.size() - 1, in.size()));
      EXPECT_FALSE(lzf::decompress(packed.data(), packed.size(), in.size() - 1));
    }
  }
  EXPECT_LT(lzf::compress(inputs[2].data(), inputs[2].size()).size(), 100000u / 80);
  // A back reference before the start of the output.
  const std::uint8_t bad[] = {0x00, 'a', 0x20, 0x05};
  EXPECT_FALSE(lzf::decompress(bad, sizeof(bad), 4));
}

// A header written by hand: v0.6 (no VIEWPOINT), padding, COUNT > 1, rgba, integer and double
// fields, an organised 2x2 cloud with a NaN point.
std::string handmade_header(const std::string& data) {
  return "# old\nVERSION .6\nFIELDS x y z _ rgba fpfh intensity ring normal_x normal_y normal_z t\n"
         "SIZE 4 4 4 1 4 4 2 1 4 4 4 8\nTYPE F F F U U F U I F F F F\n"
         "COUNT 1 1 1 3 1 2 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 2\nPOINTS 4\nDATA " + data + "\n";
}

TEST(Pcd, ReadsOldHeadersPaddingCountsAndOrganisedClouds) {
  const fs::path dir = scratch_dir();
  std::string bin = handmade_header("binary");
  std::string ascii = handmade_header("ascii");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < 4; ++i) {
    const float x = i == 3 ? nan : 0.5f * i;
    const std::uint32_t rgba = 0xff000000u | (10u * i << 16) | (20u * i << 8) | (30u * i);
    put(bin, x); put(bin, 1.0f); put(bin, -2.0f);
    bin.append(3, '\x7f');
    put(bin, rgba); put(bin, 9.0f); put(bin, 8.0f);
    put<std::uint16_t>(bin, static_cast<std::uint16_t>(1000 * i));
    put<std::int8_t>(bin, static_cast<std::int8_t>(-i));
    put(bin, 0.0f); put(bin, 0.0f); put(bin, 1.0f);
    put(bin, 1e300 * i);
    ascii += (i == 3 ? std::string("nan") : std::to_string(0.5 * i)) + " 1 -2 0 0 0 " +
             std::to_string(rgba) + " 9 8 " + std::to_string(1000 * i) + " " + std::to_string(-i) +
             " 0 0 1 " + (i ? "1e300" : "0") + "\n";
  }
  for (const std::string& file : {bin, ascii}) {
    write_bytes(dir / "h.pcd", file);
    const PointCloud c = read_pcd(dir / "h.pcd");
    ASSERT_EQ(c.size(), 4u);
    EXPECT_EQ(c.positions[2], Eigen::Vector3f(1.0f, 1.0f, -2.0f));
    EXPECT_TRUE(std::isnan(c.positions[3].x()));  // organised clouds keep NaN points
    EXPECT_EQ(c.colors[1], (Rgb8{10, 20, 30}));
    EXPECT_EQ(c.normals[3], Eigen::Vector3f::UnitZ());
    // "_" padding and the COUNT 2 descriptor are not scalars.
    ASSERT_EQ(c.scalars.size(), 3u);
    EXPECT_EQ(c.find_scalar("intensity")->values[3], 3000.0f);
    EXPECT_EQ(c.find_scalar("ring")->values[2], -2.0f);
    EXPECT_TRUE(std::isinf(c.find_scalar("t")->values[1]));  // double 1e300 -> float inf
  }
}

TEST(Pcd, AsciiColourAsIntegerOrFloatBits) {
  const fs::path dir = scratch_dir();
  // PCL writes the integer 0x00ff8000, Open3D the float whose bits it is.
  const float bits = std::bit_cast<float>(0x00ff8000u);
  char text[32];
  const std::string as_float(text, std::to_chars(text, text + sizeof(text), bits, std::chars_format::scientific, 9).ptr);
  for (const std::string& v : {std::string("16744448"), as_float}) {
    write_bytes(dir / "c.pcd", "VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\n"
                               "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3 " + v + "\n");
    const PointCloud c = read_pcd(dir / "c.pcd");
    EXPECT_EQ(c.colors.at(0), (Rgb8{255, 128, 0})) << v;
  }
}

TEST(Pcd, BadInputNamesFileAndLine) {
  const fs::path dir = scratch_dir();
  const fs::path f = dir / "bad.pcd";
  const std::string fields = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  const std::string head2 = fields + "WIDTH 2\nHEIGHT 1\nPOINTS 2\n";
  std::string compressed = head2 + "DATA binary_compressed\n";
  put<std::uint32_t>(compressed, 4);
  put<std::uint32_t>(compressed, 24);
  compressed += std::string("\x00\x41\x20\x05", 4);  // a literal, then a reference out of range
  struct Case {
    const char* what;
    std::string bytes;
    std::string expect;
  };
  const std::vector<Case> cases = {
      {"points mismatch", fields + "WIDTH 2\nHEIGHT 2\nPOINTS 5\nDATA ascii\n",
       "WIDTH 2 x HEIGHT 2 does not match POINTS 5"},
      {"size count", "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n", ":2: SIZE lists 2 values for 3"},
      {"bad type size", "FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nDATA ascii\n", ":3: field 'z' has TYPE F SIZE 2"},
      {"unknown data", head2 + "DATA zip\n", ":9: unknown DATA encoding 'zip'"},
      {"unknown keyword", "VERSION 0.7\nFELDS x y z\n", ":2: unknown PCD header keyword 'FELDS'"},
      {"version", "VERSION 0.9\n", ":1: unsupported PCD VERSION"},
      {"no data", head2, "no DATA line"},
      {"no xyz", "FIELDS x y\nSIZE 4 4\nTYPE F F\nWIDTH 1\nDATA ascii\n1 2\n", "no x, y and z"},
      {"not a number", head2 + "DATA ascii\n1 2 3\n1 2 drei\n", ":11: 'drei' is not a number"},
      {"too few values", head2 + "DATA ascii\n1 2 3\n1 2\n", ":11: point 1 has 2 values, expected 3"},
      {"too many values", head2 + "DATA ascii\n1 2 3 4\n", ":10: point 0 has more than 3 values"},
      {"too few points", head2 + "DATA ascii\n1 2 3\n", "file ends after 1 of 2 points"},
      {"too many points", head2 + "DATA ascii\n1 2 3\n1 2 3\n1 2 3\n", ":12: more than the 2 points"},
      {"truncated binary", head2 + "DATA binary\n" + std::string(20, '\0'), "binary body is truncated"},
      {"trailing binary", head2 + "DATA binary\n" + std::string(28, '\0'), "4 bytes follow the last point"},
      {"truncated compressed", head2 + "DATA binary_compressed\n\x10", "no size words"},
      {"corrupt compressed", compressed, "corrupt"},
  };
  for (const auto& c : cases) {
    write_bytes(f, c.bytes);
    const std::string msg = error_of([&] { read_pcd(f); });
    EXPECT_EQ(msg.rfind(f.string(), 0), 0u) << c.what << ": " << msg;
    EXPECT_NE(msg.find(c.expect), std::string::npos) << c.what << ": " << msg;
  }
  EXPECT_NE(error_of([&] { read_pcd(dir); }).find("is a folder"), std::string::npos);
  // A real compressed file cut short.
  write_pcd(dir / "ok.pcd", random_cloud(100, 2), PcdEncoding::BinaryCompressed);
  std::string cut = read_bytes(dir / "ok.pcd");
  cut.resize(cut.size() - 10);
  write_bytes(f, cut);
  EXPECT_NE(error_of([&] { read_pcd(f); }).find("truncated"), std::string::npos);
}

TEST(Pcd, FailedWriteLeavesNoFile) {
  const fs::path dir = scratch_dir();
  PointCloud cloud = random_cloud(10, 3);
  cloud.normals.pop_back();
  for (PcdEncoding enc : {PcdEncoding::Binary, PcdEncoding::BinaryCompressed, PcdEncoding::Ascii}) {
    try {
      write_pcd(dir / "c.pcd", cloud, enc);
      ADD_FAILURE() << "no throw";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("c.pcd: cannot write: point cloud has 10 positions but 9 normals"),
                std::string::npos)
          << e.what();
    }
  }
  cloud = random_cloud(10, 3);
  cloud.scalars[1].values.resize(11);
  EXPECT_THROW(write_pcd(dir / "c.pcd", cloud), Error);
  EXPECT_EQ(list_folder(dir), "");
}

}  // namespace
}  // namespace locard
