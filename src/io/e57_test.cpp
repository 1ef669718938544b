#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/io/e57.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/point_cloud_io.hpp>

#include "io/e57_detail.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <numeric>
#include <random>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;
using test::list_folder;
using test::scratch_dir;
using test::shared_data;

fs::path samples() { return shared_data() / "e57-samples"; }

template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no InputError";
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

struct Bounds {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(INFINITY);
  Eigen::Vector3f hi = Eigen::Vector3f::Constant(-INFINITY);
};

Bounds bounds_of(const PointCloud& c) {
  Bounds b;
  for (const auto& p : c.positions) {
    b.lo = b.lo.cwiseMin(p);
    b.hi = b.hi.cwiseMax(p);
  }
  return b;
}

Eigen::Vector3d mean_color(const PointCloud& c) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Rgb8& rgb : c.colors) sum += Eigen::Vector3d(rgb.r, rgb.g, rgb.b);
  return sum / static_cast<double>(c.colors.size());
}

// ---- the sample files: counts and fields as their SOURCE.md states them ----

TEST(E57, ReadsRealPumpRoomScanWithColourIntensityAndImageNote) {
  const E57File file = read_e57(samples() / "pumpA-visual-reference" / "pumpAVisualReferenceImage.e57");
  ASSERT_EQ(file.scans.size(), 1u);
  const E57Scan& scan = file.scans[0];
  EXPECT_EQ(scan.name, "pumpA");
  EXPECT_EQ(scan.guid, "{116B6772-AC46-41B3-B70C-0C63CC671447}");
  EXPECT_EQ(file.guid, "{4F947749-517F-49D1-9AD9-A899110EFFDD}");
  EXPECT_EQ(scan.record_count, 155201u);
  ASSERT_EQ(scan.cloud.size(), 155201u);  // every record has cartesianInvalidState 0
  EXPECT_EQ(scan.fields.coordinates, E57Coordinates::Cartesian);
  EXPECT_TRUE(scan.fields.color && scan.fields.intensity && scan.fields.row_column);
  EXPECT_FALSE(scan.has_pose);
  EXPECT_TRUE(scan.T_file_scan.matrix().isIdentity(0.0));
  // The XML's cartesianBounds, to the 1 um step of the 24-bit scaled integers (and float).
  const Bounds b = bounds_of(scan.cloud);
  EXPECT_NEAR(b.lo.x(), -2.903764, 2e-6);
  EXPECT_NEAR(b.hi.x(), 1.721604, 2e-6);
  EXPECT_NEAR(b.lo.y(), -5.301103, 2e-6);
  EXPECT_NEAR(b.hi.y(), -0.792647, 2e-6);
  EXPECT_NEAR(b.lo.z(), -1.899705, 2e-6);
  EXPECT_NEAR(b.hi.z(), 1.843003, 2e-6);
  // Real, dark colours: mean RGB about 32/38/26.
  const Eigen::Vector3d rgb = mean_color(scan.cloud);
  EXPECT_NEAR(rgb.x(), 32, 1.5);
  EXPECT_NEAR(rgb.y(), 38, 1.5);
  EXPECT_NEAR(rgb.z(), 26, 1.5);
  // Intensity 0..32767 x 3.05e-5 over limits 0..1: about 0.38..0.70.
  const ScalarField* intensity = scan.cloud.find_scalar("intensity");
  ASSERT_NE(intensity, nullptr);
  const auto [lo, hi] = std::minmax_element(intensity->values.begin(), intensity->values.end());
  EXPECT_NEAR(*lo, 0.38, 0.02);
  EXPECT_NEAR(*hi, 0.70, 0.02);
  EXPECT_EQ(file.notes, std::vector<std::string>{"images2D: 1 image (3072x2304 JPEG) not read"});
}

TEST(E57, ReadsBunnyOnTheStanfordReconstruction) {
  const E57File file = read_e57(samples() / "bunny-reference" / "bunnyDouble.e57");
  ASSERT_EQ(file.scans.size(), 1u);
  const E57Scan& scan = file.scans[0];
  EXPECT_EQ(scan.name, "bunny");
  ASSERT_EQ(scan.cloud.size(), 30571u);
  EXPECT_TRUE(scan.fields.invalid_state);
  EXPECT_FALSE(scan.cloud.has_colors());
  EXPECT_TRUE(scan.cloud.scalars.empty());
  EXPECT_TRUE(file.notes.empty());
  const Bounds b = bounds_of(scan.cloud);  // the XML's cartesianBounds
  EXPECT_NEAR(b.lo.x(), -0.094689, 1e-7);
  EXPECT_NEAR(b.hi.y(), 0.187321, 1e-7);
  EXPECT_NEAR(b.lo.z(), -0.061873, 1e-7);
  // The same bunny as the Stanford zippered reconstruction, in the same frame: nearly every
  // point lies on a reconstruction vertex's neighbourhood (the mesh is ~0.5 mm apart).
  const PointCloud reference =
      read_ply(shared_data() / "stanford-bunny" / "bunny" / "reconstruction" / "bun_zipper.ply");
  const KdTree tree(reference.positions);
  const auto nearest = tree.nearest_batch(scan.cloud.positions, 0.002f);
  const auto close = std::count_if(nearest.begin(), nearest.end(), [](const Neighbor& n) {
    return n.squared_distance <= 0.001f * 0.001f;
  });
  EXPECT_GT(static_cast<double>(close) / scan.cloud.size(), 0.95);
}

TEST(E57, ReadsFaroSubsampleWithColour) {
  const E57File file = read_e57(samples() / "faro-subsample-rgb" / "tinyCartesianFloatRgb.e57");
  ASSERT_EQ(file.scans.size(), 1u);
  const PointCloud& cloud = file.scans[0].cloud;
  EXPECT_EQ(file.scans[0].name, "exp2.fls.subsampled");
  ASSERT_EQ(cloud.size(), 2090u);
  ASSERT_TRUE(cloud.has_colors());
  EXPECT_TRUE(cloud.scalars.empty());
  const Eigen::Vector3d rgb = mean_color(cloud);  // about 131/121/113
  EXPECT_NEAR(rgb.x(), 131, 1.5);
  EXPECT_NEAR(rgb.y(), 121, 1.5);
  EXPECT_NEAR(rgb.z(), 113, 1.5);
  const Bounds b = bounds_of(cloud);  // single floats, so the XML bounds exactly
  EXPECT_EQ(b.lo.x(), -9.7795295715332031f);
  EXPECT_EQ(b.hi.z(), 298.53216552734375f);
}

TEST(E57, ReadsTwoScansOfOneFile) {
  const fs::path path = samples() / "pdal-two-scans" / "A_B.e57";
  const E57File file = read_e57(path);
  ASSERT_EQ(file.scans.size(), 2u);
  EXPECT_EQ(file.scans[0].name, "B2 - Cloud");
  EXPECT_EQ(file.scans[1].name, "A4 - Cloud");
  ASSERT_EQ(file.scans[0].cloud.size(), 2u);
  ASSERT_EQ(file.scans[1].cloud.size(), 4u);
  for (const E57Scan& scan : file.scans) {
    EXPECT_TRUE(scan.cloud.has_colors());
    const ScalarField* intensity = scan.cloud.find_scalar("intensity");
    ASSERT_NE(intensity, nullptr);
    // Each scan's own limits (0..0.87 and 0..257.9) map its intensities onto 0..1.
    EXPECT_EQ(*std::max_element(intensity->values.begin(), intensity->values.end()), 1.0f);
    EXPECT_EQ(*std::min_element(intensity->values.begin(), intensity->values.end()), 0.0f);
  }
  EXPECT_EQ(file.scans[0].cloud.colors[0], (Rgb8{255, 255, 0}));
  EXPECT_EQ(file.scans[1].cloud.colors[0], (Rgb8{0, 255, 0}));
  EXPECT_EQ(file.scans[0].cloud.positions[0], Eigen::Vector3f(-42.6394997f, 1.87259996f, 0.666700006f));
  const PointCloud merged = read_point_cloud(path);
  EXPECT_EQ(merged.size(), 6u);
  EXPECT_TRUE(merged.has_colors());
  EXPECT_NE(merged.find_scalar("intensity"), nullptr);
}

TEST(E57, SphericalRecordsBecomeCartesianAndInvalidOnesAreDropped) {
  const E57File file = read_e57(samples() / "synthetic-edge-cases" / "tiny_spherical.e57");
  ASSERT_EQ(file.scans.size(), 1u);
  const E57Scan& scan = file.scans[0];
  EXPECT_EQ(scan.fields.coordinates, E57Coordinates::Spherical);
  EXPECT_EQ(scan.record_count, 360u);
  ASSERT_EQ(scan.cloud.size(), 180u);  // the 180 records with state 1 (direction only) dropped
  for (const auto& p : scan.cloud.positions) EXPECT_NEAR(p.norm(), 1.0, 1e-6);  // range 1.0
  EXPECT_EQ(scan.cloud.positions[0], Eigen::Vector3f(1, 0, 0));  // azimuth 0, elevation 0
}

TEST(E57, PoseWithTranslationButNoRotationIsATranslation) {
  const fs::path path = samples() / "synthetic-edge-cases" / "translationWithoutRotation.e57";
  const E57File file = read_e57(path);
  ASSERT_EQ(file.scans.size(), 1u);
  const E57Scan& scan = file.scans[0];
  EXPECT_TRUE(scan.has_pose);
  EXPECT_TRUE(scan.T_file_scan.linear().isIdentity(0.0));
  EXPECT_EQ(scan.T_file_scan.translation(), Eigen::Vector3d(4, 5, 6));
  ASSERT_EQ(scan.cloud.size(), 4u);
  const Bounds local = bounds_of(scan.cloud);
  EXPECT_EQ(local.lo, Eigen::Vector3f(0, 0, 0));
  EXPECT_EQ(local.hi, Eigen::Vector3f(1, 1, 0));
  const Bounds world = bounds_of(read_e57_merged(path));  // the XML's cartesianBounds
  EXPECT_EQ(world.lo, Eigen::Vector3f(4, 5, 6));
  EXPECT_EQ(world.hi, Eigen::Vector3f(5, 6, 6));
}

// ---- round trips ----

E57Scan random_scan(std::size_t n, unsigned seed, bool colors, bool intensity) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_int_distribution<int> byte(0, 255);
  E57Scan scan;
  scan.name = "scan " + std::to_string(seed) + " <&>";  // XML special characters survive
  for (std::size_t i = 0; i < n; ++i) {
    scan.cloud.positions.emplace_back(u(rng), u(rng) * 1e-3f, u(rng) * 1e3f);
    if (colors)
      scan.cloud.colors.push_back({static_cast<std::uint8_t>(byte(rng)),
                                   static_cast<std::uint8_t>(byte(rng)),
                                   static_cast<std::uint8_t>(byte(rng))});
  }
  if (!scan.cloud.empty()) scan.cloud.positions[0] = {-0.0f, 1e-30f, 3.4e38f};
  if (intensity) {
    ScalarField f{"intensity", {}};
    for (std::size_t i = 0; i < n; ++i) f.values.push_back(unit(rng));
    scan.cloud.scalars.push_back(std::move(f));
  }
  const Eigen::Quaterniond q = Eigen::Quaterniond::UnitRandom();  // Eigen's rand(): fixed seed
  scan.T_file_scan.linear() = q.toRotationMatrix();
  scan.T_file_scan.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 100.0;
  scan.has_pose = true;
  return scan;
}

void expect_bit_identical(const PointCloud& a, const PointCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  if (!a.empty()) {  // bits, so -0.0 and NaN payloads count too
    EXPECT_EQ(0, std::memcmp(a.positions.data(), b.positions.data(), a.size() * 12));
  }
  EXPECT_EQ(a.colors, b.colors);
  EXPECT_EQ(a.scalars, b.scalars);
}

TEST(E57, MultiScanRoundTripIsBitIdenticalAndKeepsPoses) {
  const fs::path dir = scratch_dir();
  std::vector<E57Scan> scans = {random_scan(100000, 1, true, true),  // ~23 packets, many pages
                                random_scan(7, 2, false, true), random_scan(0, 3, true, false),
                                random_scan(3001, 4, true, false)};
  scans[1].has_pose = false;
  scans[1].T_file_scan = Isometry3d::Identity();
  scans[0].guid = "{00000000-0000-4000-8000-000000000001}";
  write_e57(dir / "multi.e57", scans,
            {.guid = "{00000000-0000-4000-8000-0000000000ff}", .creation_gps_time = {}});
  const E57File back = read_e57(dir / "multi.e57");
  EXPECT_EQ(back.guid, "{00000000-0000-4000-8000-0000000000ff}");
  EXPECT_TRUE(back.notes.empty());
  ASSERT_EQ(back.scans.size(), scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    SCOPED_TRACE("scan " + std::to_string(i));
    EXPECT_EQ(back.scans[i].name, scans[i].name);
    EXPECT_EQ(back.scans[i].has_pose, scans[i].has_pose);
    expect_bit_identical(back.scans[i].cloud, scans[i].cloud);
    // The rotation goes through a quaternion: equal to rounding; the translation exactly.
    EXPECT_LT((back.scans[i].T_file_scan.linear() - scans[i].T_file_scan.linear()).cwiseAbs().maxCoeff(),
              1e-15);
    EXPECT_EQ(back.scans[i].T_file_scan.translation(), scans[i].T_file_scan.translation());
    EXPECT_EQ(back.scans[i].guid.size(), 38u);  // "{8-4-4-4-12}"
  }
  EXPECT_EQ(back.scans[0].guid, scans[0].guid);
  EXPECT_NE(back.scans[1].guid, back.scans[2].guid);  // fresh guids differ
  // Merged: each scan moved by its pose; attributes kept only where every scan has them.
  const PointCloud merged = read_e57_merged(dir / "multi.e57");
  ASSERT_EQ(merged.size(), 100000u + 7u + 3001u);
  EXPECT_FALSE(merged.has_colors());  // scan 1 has none
  const Eigen::Vector3f expected =
      (scans[3].T_file_scan * scans[3].cloud.positions[5].cast<double>()).cast<float>();
  EXPECT_LT((merged.positions[100007 + 5] - expected).norm(), 1e-3f);
  EXPECT_EQ(list_folder(dir), "multi.e57\n");
}

TEST(E57, SameScansAndGuidsGiveTheSameBytes) {
  const fs::path dir = scratch_dir();
  std::vector<E57Scan> scans = {random_scan(5000, 7, true, true)};
  scans[0].guid = "{11111111-2222-4333-8444-555555555555}";
  const E57WriteOptions options{.guid = "{aaaaaaaa-2222-4333-8444-555555555555}",
                                .creation_gps_time = 1.4e9};
  write_e57(dir / "a.e57", scans, options);
  write_e57(dir / "b.e57", scans, options);
  EXPECT_EQ(read_bytes(dir / "a.e57"), read_bytes(dir / "b.e57"));
}

TEST(E57, IntensityOutsideZeroToOneIsNormalisedOnRead) {
  const fs::path dir = scratch_dir();
  E57Scan scan = random_scan(10, 9, false, true);
  for (float& v : scan.cloud.scalars[0].values) v *= 200.0f;  // limits become 0..max
  write_e57(dir / "i.e57", {scan});
  const PointCloud back = read_e57(dir / "i.e57").scans[0].cloud;
  const auto& in = scan.cloud.scalars[0].values;
  const float max = *std::max_element(in.begin(), in.end());
  for (std::size_t i = 0; i < in.size(); ++i)
    EXPECT_FLOAT_EQ(back.scalars[0].values[i], in[i] / max);
}

TEST(E57, PointCloudIoWritesOneScanAndReadsItBack) {
  const fs::path dir = scratch_dir();
  const PointCloud cloud = random_scan(2000, 11, true, true).cloud;
  write_point_cloud(dir / "c.E57", cloud);
  expect_bit_identical(read_point_cloud(dir / "c.E57"), cloud);
  const E57File file = read_e57(dir / "c.E57");
  ASSERT_EQ(file.scans.size(), 1u);
  EXPECT_EQ(file.scans[0].name, "c");
  EXPECT_FALSE(file.scans[0].has_pose);
  EXPECT_NE(error_of([&] { write_point_cloud(dir / "d.e57", cloud, {.ascii = true, .compressed = false}); })
                .find("E57 is binary only"),
            std::string::npos);
}

TEST(E57, MismatchedAttributesAreRefusedAndLeaveNoFile) {
  const fs::path dir = scratch_dir();
  E57Scan scan = random_scan(10, 12, true, false);
  scan.cloud.colors.pop_back();
  EXPECT_NE(error_of([&] { write_e57(dir / "bad.e57", {scan}); }).find("9 colours"),
            std::string::npos);
  EXPECT_EQ(list_folder(dir), "");
}

// ---- bad input: a clear InputError, never a crash ----

// The file's logical bytes (CRCs stripped) edited by `edit`, then paginated again with valid
// CRCs, so the damage reaches the layers above the pages. Our writer puts the XML last, so an
// edit that changes its length only moves the header's XML length and file length.
std::string edited(const fs::path& path, const std::function<void(std::string&)>& edit) {
  const e57_detail::LogicalFile file = e57_detail::load_logical_file(path);
  const std::size_t xml_end =
      static_cast<std::size_t>(e57_detail::to_logical(file, file.header.xml_offset, "test") +
                               file.header.xml_length);
  std::string bytes(file.bytes.begin(), file.bytes.begin() + xml_end);
  edit(bytes);
  auto* header = reinterpret_cast<std::uint8_t*>(bytes.data());
  if (bytes.size() != xml_end &&
      e57_detail::load_le<std::uint64_t>(header + 32) == file.header.xml_length) {
    e57_detail::store_le<std::uint64_t>(header + 32, file.header.xml_length + bytes.size() - xml_end);
    e57_detail::store_le<std::uint64_t>(header + 16, (bytes.size() + 1019) / 1020 * 1024);
  }
  const std::vector<std::uint8_t> pages =
      e57_detail::paginate(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  return std::string(pages.begin(), pages.end());
}

void replace_once(std::string& s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  s.replace(at, from.size(), to);
}

class E57BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = scratch_dir();
    good_ = dir_ / "good.e57";
    write_e57(good_, {random_scan(3000, 21, true, true)});
    bytes_ = read_bytes(good_);
  }
  std::string error_for(const std::string& bytes) {
    write_bytes(dir_ / "bad.e57", bytes);
    return error_of([&] { read_e57(dir_ / "bad.e57"); });
  }
  fs::path dir_, good_;
  std::string bytes_;
};

TEST_F(E57BadInput, FlippedByteIsACrcErrorNamingThePage) {
  std::string bytes = bytes_;
  bytes[2 * 1024 + 100] ^= 0x10;
  const std::string e = error_for(bytes);
  EXPECT_NE(e.find("bad.e57: page 2 (bytes 2048..3071): CRC-32C mismatch"), std::string::npos) << e;
}

TEST_F(E57BadInput, TruncatedFileSaysSo) {
  EXPECT_NE(error_for(bytes_.substr(0, bytes_.size() - 1024)).find("(truncated)"), std::string::npos);
  EXPECT_NE(error_for(bytes_.substr(0, 1500)).find("(truncated)"), std::string::npos);
  EXPECT_NE(error_for(bytes_.substr(0, 20)).find("too short for the 48-byte E57 header"),
            std::string::npos);
  EXPECT_NE(error_for("ply\nformat ascii 1.0\n" + std::string(1024, ' ')).find("not an E57 file"),
            std::string::npos);
}

TEST_F(E57BadInput, LyingCountsAndOffsetsAreRefused) {
  // More records than the packets hold.
  std::string e = error_for(edited(good_, [](std::string& s) {
    replace_once(s, "recordCount=\"3000\"", "recordCount=\"3900\"");
  }));
  EXPECT_NE(e.find("<e57Root/data3D[0]/points>: the section ends before the data of recordCount "
                   "3900"),
            std::string::npos)
      << e;
  // A count no section could hold is refused before anything is sized from it.
  e = error_for(edited(good_, [](std::string& s) {
    replace_once(s, "recordCount=\"3000\"", "recordCount=\"9e99\"");
  }));
  EXPECT_NE(e.find("not a valid number"), std::string::npos) << e;
  e = error_for(edited(good_, [](std::string& s) {
    replace_once(s, "recordCount=\"3000\"", "recordCount=\"9999999999999999\"");
  }));
  EXPECT_NE(e.find("cannot fit"), std::string::npos) << e;
  // Offsets into a CRC, past the end; a section length past the end.
  e = error_for(edited(good_, [](std::string& s) {
    replace_once(s, "fileOffset=\"48\"", "fileOffset=\"1022\"");
  }));
  EXPECT_NE(e.find("points into a page's CRC"), std::string::npos) << e;
  e = error_for(edited(good_, [](std::string& s) {
    replace_once(s, "fileOffset=\"48\"", "fileOffset=\"99999999\"");
  }));
  EXPECT_NE(e.find("past the end of the file"), std::string::npos) << e;
  e = error_for(edited(good_, [](std::string& s) { s[48 + 8 + 5] = 0x7f; }));
  EXPECT_NE(e.find("past the end of the file"), std::string::npos) << e;
  // Packets that lie about their bytestreams.
  e = error_for(edited(good_, [](std::string& s) { s[48 + 32 + 4] = 9; }));
  EXPECT_NE(e.find("has 9 bytestreams, the prototype has 7 fields"), std::string::npos) << e;
  e = error_for(edited(good_, [](std::string& s) { s[48 + 32] = 7; }));
  EXPECT_NE(e.find("unknown type 7"), std::string::npos) << e;
  // XML that does not parse, or is not E57.
  e = error_for(edited(good_, [](std::string& s) { replace_once(s, "</e57Root>", "</e57Rooo>"); }));
  EXPECT_NE(e.find("not well-formed XML"), std::string::npos) << e;
  e = error_for(edited(good_, [](std::string& s) {
    replace_once(s, "type=\"Integer\" minimum=\"0\" maximum=\"255\"",
                 "type=\"Integer\" minimum=\"9\" maximum=\"255\"");
  }));
  EXPECT_EQ(e, "no InputError");  // a different minimum is legal: colours shift, nothing breaks
}

// Bytes set at random in the logical file (CRCs made valid again): each read either succeeds
// or throws InputError; under ASan/UBSan this also shows no out-of-bounds access. Returns how
// many reads threw.
int damage_and_read(const fs::path& good, const fs::path& bad, int trials, unsigned seed) {
  std::mt19937 rng(seed);
  const std::size_t logical_size = fs::file_size(good) / 1024 * 1020;
  std::uniform_int_distribution<std::size_t> at(0, logical_size - 1);
  std::uniform_int_distribution<int> value(0, 255);
  int errors = 0;
  for (int trial = 0; trial < trials; ++trial) {
    write_bytes(bad, edited(good, [&](std::string& s) {
      // Half the trials hit the header, section header and first packet, where lengths live.
      for (int k = 0; k < 1 + trial % 4; ++k) {
        const std::size_t i = trial % 2 ? at(rng) % 200 : at(rng) % s.size();
        s[i] = static_cast<char>(value(rng));
      }
    }));
    try {
      read_e57(bad);
    } catch (const InputError&) {
      ++errors;
    }
  }
  return errors;
}

TEST_F(E57BadInput, RandomDamageNeverCrashes) {
  EXPECT_GT(damage_and_read(good_, dir_ / "bad.e57", 300, 57), 50);
  // Bit-packed fields of 1 to 24 bits (bunny: 1-bit invalid state; pump room: 24-bit
  // coordinates, 15-bit intensity, 11/9-bit row/column): damage reaches the unpacker.
  damage_and_read(samples() / "bunny-reference" / "bunnyDouble.e57", dir_ / "bad.e57", 60, 58);
  damage_and_read(samples() / "pumpA-visual-reference" / "pumpAVisualReferenceImage.e57",
                  dir_ / "bad.e57", 30, 59);
  // Every truncation at a page boundary, and a few inside pages.
  for (std::size_t size = 0; size < bytes_.size(); size += size < 2048 ? 97 : 1024)
    EXPECT_NE(error_for(bytes_.substr(0, size)), "no InputError") << size;
}

}  // namespace
}  // namespace locard
